"""The exceptions of mvscope.

Every error the library reports is an :class:`Error` (or a subclass); its message is the
one the ``mvscope`` command line prints: what is wrong, where (the file, the line of a text
file, the view) and what to do. No Rust panic reaches Python: a bug shows as
:class:`InternalError`.
"""

from __future__ import annotations

from typing import Optional

__all__ = [
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


class Error(Exception):
    """Base class of every mvscope error.

    Attributes:
        message: the message (also ``str(error)``).
        path: the file the error is about, where known.
        line: the line of a text file (1-based), where known.
        location: ``"file"``, ``"file:line"`` or ``"view NAME"`` (scene errors).
    """

    def __init__(
        self,
        message: str,
        *,
        path: Optional[str] = None,
        line: Optional[int] = None,
        location: Optional[str] = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.path = path
        self.line = line
        self.location = location

    def __str__(self) -> str:
        return self.message


class SceneError(Error):
    """A scene or one of its files is missing, unreadable or inconsistent (``path``, ``line``
    and ``location`` say where)."""


class ParameterError(Error, ValueError):
    """An unknown parameter, a value out of range, an unknown method or step unit."""


class DeviceError(Error, RuntimeError):
    """No GPU adapter, a device error, or a run that does not fit the device's memory."""


class SessionError(Error, RuntimeError):
    """A step or a read-back failed, or an operation needs another state (e.g. fusing an
    unfinished run)."""


class FileError(Error, OSError):
    """A map or point-cloud file (PFM, PLY, params.toml) cannot be read or written
    (``path``)."""

    def __init__(self, message: str, **kwargs: object) -> None:
        Error.__init__(self, message, **kwargs)  # type: ignore[arg-type]
        # OSError's own attributes stay unset (no errno): the message says it all.
        self.args = (message,)

    def __str__(self) -> str:
        return self.message


class EvalError(Error):
    """Ground truth is missing or unusable for the views evaluated."""


class InternalError(Error):
    """A bug in mvscope (a Rust panic, caught at the boundary). Please report it."""


class SceneWarning(UserWarning):
    """Something about a scene the user should know: sources dropped, depth ranges
    estimated, images downscaled (the CLI prints these as ``warning: ...``)."""
