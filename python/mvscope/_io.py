"""Map and point-cloud files as the CLI reads and writes them."""

from __future__ import annotations

import os
from typing import Optional, Union

import numpy as np

from . import _mvscope as _native
from ._session import Cloud, _cloud

__all__ = ["read_pfm", "write_pfm", "read_ply", "write_ply"]

PathLike = Union[str, "os.PathLike[str]"]


def read_pfm(path: PathLike) -> np.ndarray:
    """Reads a PFM map (``mvscope run``'s depth, normal, cost): H x W float32, or H x W x 3,
    top row first (the file stores rows bottom to top, the MVSNet/Middlebury layout)."""
    w, h, c, data = _native.read_pfm(os.fspath(path))
    a = np.frombuffer(data, dtype=np.float32)
    return a.reshape(h, w) if c == 1 else a.reshape(h, w, c)


def write_pfm(path: PathLike, array: np.ndarray) -> None:
    """Writes an H x W or H x W x 3 map as a little-endian PFM, as ``mvscope run`` does."""
    a = np.ascontiguousarray(array, dtype=np.float32)
    if a.ndim == 2:
        c = 1
    elif a.ndim == 3 and a.shape[2] in (1, 3):
        c = a.shape[2]
    else:
        from .errors import ParameterError

        raise ParameterError(f"{os.fspath(path)}: a PFM holds H x W or H x W x 3, not {a.shape}")
    _native.write_pfm(os.fspath(path), a.shape[1], a.shape[0], c, a.tobytes())


def read_ply(path: PathLike) -> Cloud:
    """Reads a PLY point cloud (positions, and normals and colours where present)."""
    return _cloud(*_native.read_ply(os.fspath(path)))


def write_ply(
    path: PathLike,
    points: Union[Cloud, np.ndarray],
    normals: Optional[np.ndarray] = None,
    colors: Optional[np.ndarray] = None,
) -> None:
    """Writes a binary little-endian PLY (as ``fused.ply``): a :class:`Cloud`, or N x 3
    points with optional N x 3 normals (zeros if absent) and N x 3 uint8 colours (grey if
    absent)."""
    if isinstance(points, Cloud):
        points, normals, colors = points
    p = np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 3)
    n = len(p)
    q = (
        np.zeros((n, 3), np.float32)
        if normals is None
        else np.ascontiguousarray(normals, dtype=np.float32).reshape(-1, 3)
    )
    c = (
        np.full((n, 3), 128, np.uint8)
        if colors is None
        else np.ascontiguousarray(colors, dtype=np.uint8).reshape(-1, 3)
    )
    _native.write_ply(os.fspath(path), n, p.tobytes(), q.tobytes(), c.tobytes())
