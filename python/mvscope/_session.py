"""The Session: ACMM (or ACMH, DWTA, ACMP, ACMMP) stepped as the viewer steps it."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _mvscope as _native
from ._params import to_sets
from ._scene import Scene
from .errors import ParameterError

if TYPE_CHECKING:
    from ._eval import DepthReport

__all__ = [
    "Session",
    "Maps",
    "Cloud",
    "UNITS",
    "METHODS",
    "WINNERS",
    "WINNER_COLORS",
    "winner_rgb",
    "TRIANGLE_STATES",
]

#: The viewer's step units, smallest first.
UNITS = ("half", "iteration", "view", "stage", "scale")

#: The methods (``--method``).
METHODS = ("acmm", "acmh", "dwta", "acmp", "acmmp", "regions")

#: What each code of ``maps["winner"]`` means: the hypothesis a pixel adopted in its last
#: update (adaptive checkerboard areas, the plane it had, the refinement's six, its prior
#: plane kept because no source sees its point (Regions' ``prior_keep_unseen``), the random
#: initial plane).
WINNERS: Dict[int, str] = {
    0: "propagated: up V",
    1: "propagated: up strip",
    2: "propagated: down V",
    3: "propagated: down strip",
    4: "propagated: left V",
    5: "propagated: left strip",
    6: "propagated: right V",
    7: "propagated: right strip",
    8: "kept",
    9: "refined: (d_rand, n)",
    10: "refined: (d, n_rand)",
    11: "refined: (d_rand, n_rand)",
    12: "refined: (d_pert, n)",
    13: "refined: (d, n_pert)",
    14: "refined: (d_pert, n_pert)",
    15: "its prior plane (no source sees it)",
    254: "initial",
    255: "none",
}

_WINNER_LUT = np.array([_native.winner_color(code) for code in range(256)], dtype=np.uint8)

#: The viewer's colour (sRGB bytes) for each code of :data:`WINNERS`, from the same table
#: the winner map draws with: a hue per propagation direction (the V area dark, the strip
#: light), warm colours for the refinements, near-white for kept, magenta for a prior plane
#: no source sees, mid grey for the initial plane, and the invalid grey for ``none``.
WINNER_COLORS: Dict[int, Tuple[int, int, int]] = {
    code: (int(_WINNER_LUT[code, 0]), int(_WINNER_LUT[code, 1]), int(_WINNER_LUT[code, 2]))
    for code in WINNERS
}


def winner_rgb(winner: np.ndarray) -> np.ndarray:
    """``maps["winner"]`` (H x W codes) as the viewer's winner map draws it: an H x W x 3
    uint8 sRGB image (``matplotlib.pyplot.imshow`` shows it as it is). Codes outside
    :data:`WINNERS` are drawn in the invalid grey."""
    codes = np.asarray(winner)
    if codes.dtype != np.uint8:
        if codes.size and (codes.min() < 0 or codes.max() > 255):
            raise ValueError("winner codes are 0..255 (maps['winner'] is uint8)")
        codes = codes.astype(np.uint8)
    return _WINNER_LUT[codes]


#: What each code of ``Session.prior_mesh(view)["triangle_state"]`` means: a kept triangle
#: gives its pixels a prior; a degenerate one (collinear, or its plane through the camera
#: centre) and an inconsistent one (its plane more than ``prior_triangle_normal`` degrees
#: from a vertex's own normal) give none.
TRIANGLE_STATES: Dict[int, str] = {0: "kept", 1: "degenerate", 2: "inconsistent"}


class Maps(dict):  # type: ignore[type-arg]
    """A view's maps at a step of a run: a ``dict`` of numpy arrays (H x W at the view's
    current scale), with the scale as attributes.

    Always present:
        ``depth`` (float32; 0 where nothing is estimated: ``mvscope run``'s depth PFM),
        ``normal`` (H x W x 3 float32, unit normals in the WORLD frame, 0 where no depth:
        the normal PFM), ``normal_camera`` (H x W x 3, camera frame, as the passes hold
        them), ``plane`` (H x W x 4: camera-frame normal and depth, raw), ``cost``
        (aggregated matching cost in [0, 2]), ``selected`` (H x W x S bool: source j in the
        view-selection set S_t), ``selected_count`` (uint8), ``weights`` (H x W x S float32:
        w'(I_j)), ``winner`` (uint8 code, see :data:`WINNERS`), ``most_important_view``
        (uint8 source index v_t, 255: none).

    Once the run has made them:
        ``reprojection_error`` (mean forward-backward reprojection error over the sources,
        geometric stages), ``restorer_difference`` (C_init − C_photo of the detail
        restorer), ``replaced`` (bool: pixels the restorer replaced), and for ACMP/ACMMP
        ``prior_depth`` (the planar prior's depth; ≤ 0 where none: 0 no triangle, −1 dropped
        triangle, −2 out of range), ``prior_normal`` (camera frame), ``prior_weight`` (the
        prior factor γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²) of the current plane, 0 where no
        prior), ``prior_effect`` (bool: restarted from the prior / the prior changed the
        choice) and ``support_points`` (N x 2 float32, x and y); with ``prior_anchors``,
        while the view is in its prior stage from the prior planes' step on, ``anchors``
        (uint8: how many of the 8 directions hold an anchor agreeing on the pixel's prior
        plane, 0: not anchored; the viewer's Anchors map) and ``anchor_radii`` (H x W x 8
        uint8: per direction 0 none, else the index + 1 of its radius in 2, 4, ..., 128 px).

    Attributes:
        view: the view's index.
        level: pyramid level, 0 = coarsest.
        scale: ``level + 1`` as the labels count (``scale 1/3`` is the coarsest).
        width, height: the maps' size.
    """

    view: int
    level: int
    scale: int
    width: int
    height: int

    def __repr__(self) -> str:
        return (
            f"Maps(view={self.view}, scale {self.scale}, {self.width}x{self.height}, "
            f"keys={sorted(self)})"
        )


def _maps(view: int, raw: Dict[str, Any]) -> Maps:
    h, w, s = raw["height"], raw["width"], raw["num_sources"]

    def f32(key: str, *shape: int) -> np.ndarray:
        return np.frombuffer(raw[key], dtype=np.float32).reshape(h, w, *shape)

    plane = f32("plane", 4)
    aux = np.frombuffer(raw["aux"], dtype=np.uint32).reshape(h, w)
    bits = np.frombuffer(raw["selected"], dtype=np.uint32).reshape(h, w)
    selected = ((bits[..., None] >> np.arange(s, dtype=np.uint32)) & 1).astype(bool)
    weights = np.frombuffer(raw["weights"], dtype=np.float32)
    weights = weights.reshape(h, w, s) if s > 0 else np.zeros((h, w, 0), np.float32)
    m = Maps(
        depth=f32("depth"),
        normal=f32("normal", 3),
        normal_camera=np.where(plane[..., 3:] > 0, plane[..., :3], 0).astype(np.float32),
        plane=plane,
        cost=np.frombuffer(raw["cost"], dtype=np.float32).reshape(h, w),
        selected=selected,
        selected_count=selected.sum(axis=2, dtype=np.uint8),
        weights=weights,
        winner=(aux & 0xFF).astype(np.uint8),
        most_important_view=((aux >> 8) & 0xFF).astype(np.uint8),
    )
    for key in ("reprojection_error", "restorer_difference"):
        if raw[key] is not None:
            m[key] = f32(key)
    if raw["replaced"] is not None:
        m["replaced"] = np.frombuffer(raw["replaced"], dtype=np.uint8).reshape(h, w) != 0
    if raw["prior"] is not None:
        prior = f32("prior", 4)
        m["prior_depth"] = np.ascontiguousarray(prior[..., 3])
        m["prior_normal"] = np.ascontiguousarray(prior[..., :3])
        m["prior_effect"] = ((aux >> 17) & 1).astype(bool)
        if raw["prior_weight"] is not None:
            m["prior_weight"] = f32("prior_weight")
    if raw["support_points"] is not None:
        m["support_points"] = np.frombuffer(raw["support_points"], np.float32).reshape(-1, 2)
    if raw["anchor_codes"] is not None:
        codes = np.frombuffer(raw["anchor_codes"], dtype=np.uint32).reshape(h, w)
        # 3 bits per direction: 0 none, else the radius's index + 1.
        digits = (codes[..., None] >> (3 * np.arange(8, dtype=np.uint32))) & 7
        m["anchor_radii"] = digits.astype(np.uint8)
        m["anchors"] = (digits != 0).sum(axis=2, dtype=np.uint8)
    m.view = view
    m.level = raw["level"]
    m.scale = raw["level"] + 1
    m.width, m.height = w, h
    return m


class Cloud(NamedTuple):
    """A point cloud: ``points`` and ``normals`` (N x 3 float32), ``colors`` (N x 3 uint8)."""

    points: np.ndarray
    normals: np.ndarray
    colors: np.ndarray

    def write_ply(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes the cloud as a binary PLY (as ``fused.ply``)."""
        from ._io import write_ply

        write_ply(path, self)

    def __repr__(self) -> str:
        # A tuple's repr would print every array (numpy's summary of three N x 3 arrays, some
        # twenty lines); a notebook wants the size and where the points lie.
        n = len(self.points)
        if n == 0:
            return "Cloud(0 points)"
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        box = ", ".join(f"{a} {l:.3g}..{h:.3g}" for a, l, h in zip("xyz", lo, hi))
        return f"Cloud({n} point{'s' if n != 1 else ''}; {box})"


def _cloud(n: int, points: bytearray, normals: bytearray, colors: bytearray) -> Cloud:
    return Cloud(
        np.frombuffer(points, dtype=np.float32).reshape(n, 3),
        np.frombuffer(normals, dtype=np.float32).reshape(n, 3),
        np.frombuffer(colors, dtype=np.uint8).reshape(n, 3),
    )


class Session:
    """A run of one method over one scene, step by step: what the viewer shows, scriptable.

    The schedule (:attr:`steps`) is the viewer's timeline: per scale (ACMM: coarsest
    first), its stages (photometric ACMH from random planes at the coarsest scale; at each
    finer one the detail restorer: joint bilateral upsampling, the basic model started from
    the upsampled planes and the comparison C_init − C_photo > ξ; then the geometric
    consistency passes weighing the reprojection error by λ, truncated at δ), and per stage
    each view's init, red and black halves of each iteration, median, restore and measure
    steps. Every stage works from the depths all views had when the previous stage ended, so
    the maps do not depend on the order views run in: the final maps equal ``mvscope run``'s
    byte for byte for the same scene, method, parameters and seed.

    Args:
        scene: the scene (:meth:`Scene.open`, :func:`mvscope.demo`).
        method: ``"acmm"`` (the paper's, multi-scale), ``"acmh"`` (one scale),
            ``"dwta"`` (the ablation baseline), ``"acmp"`` or ``"acmmp"`` (the planar prior), or
            ``"regions"`` (ACMMP with one plane per flat region).
        seed: seed of every random number (``--seed``); the same seed gives the same maps.
        params: parameters by params.toml's names (``--set``), e.g. ``{"tau0": 0.7}``:
            τ0 ``tau0``, τ1 ``tau1``, α ``alpha``, β ``beta`` (view selection), λ
            ``lambda``, δ ``delta`` (geometric consistency), ξ ``xi`` (detail restorer), k
            ``scales``, η ``eta`` (pyramid), γ ``prior_gamma`` (planar prior), ...; see
            :data:`mvscope.SYMBOLS` and :func:`mvscope.default_params`.
        device_memory: the device memory to plan with, MiB (``--device-memory``; default:
            what the device is known to have). A scene whose views do not fit at once runs
            each stage in batches that do, with the same maps.

    Raises:
        ParameterError: an unknown method or parameter, a value out of range, or a seed
            given twice with different values.
        DeviceError: no GPU adapter (lavapipe serves where there is no GPU), or a scene
            that does not fit the device (the message gives the largest ``max_image_size``
            that fits).

    The device is the one the CLI picks (``mvscope gpu``; ``WGPU_BACKEND``,
    ``WGPU_ADAPTER_NAME``). The GIL is released while the device works, and Ctrl-C
    (KeyboardInterrupt) stops :meth:`run`, :meth:`step` and :meth:`goto` between steps: the
    session stays usable where it stopped.
    """

    def __init__(
        self,
        scene: Scene,
        method: str = "acmm",
        seed: int = 0,
        params: Optional[Mapping[str, Any]] = None,
        *,
        device_memory: Optional[float] = None,
    ) -> None:
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be an mvscope.Scene, not {type(scene).__name__}")
        params = dict(params or {})
        if "seed" in params and int(params["seed"]) != int(seed):
            raise ParameterError(
                f"params['seed'] = {params['seed']} and seed = {seed}: give the seed once "
                f"(Session(scene, seed={params['seed']}))"
            )
        params.pop("seed", None)
        self._scene = scene
        self._native = _native.Session(
            scene._native,
            method,
            to_sets(params),
            int(seed),
            None if device_memory is None else float(device_memory),
        )
        self._steps: Optional[List[Dict[str, Any]]] = None

    # --- what it is ---------------------------------------------------------------------

    @property
    def scene(self) -> Scene:
        return self._scene

    @property
    def method(self) -> str:
        """The method's name (``"acmm"``, ...)."""
        return str(self._native.method())

    @property
    def params(self) -> Dict[str, Any]:
        """Every parameter by params.toml's names (a copy: change them with :meth:`set`)."""
        return json.loads(self._native.params_json())

    @property
    def steps(self) -> List[Dict[str, Any]]:
        """The schedule, one dict per step: ``index``, ``scale`` (1 = coarsest, as the labels
        count) and ``level`` (0 = coarsest), ``scales``, ``stage`` ("photometric", "detail
        restorer", "planar prior", "geometric 1", ...), ``geometric_pass``, ``view``,
        ``action`` ("init", "half", "median", "upsample", "restore", "measure", "support
        points", "triangulate", "prior plane"), ``iteration`` and ``half`` ("red"/"black")
        for half-iterations, and the viewer's ``label``."""
        if self._steps is None:
            self._steps = list(self._native.schedule())
        return [dict(s) for s in self._steps]

    @property
    def cursor(self) -> int:
        """Steps run so far (the index of the next step; ``len(steps)`` when finished)."""
        return int(self._native.cursor())

    @property
    def finished(self) -> bool:
        return self.cursor >= len(self.steps)

    @property
    def current_step(self) -> Optional[Dict[str, Any]]:
        """The last step run (None before the first)."""
        c = self.cursor
        return self.steps[c - 1] if c > 0 else None

    @property
    def num_levels(self) -> int:
        """Scales of the pyramid (1 for the one-scale methods)."""
        return int(self._native.num_levels())

    # --- moving -------------------------------------------------------------------------

    def step(self, n: int = 1, unit: str = "half") -> None:
        """Runs ``n`` of the viewer's units forward: ``"half"`` (one step: a red or black
        half-iteration, or an init, median, upsample, restore step), ``"iteration"`` (to the
        end of the current iteration), ``"view"`` (the current view's work in this stage),
        ``"stage"`` (all views) or ``"scale"``."""
        self._native.step(_count(n), _unit(unit))

    def back(self, n: int = 1, unit: str = "half") -> None:
        """Goes back ``n`` units (from the latest checkpoint, replaying the steps in between:
        the maps are those the run had there, bit for bit)."""
        self._native.back(_count(n), _unit(unit))

    def goto(self, k: int) -> None:
        """Moves to ``k`` steps run: forward by running, backward from a checkpoint."""
        if k < 0:
            k += len(self.steps) + 1
        if k < 0:
            raise ParameterError(f"goto({k}): the schedule has {len(self.steps)} steps")
        self._native.goto(int(k))

    def run(self) -> None:
        """Runs every remaining step."""
        self._native.goto(len(self.steps))

    def reset(self) -> None:
        """Back to the start (nothing run)."""
        self._native.reset()

    def set(self, **changes: Any) -> Dict[str, int]:
        """Changes parameters as the viewer does: the session goes back to the first step
        the change affects (a change of λ re-runs from the first geometric pass, of ξ from
        the first restore step, of τ0 from the start) and runs again to the same point of
        the schedule (same scale, stage, view and iteration).

        ``s.set(tau0=0.7, xi=0.2)``; λ, a Python keyword, is ``lambda_`` (or
        ``s.set(**{"lambda": 0.3})``).

        Returns:
            ``{"from_step": first step re-run, "previous_cursor": ..., "cursor": ...}``.
        """
        if "seed" in changes:
            changes["seed"] = int(changes["seed"])
        from_step, previous, cursor = self._native.set(to_sets(changes))
        self._steps = None
        return {"from_step": from_step, "previous_cursor": previous, "cursor": cursor}

    # --- looking ------------------------------------------------------------------------

    def maps(self, view: int) -> Optional[Maps]:
        """View ``view``'s maps at the current step (the maps the viewer shows), or None
        before the view's first step. See :class:`Maps` for the keys. A negative ``view``
        counts from the end, as Python's indices do."""
        view = self._view(view)
        raw = self._native.maps(view)
        return None if raw is None else _maps(view, raw)

    def depth(self, view: int) -> Optional[np.ndarray]:
        """``maps(view)["depth"]``."""
        m = self.maps(view)
        return None if m is None else m["depth"]

    def inspect(self, view: int, x: int, y: int) -> Optional[Dict[str, Any]]:
        """The pixel inspector: why pixel (x, y) of view ``view``'s current maps got its
        plane. The last red/black half that updated the pixel at the current scale is
        replayed with its input captured and re-computed on the CPU reference.

        Returns (None if no half-iteration of the pixel's colour has run at this scale):
            ``step`` and ``label`` of that half; ``candidates`` (8 dicts: ``origin`` pixel,
            ``plane``, aggregated ``cost``, ``valid``); ``cost_matrix`` (8 x S: candidate i
            scored by source j, with λ·Δe in geometric passes); ``tau_t`` (τ(t));
            ``votes`` (per source: ``good`` costs < τ(t), ``bad`` > τ1, ``selected``,
            ``weight`` w(I_j), ``weight_prime`` w'(I_j)); ``current_plane``,
            ``current_costs``, ``current_cost``; ``refinement`` (the six ``planes`` and
            their ``costs``); ``cpu`` and ``gpu`` (the CPU reference's and the device's
            result: ``plane``, ``cost``, ``selected`` bits, ``weights``, ``winner``, see
            :data:`WINNERS`) and ``agrees``; ``reprojection`` (Δe per source, geometric
            passes); ``prior`` (ACMP/ACMMP: the prior plane, factors γ + ..., scores S and
            whether the prior flipped the choice); ``anchors`` (a pixel anchored by
            ``prior_anchors`` in the prior-assisted pass: its anchors' ``pixels`` (x, y),
            the anchors' ``weight`` in its cost, and per candidate its ``own`` window's
            cost and its ``anchored`` windows' mean cost, m = (1 − weight)·own +
            weight·anchored where views are selected); ``window`` (how the matching
            cost weighs the pixel's reference window: the bilateral ``kernel``, its colour
            ``sigma`` in grey levels, the window's ``spread`` 1.4826 × median |ΔI|, the
            ``weights`` as (2r+1) rows relative to the heaviest sample, NaN where the window's
            step skips a pixel, ``effective`` = (Σw)²/Σw² of its ``samples``, and each
            pixel's ``variance_share`` of the window's weighted variance, which the NCC
            matches: a sample across an edge may weigh little and still hold most of it);
            ``restorer`` (C_init − C_photo and
            whether the restorer replaced the pixel); ``source_views``. Planes are
            camera-frame normal xyz and depth.
        """
        return self._native.inspect(self._view(view), int(x), int(y))

    def support_cell(self, view: int, x: int, y: int) -> Optional[Dict[str, Any]]:
        """Why the cell holding pixel (x, y) of view ``view`` has its support point (the
        planar prior of ACMP, ACMMP, Regions): the view's last support-point step at the
        current scale is replayed, what it read is read back, and the cell is explained on
        the CPU (the viewer's inspector).

        Returns (None before that step has run): ``step`` (its index), ``origin`` (the
        cell's top-left pixel), ``size``, ``chosen`` (the pixel chosen, or None),
        ``by_flat_window``, and ``candidates``, every pixel of the cell best first by the
        rule in force (cost; the count of confirming sources; cost − confidence), each a
        dict of ``pixel``, ``depth``, ``cost``, ``flat``, ``eligibility`` ("below cost
        limit", "flat window", "cost too high", "views disagree"), ``confidence`` (the
        count, or the summed confidence with ``prior_confidence_score``; None without
        ``prior_confirmed_points``) and ``score``.
        """
        return self._native.support_cell(self._view(view), int(x), int(y))

    def prior_mesh(self, view: int) -> Optional[Dict[str, Any]]:
        """View ``view``'s planar prior at its current scale as its triangulation step built
        it (ACMP, ACMMP, Regions; the viewer's triangulation map), or None before that step.

        Returns a dict of numpy arrays: ``points`` (N x 2 int: the support points' x, y),
        ``point_depth``, ``point_cost`` (N float32), ``point_normal`` (N x 3, camera frame),
        ``triangles`` (M x 3 int: indices into ``points``), ``triangle_plane`` (M x 4:
        camera-frame n and w, n·X + w = 0), ``triangle_state`` (M uint8, see
        :data:`TRIANGLE_STATES`); and with ``prior_regions`` ``regions``, a dict of
        ``cell`` (the grid's side, pixels), ``region`` (cells_y x cells_x uint32: 0 not
        flat, else 1 + the flat region), ``plane`` (cells_y x cells_x int32: the index into
        ``planes`` of the plane the cell takes, −1 none), ``sizes`` (each region's count of
        support points), ``planes`` (dicts of ``region``, ``plane`` (n, w) and
        ``inliers``, the indices of the support points it holds) and, with
        ``prior_region_edge``, ``shades`` (cells_y x cells_x float32: each cell's median grey,
        which the edge rule compares; None without it). Each plane's ``axis`` is the axis of
        the view's Manhattan frame that is its normal (0-2; ``prior_region_axes``), or None
        for RANSAC's plane through three points; ``frame`` is that frame, or None (the
        option off, or too few straight lines): ``axes`` (3 x 3, camera frame, one axis a
        row), ``segments`` (K x 2 x 2: each straight segment's two ends, pixels) and
        ``along`` (K uint8: the axis each segment points at, 3 none). With
        ``prior_region_choice`` a plane whose ``later`` is True came from the fit to the
        support points of the scale's first geometric pass: its ``inliers`` index
        ``later_points`` (E x 3 float32: x, y, depth of that fit's support points; empty
        when no region took it); the triangles and the other planes are the earlier
        points', those of the restorer's result.
        """
        raw = self._native.prior_mesh(self._view(view))
        if raw is None:
            return None
        out: Dict[str, Any] = {
            "width": raw["width"],
            "height": raw["height"],
            "points": np.frombuffer(raw["points"], np.uint32).reshape(-1, 2).astype(np.int64),
        }
        dc = np.frombuffer(raw["depth_cost"], np.float32).reshape(-1, 2)
        out["point_depth"] = np.ascontiguousarray(dc[:, 0])
        out["point_cost"] = np.ascontiguousarray(dc[:, 1])
        out["point_normal"] = np.frombuffer(raw["point_normals"], np.float32).reshape(-1, 3)
        out["triangles"] = (
            np.frombuffer(raw["triangles"], np.uint32).reshape(-1, 3).astype(np.int64)
        )
        out["triangle_plane"] = np.frombuffer(raw["triangle_planes"], np.float32).reshape(-1, 4)
        out["triangle_state"] = np.frombuffer(raw["triangle_states"], np.uint8).copy()
        if "regions" in raw:
            r = raw["regions"]
            shape = (r["cells_y"], r["cells_x"])
            assigned = np.frombuffer(r["assigned"], np.uint32).reshape(shape)
            out["regions"] = {
                "cell": r["cell"],
                "region": np.frombuffer(r["region"], np.uint32).reshape(shape).copy(),
                "plane": assigned.astype(np.int32) - 1,
                "sizes": list(r["sizes"]),
                "shades": (
                    np.frombuffer(r["shades"], np.float32).reshape(shape).copy()
                    if len(r["shades"])
                    else None
                ),
                "planes": [
                    {
                        "region": p["region"],
                        "plane": np.asarray(p["plane"], np.float32),
                        "inliers": np.asarray(p["inliers"], np.int64),
                        # The frame's axis that is its normal; None: RANSAC's free plane.
                        "axis": p["axis"],
                        # `prior_region_choice`: the inliers index `later_points`.
                        "later": p["later"],
                    }
                    for p in r["planes"]
                ],
                "later_points": np.frombuffer(r["later_points"], np.float32)
                .reshape(-1, 3)
                .copy(),
                "frame": (
                    {
                        "axes": np.asarray(r["frame"]["axes"], np.float64),
                        "segments": np.frombuffer(r["frame"]["segments"], np.float32)
                        .reshape(-1, 2, 2)
                        .copy(),
                        "along": np.frombuffer(r["frame"]["along"], np.uint8).copy(),
                    }
                    if "frame" in r
                    else None
                ),
            }
        return out

    def fuse(self, **fusion_params: Any) -> Cloud:
        """Fuses the finished maps into a coloured cloud as ``mvscope run`` does
        (``fused.ply``). Fusion's parameters may be overridden as ``mvscope fuse --set``
        does: ψ ``fusion_reprojection``, ε ``fusion_relative_depth``, θ
        ``fusion_normal_angle``, n ``fusion_min_views``.

        Raises:
            SessionError: the run is not finished.
        """
        return _cloud(*self._native.fuse(to_sets(fusion_params)))

    def evaluate(self, gt: Union[str, "os.PathLike[str]"], **thresholds: Any) -> "DepthReport":
        """``mvscope.evaluate(self, gt, ...)``: this session's maps at the current step
        scored against the ground truth in ``gt``."""
        from ._eval import evaluate

        return evaluate(self, gt, **thresholds)

    def seen(self, gt: Union[str, "os.PathLike[str]"]) -> List[Optional[np.ndarray]]:
        """Each view's pixels a source sees, from the ground truth in ``gt`` (as
        :meth:`evaluate` reads it): ``True`` where the view's true point, projected into one of
        its sources, lands inside that image and the source's truth there is not nearer by
        more than 3%. The masks :meth:`evaluate`'s ``report.seen`` splits the scores by, at
        the scene's processed size (the finest scale's maps), one per view; ``None`` for a
        view without truth.

        Raises:
            EvalError: a truth file that cannot be read.
        """
        out: List[Optional[np.ndarray]] = []
        for m in self._native.seen(os.fspath(gt)):
            if m is None:
                out.append(None)
                continue
            w, h, data = m
            out.append(np.frombuffer(bytes(data), dtype=np.uint8).reshape(h, w).astype(bool))
        return out

    def _view(self, view: int) -> int:
        n = len(self._scene)
        v = int(view)
        if v < 0:
            v += n
        if not 0 <= v < n:
            raise ParameterError(f"view {view}: the scene has {n} views")
        return v

    # --- memory -------------------------------------------------------------------------

    @property
    def device_bytes(self) -> int:
        """Bytes the session holds on the device (maps, images, checkpoints)."""
        return int(self._native.device_bytes())

    @property
    def checkpoint_budget(self) -> int:
        """The most bytes Back's checkpoints may hold (default 512 MiB; oldest go first)."""
        return int(self._native.checkpoint_budget)

    @checkpoint_budget.setter
    def checkpoint_budget(self, value: int) -> None:
        self._native.checkpoint_budget = int(value)

    def __len__(self) -> int:
        return len(self.steps)

    def __repr__(self) -> str:
        step = self.current_step
        where = step["label"] if step else "not started"
        return (
            f"Session({self.method}, {len(self._scene)} views, step {self.cursor} of "
            f"{len(self.steps)}: {where})"
        )


def _count(n: int) -> int:
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 0:
        raise ParameterError(f"n={n!r}: a number of units, 0 or more")
    return int(n)


def _unit(unit: str) -> str:
    if unit not in UNITS:
        raise ParameterError(f"unit={unit!r}: one of {', '.join(map(repr, UNITS))}")
    return unit
