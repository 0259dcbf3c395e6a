"""mvscope: ACMM multi-view stereo (Xu & Tao, CVPR 2019) on the GPU, from Python.

The library behind the ``mvscope`` command line and viewer, for scripts and notebooks:

>>> import mvscope
>>> scene = mvscope.demo("demo-scene", views=3, width=160, height=120)
>>> s = mvscope.Session(scene, method="acmm", seed=0, params={"tau0": 0.8})
>>> s.step(unit="scale")                  # the coarsest scale, as the viewer steps it
>>> depth = s.maps(0)["depth"]            # H x W float32 at that scale
>>> s.run()
>>> mvscope.evaluate(s, gt="demo-scene").within(0.02)   # as `mvscope eval`
>>> cloud = s.fuse()                      # points, normals, colours
>>> mvscope.evaluate_cloud(cloud, gt="demo-scene").f1(0.05)   # ETH3D's F1 at 5 cm

Parameters carry params.toml's names; the papers' symbols: τ0 ``tau0``, τ1 ``tau1``, α
``alpha``, β ``beta`` (multi-hypothesis joint view selection), λ ``lambda``, δ ``delta``
(geometric consistency), ξ ``xi`` (detail restorer), k ``scales``, η ``eta`` (the pyramid),
γ ``prior_gamma`` (planar prior), ψ, ε, θ, n (fusion); see :data:`SYMBOLS`.

Errors are :class:`Error` subclasses with the CLI's messages. The device is the CLI's
(``mvscope gpu``): a GPU where there is one, else Mesa's lavapipe. docs/python.md has worked
examples.
"""

from __future__ import annotations

from typing import Any, Dict

from . import _mvscope
from ._eval import CloudReport, CloudScore, DepthReport, DepthScore, evaluate, evaluate_cloud
from ._io import read_pfm, read_ply, write_pfm, write_ply
from ._params import SYMBOLS, check_params, default_params
from ._scene import DepthRange, Scene, Source, View, demo
from ._session import (
    METHODS,
    TRIANGLE_STATES,
    UNITS,
    WINNER_COLORS,
    WINNERS,
    Cloud,
    Maps,
    Session,
    winner_rgb,
)
from .errors import (
    DeviceError,
    Error,
    EvalError,
    FileError,
    InternalError,
    ParameterError,
    SceneError,
    SceneWarning,
    SessionError,
)

__version__ = _mvscope.library_version()

__all__ = [
    "Scene",
    "View",
    "Source",
    "DepthRange",
    "demo",
    "Session",
    "Maps",
    "Cloud",
    "UNITS",
    "METHODS",
    "WINNERS",
    "WINNER_COLORS",
    "winner_rgb",
    "TRIANGLE_STATES",
    "evaluate",
    "DepthReport",
    "DepthScore",
    "evaluate_cloud",
    "CloudReport",
    "CloudScore",
    "read_pfm",
    "write_pfm",
    "read_ply",
    "write_ply",
    "default_params",
    "check_params",
    "SYMBOLS",
    "device",
    "Error",
    "SceneError",
    "ParameterError",
    "DeviceError",
    "SessionError",
    "FileError",
    "EvalError",
    "InternalError",
    "SceneWarning",
]


def device() -> Dict[str, Any]:
    """The adapter sessions run on, as ``mvscope gpu`` picks it: ``name``, ``backend``,
    ``device_type``, ``driver``, ``software`` (True for lavapipe) and ``description``."""
    return dict(_mvscope.device_info())
