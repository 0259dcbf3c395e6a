"""Scenes: :meth:`Scene.open` loads one as ``mvscope run`` does; :func:`demo` writes the
synthetic scene."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import _mvscope as _native
from .errors import SceneWarning

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["Scene", "View", "Source", "DepthRange", "demo"]


class Source(NamedTuple):
    """A source view of a reference view: its index in the scene (``view``) and the score
    that ranked it (best first)."""

    view: int
    score: float


class DepthRange(NamedTuple):
    """The depth (camera z) interval in which a view's surfaces lie."""

    min: float
    max: float


@dataclass(frozen=True)
class View:
    """One calibrated view of a :class:`Scene`, at the processed size.

    Conventions (docs/design.md): pixel centres on integers, ``X_cam = R @ X_world + t``,
    depth is the camera's z.

    Attributes:
        index: index in the scene as opened.
        scene_index: index in the scene on disk (differs with ``Scene.open(views=...)``);
            output files and ground truth are numbered by it.
        name: the image's name.
        width, height: the processed image size (after ``max_image_size``).
        K: 3x3 intrinsic matrix.
        R: 3x3 rotation, camera from world.
        t: translation (3,), camera from world.
        sources: the source views, best first.
        depth_range: the view's depth range.
        image_path: where the image was read from (None for generated scenes).
    """

    index: int
    scene_index: int
    name: str
    width: int
    height: int
    K: np.ndarray = field(repr=False)
    R: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    sources: Tuple[Source, ...]
    depth_range: DepthRange
    image_path: Optional[str] = field(repr=False)
    _scene: Any = field(repr=False, compare=False)

    @property
    def center(self) -> np.ndarray:
        """The camera centre in world coordinates, ``-R.T @ t``."""
        return -self.R.T @ self.t

    @property
    def P(self) -> np.ndarray:
        """The 3x4 projection matrix ``K @ [R | t]``."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def image(self) -> np.ndarray:
        """The colour image at the processed size, H x W x 3 uint8."""
        w, h, data = self._scene.image(self.index)
        return np.frombuffer(data, dtype=np.uint8).reshape(h, w, 3)

    def gray(self) -> np.ndarray:
        """The intensity matching reads (BT.601 grey, 0..255), H x W float32."""
        w, h, data = self._scene.gray(self.index)
        return np.frombuffer(data, dtype=np.float32).reshape(h, w)


def _view(native: Any, d: Dict[str, Any]) -> View:
    fx, fy, cx, cy = d["fx_fy_cx_cy"]
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    R = np.array(d["R_columns"], dtype=np.float64).reshape(3, 3).T
    for a in (K, R):
        a.setflags(write=False)
    t = np.array(d["t"], dtype=np.float64)
    t.setflags(write=False)
    return View(
        index=d["index"],
        scene_index=d["scene_index"],
        name=d["name"],
        width=d["width"],
        height=d["height"],
        K=K,
        R=R,
        t=t,
        sources=tuple(Source(i, s) for i, s in d["sources"]),
        depth_range=DepthRange(*d["depth_range"]),
        image_path=d["image_path"],
        _scene=native,
    )


class Scene:
    """A scene: calibrated views with depth ranges and source views.

    Open one with :meth:`Scene.open` (ACMM/MVSNet folders, COLMAP models, Middlebury
    ``*_par.txt``, Strecha folders, as ``mvscope run`` reads them) or write the synthetic one
    with :func:`demo`.
    """

    def __init__(self, native: Any) -> None:
        self._native = native
        self._views: Optional[List[View]] = None

    @classmethod
    def open(
        cls,
        path: PathLike,
        max_image_size: Optional[int] = None,
        views: Optional[Sequence[int]] = None,
        model: Optional[int] = None,
        *,
        format: Optional[str] = None,
        depth_range: Optional[Tuple[float, float]] = None,
    ) -> "Scene":
        """Loads a scene as ``mvscope run`` does.

        Args:
            path: a scene folder (ACMM/MVSNet, COLMAP, Strecha) or a Middlebury
                ``*_par.txt``.
            max_image_size: downscale images (and cameras) so that their long side is at most
                this many pixels (``--max-image-size``).
            views: only these views, by index in the scene on disk (``--views``); their
                sources are remapped and those outside the subset dropped.
            model: COLMAP: the model in ``sparse/N`` (``--model``).
            format: ``"acmm"``, ``"colmap"``, ``"middlebury"`` or ``"strecha"`` instead of
                detecting it (``--format``).
            depth_range: (min, max) for every view, overriding the scene's
                (``--depth-range``).

        Raises:
            SceneError: a missing or broken file; the message names the file (and line) and
                says what to do.
            ParameterError: a bad argument.

        The scene's warnings (sources dropped, ranges estimated) are issued as
        :class:`SceneWarning`.
        """
        native = _native.Scene.open(
            os.fspath(path),
            max_image_size=max_image_size,
            views=None if views is None else [int(v) for v in views],
            model=model,
            format=format,
            depth_range=None
            if depth_range is None
            else (float(depth_range[0]), float(depth_range[1])),
        )
        for w in native.warnings:
            warnings.warn(w, SceneWarning, stacklevel=2)
        return cls(native)

    @property
    def views(self) -> List[View]:
        """The views, in the scene's order."""
        if self._views is None:
            self._views = [_view(self._native, d) for d in self._native.views()]
        return list(self._views)

    @property
    def path(self) -> str:
        """The folder (or file) the scene was loaded from."""
        return os.fspath(self._native.path)

    @property
    def format(self) -> Optional[str]:
        """The format read: ``"acmm"``, ``"colmap"``, ``"middlebury"`` or ``"strecha"``."""
        return self._native.format

    @property
    def warnings(self) -> List[str]:
        """What the user should know about the scene (also issued as warnings on open)."""
        return list(self._native.warnings)

    @property
    def indices(self) -> List[int]:
        """Each view's index in the scene on disk."""
        return list(self._native.indices)

    @property
    def max_image_size(self) -> Optional[int]:
        return self._native.max_image_size

    def __len__(self) -> int:
        return len(self._native)

    def __getitem__(self, index: int) -> View:
        return self.views[index]

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self.views)

    def __repr__(self) -> str:
        v = self.views
        size = f"{v[0].width}x{v[0].height}" if v else "empty"
        return f"Scene({self.path!r}, {len(v)} views, {size}, format={self.format!r})"


def demo(
    out: PathLike,
    views: int = 5,
    width: int = 640,
    height: int = 480,
    seed: int = 1,
    room: bool = False,
    *,
    noise: float = 1.0,
) -> Scene:
    """Writes the built-in synthetic scene (``mvscope demo``) to ``out`` and opens it.

    The folder is an ACMM scene (images/, cams/, pair.txt) with ground truth in
    ``gt/%08d.pfm`` (and weak-texture masks), so :func:`mvscope.evaluate` can score a run
    of it.

    Args:
        out: the folder (created if missing).
        views, width, height: number and size of the images.
        seed: seed of the textures and the sensor noise.
        room: a closed room (textured side walls and ceiling meet a low-texture back wall),
            the case the planar prior is for.
        noise: sensor noise standard deviation in grey levels.
    """
    _native.demo(os.fspath(out), views, width, height, seed, room, noise)
    return Scene.open(out)
