"""Evaluation against ground truth: the numbers of ``mvscope eval``."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _mvscope as _native

__all__ = ["evaluate", "DepthReport", "DepthScore"]


@dataclass(frozen=True)
class DepthScore:
    """The scores of one view (or of all views' pixels pooled: ``view`` None).

    Attributes:
        view: the view's index in the scene on disk (None for the pooled scores).
        pixels: ground-truth pixels evaluated.
        absolute: threshold (scene units) -> share of ground-truth pixels within it.
        relative: threshold (e.g. 0.02 for 2%) -> share within it; a missing estimate counts
            as a miss.
        low_texture: the same on the weak-texture mask, where the ground truth has one.
        median_relative_error: median |d − gt| / gt over the pixels with an estimate.
        median_ratio: median d / gt over the same pixels: 1 where the estimate has the
            truth's scale; most views more than 5% off the same way points at the cameras
            or the truth, not the method (the table then says so).
        scale_free: the relative shares with the estimate divided by its view's
            median_ratio (pooled: each view by its own), ``{"relative": {t: share},
            "low_texture": {t: share} or None}``; None where the view has no estimate.
    """

    view: Optional[int]
    pixels: int
    absolute: Dict[float, float]
    relative: Dict[float, float]
    low_texture: Optional[Dict[float, float]]
    median_relative_error: float
    median_ratio: float
    scale_free: Optional[Dict[str, Optional[Dict[float, float]]]] = None

    def within(self, relative: float = 0.02) -> float:
        """The share within ``relative`` (one of the thresholds evaluated)."""
        for t, v in self.relative.items():
            if abs(t - relative) < 1e-12:
                return v
        raise KeyError(
            f"within({relative}): evaluated at {sorted(self.relative)}; pass rel=[...]"
        )


def _score(d: Mapping[str, Any]) -> DepthScore:
    view = d["view"]
    return DepthScore(
        view=None if view == 2**64 - 1 else view,
        pixels=d["pixels"],
        absolute={t: v for t, v in d["absolute"]},
        relative={t: v for t, v in d["relative"]},
        low_texture=None if d["low_texture"] is None else {t: v for t, v in d["low_texture"]},
        median_relative_error=float(
            "nan" if d["median_relative_error"] is None else d["median_relative_error"]
        ),
        median_ratio=float("nan" if d.get("median_ratio") is None else d["median_ratio"]),
        scale_free=None
        if d.get("scale_free") is None
        else {
            "relative": {t: v for t, v in d["scale_free"]["relative"]},
            "low_texture": None
            if d["scale_free"]["low_texture"] is None
            else {t: v for t, v in d["scale_free"]["low_texture"]},
        },
    )


class DepthReport:
    """What ``mvscope eval`` reports: per view and pooled. ``str(report)`` is its table;
    :meth:`to_dict` the ``"depth"`` entry of the ``eval.json`` it writes.

    ``seen`` (from a session at the finest scale or a run's folder whose scene is still
    where it ran; None from arrays): the maps scored
    on the pixels whose true point one of the view's sources sees (the truth projected
    into them, not occluded by their truth) and on the others, which no view offers
    evidence for: ``{"seen": share of pixels, "within_2", "low_texture_within_2",
    "unseen_within_2", "per_view": [(view, share seen), ...]}`` (``eval.json``'s ``"seen"``
    holds the same, the shares under ``"score"``)."""

    def __init__(self, report_json: str, table: str) -> None:
        self._dict = json.loads(report_json)
        self.table = table
        self.views: List[DepthScore] = [_score(v) for v in self._dict["views"]]
        self.overall: DepthScore = _score(self._dict["overall"])
        seen = self._dict.pop("seen", None)
        self.seen: Optional[Dict[str, Any]] = (
            None if seen is None else {**seen["score"], "per_view": seen["per_view"]}
        )

    def within(self, relative: float = 0.02) -> float:
        """The pooled share of ground-truth pixels within ``relative`` (0.02: 2%)."""
        return self.overall.within(relative)

    def to_dict(self) -> Dict[str, Any]:
        """The report as ``eval.json`` holds it under ``"depth"``."""
        return json.loads(json.dumps(self._dict))

    def __str__(self) -> str:
        return self.table

    def __repr__(self) -> str:
        rel = ", ".join(f"<{t * 100:g}%: {v:.3f}" for t, v in self.overall.relative.items())
        return f"DepthReport({len(self.views)} views, {self.overall.pixels} pixels, {rel})"


def evaluate(
    depths: Any,
    gt: Union[str, "os.PathLike[str]"],
    abs: Sequence[float] = (0.02, 0.1),
    rel: Sequence[float] = (0.01, 0.02, 0.05),
) -> DepthReport:
    """Scores depth maps against ground truth: the same numbers as ``mvscope eval``.

    Args:
        depths: a :class:`Session` (its maps at the current step; each view scored as its
            index in the scene on disk), an output folder of ``mvscope run`` (its
            ``depth/%08d.pfm`` of the views in its params.toml), a list of H x W depth
            arrays (view 0, 1, ...) or a dict {view index: array}. Depth ≤ 0 is no
            estimate.
        gt: a scene folder with ground truth: ``gt/%08d.pfm`` depth maps (0 = unknown) and
            optional ``gt/%08d_lowtex.png`` weak-texture masks (the demo scene, the shared
            Middlebury and RGB-D scenes). Ground truth of another size is sampled at the
            estimate's pixel centres.
        abs: absolute thresholds in scene units (the paper's 2 cm and 10 cm).
        rel: relative thresholds.

    Raises:
        EvalError: no ground truth for any of the views.
        FileError: a depth or ground-truth file that cannot be read.
    """
    from ._session import Session

    gt = os.fspath(gt)
    a = [float(t) for t in abs]
    r = [float(t) for t in rel]
    if isinstance(depths, Session):
        return DepthReport(*depths._native.evaluate(gt, a, r))
    if isinstance(depths, (str, os.PathLike)):
        return DepthReport(*_native.evaluate_dir(os.fspath(depths), gt, a, r))
    if isinstance(depths, np.ndarray) and depths.ndim == 2:
        depths = [depths]
    items = depths.items() if isinstance(depths, Mapping) else enumerate(depths)
    arrays = []
    for view, d in items:
        d = np.ascontiguousarray(d, dtype=np.float32)
        if d.ndim != 2:
            from .errors import ParameterError

            raise ParameterError(f"view {view}: a depth map is H x W, not {d.shape}")
        arrays.append((int(view), d.shape[1], d.shape[0], d.tobytes()))
    return DepthReport(*_native.evaluate_arrays(arrays, gt, a, r))
