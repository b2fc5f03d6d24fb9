"""`SimulatedArmSnapshot`: a `SimulatedArm`'s whole state, taken and put back in one piece.

A host that steps the arm's reference ahead for servo periods that then do not run (a MuJoCo run cut
at the ball's release: `wiithrow.app.worlds.mujoco.devices.MujocoArm`) takes those steps back with
`SimulatedArm.snapshot` and `restore` (`take_snapshot`, `restore_snapshot`). The state is the
attributes `STATE_FIELDS` names, read in one C call (`state_values`, taken at every run of servo
periods while the arm moves), and the random generator's state.
"""

from __future__ import annotations

import operator
import threading
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

#: Everything of a `SimulatedArm` that changes as the simulation steps or is commanded.
STATE_FIELDS = (
    *("_k", "_q", "_v", "_a", "_hold", "_err"),
    *("_cmd", "_cmd_k", "_cmd_offset", "_cmd_moving_end", "_cmd_kind"),
    *("saturated_steps", "position_clamped_steps", "commands_started"),
)
#: The values of `STATE_FIELDS` of an arm, as a tuple, in one C call.
state_values = operator.attrgetter(*STATE_FIELDS)


class SimulatedArmSnapshot(NamedTuple):
    """A `SimulatedArm`'s state (`SimulatedArm.snapshot`): the values of `STATE_FIELDS` and
    its random generator's state (None for an arm without tracking noise)."""

    values: tuple[object, ...]
    rng_state: Mapping[str, Any] | None


def take_snapshot(arm: object, lock: threading.RLock, rng: np.random.Generator | None) -> SimulatedArmSnapshot:
    """`arm`'s whole state under its `lock`, for `restore_snapshot`; `rng`: its generator, None for
    an arm that never draws from it (no tracking noise). No copies: the state's arrays are replaced
    as the simulation goes on, never written in place (as `SimulatedArm.ideal_qv` promises)."""
    with lock:
        return SimulatedArmSnapshot(state_values(arm), rng.bit_generator.state if rng is not None else None)


def restore_snapshot(
    arm: object, snapshot: SimulatedArmSnapshot, lock: threading.RLock, rng: np.random.Generator
) -> None:
    """Put back into `arm` (under its `lock`; `rng`: its generator) a state `take_snapshot` took."""
    with lock:
        for name, value in zip(STATE_FIELDS, snapshot.values, strict=True):
            setattr(arm, name, value)
        if snapshot.rng_state is not None:
            rng.bit_generator.state = snapshot.rng_state
