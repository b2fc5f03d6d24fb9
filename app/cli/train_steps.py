"""`wiithrow train`'s throws, one session training step at a time: the dashboard's procedure
(`wiithrow.app.session.training.TrainingOperations` over a `TrainingRun`) driven from the terminal,
and what is done with a throw that failed.

Owns `throw_the_run` (the loop: preview, throw, measure, until every target is measured or
skipped), `FailedThrows` (the decision for a failed throw: retry, skip or stop, asked at the
terminal or as `--on-lost` says) and `TrainingStopped`.

Each throw goes through the session's steps, as the panel's buttons do: Preview training throw (the
simulated operator's solution, validated), Throw (training) (a lost ball, a Stop, a fault or a late
release leaves the throw failed, at its safe boundary), Measure training landing (the landing
marker, measured by the rig). The run is saved by the session after every step, beside the library
(`<library>.training.json`), so whatever ends the command, every measured throw is in that file.
Before each throw the arm goes home if it is not there (a failed throw leaves it where it braked):
every label describes a throw from the home pose, as the library's throws will be.

Who puts the landing marker down: a simulated world's simulated operator (the session's Measure
step does; a marker the rig does not see then fails the throw at once: looking again would see the
same); on the hardware path the operator, asked at the terminal once the ball is down
(`world_choice.landing_prompt`): Enter measures, up to `world_choice.LANDING_LOOKS` looks, the
last marking the throw failed; `r`, `s` or `q` at that prompt retry, skip or stop at once.

A failed throw (its landing not seen or refused, the ball lost, any `ThrowFailed`, a throw that
cannot be planned) is decided by `FailedThrows`: `ask` (the default on a terminal) asks "r retry /
s skip / q stop"; `retry` retries it up to `RETRIES_PER_TARGET` times, then skips it, saying so;
`skip` skips it; `stop` (the default off a terminal) stops the run, which is kept for `--resume`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from wiithrow.app.cli.operator_input import OperatorInput
from wiithrow.app.cli.world_choice import LANDING_LOOKS, landing_prompt
from wiithrow.app.errors import AppError, LandingNotMeasured
from wiithrow.app.rig.waiting import wait_while_moving
from wiithrow.app.session import Session
from wiithrow.app.throws.safe_stop import ThrowFailed
from wiithrow.app.throws.training_run import TrainingRun

Action = Literal["retry", "skip", "stop"]
#: What `--on-lost` may say (module docstring).
ON_LOST = ("ask", "retry", "skip", "stop")
#: How many times `--on-lost retry` throws a failed target again before it skips it: a target whose
#: throw fails three times running fails for a reason of its own (its landing out of the rig's view,
#: a grip that does not hold that throw), which more throws do not change; the run goes on without it.
RETRIES_PER_TARGET = 2
#: How far (rad) from the home pose the arm may rest and still count as home before a throw.
HOME_TOLERANCE_RAD = 0.01
#: How long (s, the world's clock) a throw waits for the arm to come to rest before its preview (a
#: position servo without gravity compensation settles for a while after power-on or a move).
SETTLE_TIMEOUT_S = 10.0
#: The answers the operator may type, and what each does.
ANSWERS: dict[str, Action] = {"r": "retry", "retry": "retry", "s": "skip", "skip": "skip", "q": "stop", "stop": "stop"}


class TrainingStopped(Exception):
    """The run was stopped (the operator's `q`, `--on-lost stop`, the end of input): every measured
    throw is in its progress file; `reason` says why."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass
class FailedThrows:
    """What is done with a failed throw (module docstring): `policy` is one of `ON_LOST`; `say`
    prints a line; `operator` answers when the policy is `ask`."""

    policy: str
    operator: OperatorInput
    say: Callable[[str], None]
    retries: dict[int, int] = field(default_factory=dict)

    def decide(self, index: int, count: int, reason: str) -> Action:
        """Retry, skip or stop throw `index` (0-based) of `count`, which failed for `reason`."""
        what = f"throw {index + 1}/{count}"
        if self.policy == "ask":
            return self._ask(what, reason)
        if self.policy == "retry":
            done = self.retries.get(index, 0)
            if done >= RETRIES_PER_TARGET:
                self.say(f"  {what} failed: {reason}; skipped after {RETRIES_PER_TARGET} retries (--on-lost retry)")
                return "skip"
            self.retries[index] = done + 1
            self.say(f"  {what} failed: {reason}; retry {done + 1} of {RETRIES_PER_TARGET} (--on-lost retry)")
            return "retry"
        if self.policy == "skip":
            self.say(f"  {what} failed: {reason}; skipped (--on-lost skip)")
            return "skip"
        self.say(f"  {what} failed: {reason}")
        return "stop"

    def _ask(self, what: str, reason: str) -> Action:
        while True:
            self.operator.discard_pending()  # only an answer typed after the question counts
            self.say(f"{what} failed: {reason}. Type r retry / s skip / q stop (the progress is saved), then Enter")
            line = self.operator.wait_line()
            if line is None:
                return "stop"
            answer = ANSWERS.get(line.strip().lower())
            if answer is not None:
                return answer


#: Called once a throw is done (measured or skipped): the run then, and the throw's index.
Done = Callable[[TrainingRun, int], None]


def throw_the_run(
    session: Session,
    failed: FailedThrows,
    *,
    operator: OperatorInput,
    say: Callable[[str], None],
    on_done: Done,
) -> TrainingRun:
    """Throw the session's training run to its end (module docstring): every target measured or
    skipped; the complete run. `TrainingStopped` when a failed throw's decision is to stop; whatever
    else is raised (a Ctrl-C, an error) leaves the run as saved after its last step."""
    while True:
        run = session.snapshot().training
        if run is None:
            raise AppError("no training run under way")
        i = run.index
        if i is None:
            return run
        throw = run.throws[i]
        if throw.state == "failed":
            _act(session, failed.decide(i, run.count, throw.note or "it failed"), throw.note)
        elif throw.state == "pending":
            _throw(session, failed, i, run.count)
        else:  # thrown: its landing
            _measure(session, failed, operator=operator, say=say, index=i, count=run.count)
        after = session.snapshot().training
        if after is not None and after.throws[i].state in ("measured", "skipped"):
            on_done(after, i)


def _throw(session: Session, failed: FailedThrows, index: int, count: int) -> None:
    """Preview and throw the current target from home. A throw that fails is left failed by the
    session (decided next round); one that cannot be planned is decided here."""
    world = session.world
    if np.max(np.abs(world.arm.state().q - world.arm_model.home)) > HOME_TOLERANCE_RAD:
        session.home()
    wait_while_moving(world.arm, world.clock, world.rig, timeout_s=SETTLE_TIMEOUT_S)  # the preview plans from rest
    try:
        preview = session.preview_training_throw()
    except AppError as exc:  # out of reach, refused by the validator: nothing was thrown
        action = failed.decide(index, count, f"no throw could be planned ({exc})")
        if action == "skip":
            session.skip_training_throw()
        elif action == "stop":
            raise TrainingStopped(f"no throw could be planned ({exc})") from None
        return
    try:
        session.training_throw(preview.id)
    except ThrowFailed:  # the arm rests, the hand as the phase demanded; the run holds the throw failed
        return


def _measure(
    session: Session,
    failed: FailedThrows,
    *,
    operator: OperatorInput,
    say: Callable[[str], None],
    index: int,
    count: int,
) -> None:
    """The current throw's landing, measured: by the world's simulated operator's marker, or the
    operator's at the terminal prompt (module docstring)."""
    world = session.world
    if world.landing_marker is not None:  # a simulated world puts the marker where the ball came down
        try:
            session.measure_training_landing(fail_unmeasured=True)
        except LandingNotMeasured:
            pass  # the throw is failed now: decided next round
        return
    what = f"throw {index + 1}/{count}"
    choices = "or type r to throw it again, s to skip it, q to stop"
    again = ""
    for look in range(LANDING_LOOKS):
        # the session's loop reads the rig meanwhile (`Session.start`)
        line = landing_prompt(world, what, operator, say=say, keep_reading=False, choices=choices, again=again)
        if line is None:
            raise TrainingStopped("no operator at the terminal to mark the landing (end of input)")
        action = ANSWERS.get(line.lower())
        if action is not None:
            _act(session, action, "stopped by the operator at the landing prompt")
            return
        try:
            session.measure_training_landing(fail_unmeasured=look == LANDING_LOOKS - 1)
            return
        except LandingNotMeasured as exc:
            again = exc.reason


def _act(session: Session, action: Action, reason: str) -> None:
    if action == "retry":
        session.retry_training_throw()
    elif action == "skip":
        session.skip_training_throw()
    else:
        raise TrainingStopped(reason)
