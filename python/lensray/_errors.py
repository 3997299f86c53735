"""The exceptions lensray raises."""

from __future__ import annotations

from typing import Any, Optional


class LensrayError(Exception):
    """An error from liblensray or from the daemon.

    Attributes:
        message: the sentence the library (or the daemon) gave; for input
            errors it already names the field.
        path: the JSON path of the offending field (``"objects[3].radius"``,
            ``"camera.fov"``), or ``""`` when the error is not about one field.
        status: the library's status name (``"invalid"``, ``"io"``, ...) or,
            from the daemon, its error code (``"invalid_value"``, ...).
    """

    def __init__(self, message: str, path: str = "", status: str = "",
                 http_status: Optional[int] = None) -> None:
        super().__init__(message)
        self.message = message
        self.path = path
        self.status = status
        self.http_status = http_status


class SceneError(LensrayError, ValueError):
    """A bad scene, camera or render setting: ``.path`` names the field."""


class LensrayIOError(LensrayError, OSError):
    """A file could not be read or written."""


class CancelledError(LensrayError):
    """The render was cancelled before it finished.

    ``.stats`` holds the statistics of the part that was rendered, when
    known (in-process renders fill it; a daemon's job has none).
    """

    def __init__(self, message: str, path: str = "", status: str = "",
                 http_status: Optional[int] = None,
                 stats: Optional[dict[str, Any]] = None) -> None:
        super().__init__(message, path, status, http_status)
        self.stats = stats
