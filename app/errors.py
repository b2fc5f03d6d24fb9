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
