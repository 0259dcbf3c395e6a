"""Parameters: params.toml's names, ``NAME=VALUE`` strings as ``--set`` takes them, and what
each means with its paper symbol."""

from __future__ import annotations

import json
import numbers
from typing import Any, Dict, List, Mapping

from . import _mvscope as _native
from .errors import ParameterError

#: The main parameters with their symbols in the papers (ACMM: Xu & Tao, CVPR 2019; the planar
#: prior: ACMP, AAAI 2020). Every name of params.toml is accepted; ``default_params()`` lists
#: them all with their defaults, and docs/commands.md describes each.
SYMBOLS: Dict[str, str] = {
    "tau0": "τ0: initial good-matching-cost threshold, τ(t) = τ0·exp(-t²/α) (Sec. 4.3)",
    "tau1": "τ1: fixed bad-matching-cost threshold, τ1 > τ(t) (Sec. 4.3)",
    "alpha": "α: how fast τ(t) decays with the iteration t (Sec. 4.3)",
    "beta": "β: confidence C(m) = exp(-m²/(2β²)) of a view's costs (Sec. 4.3)",
    "n1": "n1: a view is selected when more than n1 of the 8 costs are below τ(t)",
    "n2": "n2: ... and fewer than n2 are above τ1",
    "top_k": "K: the initial cost is the mean of the K best per-view costs (Sec. 4.1)",
    "window_radius": "half size of the matching window (5: 11x11)",
    "window_step": "sample every window_step-th row and column of the window",
    "sigma_spatial": "σs: spatial spread of the bilateral NCC weight, pixels",
    "sigma_color": "σc: intensity spread of the bilateral NCC weight, grey levels",
    "scales": "k: number of scales of the pyramid (Sec. 5)",
    "eta": "η: downsampling factor between scales (Sec. 5)",
    "lambda": "λ: weight of the reprojection error in m_geo = m + λ·min(Δe, δ) (Sec. 5.1)",
    "delta": "δ: truncation of the forward-backward reprojection error, pixels (Sec. 5.1)",
    "xi": "ξ: the detail restorer replaces a pixel where C_init − C_photo > ξ (Sec. 5.2)",
    "restorer": "how the detail restorer runs: refine (default), gated or random (Sec. 5.2)",
    "geometric_passes": "geometric consistency passes per scale (the paper: 2)",
    "median_radius": "half size of the final median filter on depth (2: 5x5)",
    "prior_gamma": "γ: floor of the planar prior's factor γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²)",
    "prior_beta": "β of the prior-weighted score exp(−m²/β)·(γ + ...) (ACMP)",
    "prior_sigma_depth": "σd as a share of the view's depth range (ACMP)",
    "prior_sigma_normal": "σθ: spread of the angle to the prior's normal, degrees (ACMP)",
    "fusion_reprojection": "ψ: largest reprojection error of a consistent match, pixels (Sec. 6)",
    "fusion_relative_depth": "ε: largest relative depth difference of a consistent match",
    "fusion_normal_angle": "θ: largest angle between consistent normals, degrees (Sec. 6)",
    "fusion_min_views": "n: consistent source views a depth needs to become a point",
    "seed": "seed of every random number (initialisation, refinement)",
}


def value_text(name: str, value: Any) -> str:
    """``value`` as ``--set NAME=VALUE`` writes it (booleans lower case, floats in their
    shortest round-trip form)."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    if isinstance(value, str):
        return value
    raise ParameterError(
        f"{name}={value!r}: a parameter's value is a number, a bool or a string"
    )


#: Python keywords cannot be keyword arguments: ``s.set(lambda_=0.3)`` sets λ.
ALIASES: Dict[str, str] = {"lambda_": "lambda"}


def to_sets(params: Mapping[str, Any]) -> List[str]:
    """A dict of parameters as ``NAME=VALUE`` strings (``lambda_`` for ``lambda``)."""
    if not isinstance(params, Mapping):
        raise ParameterError(
            f"params={params!r}: give a dict of params.toml names, e.g. {{'tau0': 0.7}}"
        )
    sets = []
    for name, value in params.items():
        name = ALIASES.get(name, name)
        sets.append(f"{name}={value_text(name, value)}")
    return sets


def default_params(method: str = "acmm") -> Dict[str, Any]:
    """Every parameter with ``method``'s default, by params.toml's names (a new dict each
    call). The methods share their defaults except Regions, which turns its ten options
    on (``prior_regions``, ``prior_flat_points``, ``prior_confirmed_points``,
    ``prior_confidence_score``, ``prior_flat_ramp``, ``prior_extend``,
    ``prior_keep_unseen``, ``prior_region_cover_seen``, ``prior_region_edge``,
    ``prior_flat_noise``), sets ``prior_region_cover_band = 3`` and weighs its matching
    windows by the adaptive bilateral form (``bilateral_kernel = "adaptive"``)."""
    return json.loads(_native.default_params_json(method))


def check_params(params: Mapping[str, Any], method: str = "acmm") -> Dict[str, Any]:
    """``method``'s defaults with ``params`` applied, checked as ``--set`` checks them (an
    unknown name or a value out of range raises :class:`ParameterError`)."""
    return json.loads(_native.params_json_with(to_sets(params), method))
