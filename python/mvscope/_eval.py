"""Evaluation against ground truth: the numbers of ``mvscope eval``."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _mvscope as _native

__all__ = [
    "evaluate",
    "DepthReport",
    "DepthScore",
    "evaluate_cloud",
    "CloudReport",
    "CloudScore",
]


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


@dataclass(frozen=True)
class CloudScore:
    """ETH3D's scores of a cloud at one distance ``threshold`` (scene units): ``accuracy``,
    the share of its points within the threshold of a ground-truth point; ``completeness``,
    the share of ground-truth points within it of a point of the cloud; ``f1``, their
    harmonic mean."""

    threshold: float
    accuracy: float
    completeness: float
    f1: float


class CloudReport:
    """What ``mvscope eval`` prints under "cloud": a :class:`CloudScore` per threshold
    (:attr:`scores`), the cloud's and the truth's sizes (:attr:`points`,
    :attr:`truth_points`) and where the truth came from (:attr:`truth`). ``str(report)``
    is the CLI's table; :meth:`to_dict` ``eval.json``'s ``"cloud"`` list."""

    def __init__(self, scores_json: str, points: int, truth_points: int, truth: str) -> None:
        self._list = json.loads(scores_json)
        self.scores: List[CloudScore] = [CloudScore(**d) for d in self._list]
        self.points = points
        self.truth_points = truth_points
        self.truth = truth

    def _at(self, threshold: float) -> CloudScore:
        for s in self.scores:
            if abs(s.threshold - threshold) < 1e-12:
                return s
        raise KeyError(
            f"{threshold}: scored at {[s.threshold for s in self.scores]}; "
            "pass thresholds=[...]"
        )

    def f1(self, threshold: float = 0.05) -> float:
        """F1 at ``threshold`` (one of those scored)."""
        return self._at(threshold).f1

    def accuracy(self, threshold: float = 0.05) -> float:
        return self._at(threshold).accuracy

    def completeness(self, threshold: float = 0.05) -> float:
        return self._at(threshold).completeness

    def to_dict(self) -> List[Dict[str, float]]:
        return json.loads(json.dumps(self._list))

    def __str__(self) -> str:
        lines = [
            f"cloud ({self.points} points) against {self.truth} ({self.truth_points} points):",
            f"  {'threshold':>10}  {'accuracy':>9}  {'completeness':>12}  {'F1':>6}",
        ]
        for s in self.scores:
            lines.append(
                f"  {s.threshold:>10g}  {s.accuracy:>9.3f}  {s.completeness:>12.3f}  {s.f1:>6.3f}"
            )
        return "\n".join(lines) + "\n"

    def __repr__(self) -> str:
        f1 = ", ".join(f"F1@{s.threshold:g}: {s.f1:.3f}" for s in self.scores)
        return f"CloudReport({self.points} points, {self.truth_points} truth points, {f1})"


def _xyz(points: Any) -> np.ndarray:
    from ._session import Cloud

    if isinstance(points, Cloud):
        points = points.points
    p = np.ascontiguousarray(points, dtype=np.float32)
    if p.ndim != 2 or p.shape[1] != 3:
        from .errors import ParameterError

        raise ParameterError(f"a cloud is N x 3 points, not an array of shape {p.shape}")
    return p


def evaluate_cloud(
    cloud: Any,
    gt: Union[str, "os.PathLike[str]"],
    thresholds: Sequence[float] = (0.02, 0.05, 0.1),
) -> CloudReport:
    """Scores a point cloud against ground truth: ETH3D's accuracy, completeness and F1,
    the numbers ``mvscope eval`` prints under "cloud" and the accuracy suite scores the
    rooms by (at 2 and 5 cm).

    Args:
        cloud: a finished :class:`Session` (fused as :meth:`Session.fuse` does, its truth
            through its own cameras), an output folder of ``mvscope run`` (its
            ``fused.ply``, the truth of the views it ran through its scene's cameras, as
            ``mvscope eval DIR --gt GT`` scores it), a PLY file, a :class:`Cloud` or an
            N x 3 array (the truth of every view of the scene folder ``gt``).
        gt: a scene folder with ``gt/%08d.pfm`` depth maps (the demo scene, the shared
            RGB-D rooms): the truth is their pixels back-projected, one point per cube of
            half the smallest threshold, so a wall seen by ten views counts once; or a
            ground-truth PLY (``mvscope eval --cloud``).
        thresholds: distances in scene units (metres for the rooms).

    Raises:
        EvalError: no ground truth for any of the views.
        FileError: a cloud or ground-truth file that cannot be read.
        ParameterError: a threshold that is not a positive distance, an array not N x 3.
        SessionError: a session that has not finished.
    """
    from ._io import read_ply
    from ._session import Session
    from .errors import EvalError, ParameterError

    gt = os.fspath(gt)
    t = [float(x) for x in thresholds]
    if not t or any(not (x > 0.0 and np.isfinite(x)) for x in t):
        raise ParameterError(
            f"thresholds {t}: give positive distances in scene units (e.g. 0.02, 0.05)"
        )
    voxel = min(t) / 2.0
    if isinstance(cloud, Session):
        points = _xyz(cloud.fuse())
        truth_of = lambda: cloud._native.truth_cloud(gt, voxel)  # noqa: E731
    elif isinstance(cloud, (str, os.PathLike)) and os.path.isdir(os.fspath(cloud)):
        run = os.fspath(cloud)
        points = _xyz(read_ply(os.path.join(run, "fused.ply")))
        truth_of = lambda: _native.truth_cloud(gt, voxel, run)  # noqa: E731
    else:
        if isinstance(cloud, (str, os.PathLike)):
            cloud = read_ply(cloud)
        points = _xyz(cloud)
        truth_of = lambda: _native.truth_cloud(gt, voxel)  # noqa: E731
    if os.path.isfile(gt):
        truth = _xyz(read_ply(gt))
        source = gt
    else:
        got = truth_of()
        if got is None:
            raise EvalError(
                f"no ground truth for these views: expected {gt}/gt/%08d.pfm "
                "(as `mvscope demo` writes), or give a ground-truth PLY"
            )
        n, data = got
        truth = np.frombuffer(data, dtype=np.float32).reshape(n, 3)
        source = f"the truth's depth maps back-projected, one point per {voxel:g} cube"
    scores = _native.cloud_scores(points.tobytes(), truth.tobytes(), t)
    return CloudReport(scores, len(points), len(truth), source)
