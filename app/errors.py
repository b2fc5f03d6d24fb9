"""Errors of the running system, and the set of errors the command line reports without a traceback."""

from __future__ import annotations

import contextlib


class AppError(RuntimeError):
    """An expected failure of the running system (a run that cannot start, a busy session, ...)."""


def expected_errors() -> tuple[type[BaseException], ...]:
    """Exception types that are the user's or the environment's doing: reported as one clear line.

    Each package contributes its base error; imported lazily so that `wiithrow --help` stays fast.
    """
    from wiithrow.vision.errors import VisionError

    errors: list[type[BaseException]] = [AppError, VisionError]
    for module, name in (("wiithrow.robot.errors", "RobotError"), ("wiithrow.throwing.errors", "ThrowingError")):
        with contextlib.suppress(ImportError, AttributeError):
            errors.append(getattr(__import__(module, fromlist=[name]), name))
    return tuple(errors)


#: Why a landing was not measured when the rig saw no marker (`LandingNotMeasured.reason`).
NO_MARKER_SEEN = "the rig does not see a marker"


class LandingNotMeasured(AppError):
    """The rig measured no landing for a throw: it saw no landing marker, or one that cannot be the
    throw's landing (`wiithrow.app.throws.landing_checks`), or nobody was there to put it down. The
    marker may be put down again, or the throw retried or skipped. The message may be a view's own
    words (the dashboard's button); `reason` says why in words that fit any view."""

    def __init__(self, message: str, reason: str = NO_MARKER_SEEN) -> None:
        super().__init__(message)
        self.reason = reason
