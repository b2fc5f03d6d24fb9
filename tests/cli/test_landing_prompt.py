"""The terminal's landing prompt on the hardware path (`world_choice.operator_measures_landing`):
it says what to do at the terminal (never a dashboard button), it appears only once the ball is down
(the arm at rest, then `LANDING_SETTLE_S` on the world's clock), and what was typed or piped before it
is discarded, so that an Enter written ahead cannot race the touchdown: the prompt's own line is the
one that measures. Through a pipe and through a pseudo-terminal."""

from __future__ import annotations

import os
import pty
import select

import numpy as np
import pytest

from wiithrow.app.cli.operator_input import OperatorInput
from wiithrow.app.cli.world_choice import LANDING_LOOKS, LANDING_SETTLE_S, operator_measures_landing
from wiithrow.app.errors import LandingNotMeasured
from wiithrow.app.session import PLACE_MARKER
from wiithrow.app.settings import Settings
from wiithrow.app.worlds.named import make_world


@pytest.fixture(scope="module")
def world():
    built = make_world("kinematic", Settings(), seed=0)
    built.connect()
    yield built
    built.close()


def unread(fd: int) -> bool:
    return bool(select.select([fd], [], [], 0)[0])


@pytest.mark.parametrize("terminal", [False, True], ids=["pipe", "pty"])
def test_an_enter_written_before_the_prompt_is_not_taken_for_the_landing(world, terminal):
    if terminal:
        writer, reader = pty.openpty()  # the operator's keyboard writes to the leader
    else:
        reader, writer = os.pipe()
    operator = OperatorInput(reader)
    events: list[tuple[str, float]] = []
    start = world.clock.now()
    os.write(writer, b"\n")  # typed (or piped) while the ball was still in the air
    assert select.select([reader], [], [], 10.0)[0]  # waiting in the input (a pty's line discipline is asynchronous)

    def say(line: str) -> None:
        events.append(("said: " + line, world.clock.now()))
        if "press Enter" in line:
            os.write(writer, b"\n")  # the operator's Enter, once asked

    def measure() -> np.ndarray:
        events.append(("measured", world.clock.now()))
        return np.array([1.2, 0.0, 0.1])

    try:
        point = operator_measures_landing(world, "throw 3/10", measure=measure, operator=operator, say=say)
        assert np.allclose(point, [1.2, 0.0, 0.1])
        prompts = [t for what, t in events if "press Enter" in what]
        assert [what for what, _ in events].count("measured") == 1 and len(prompts) == 1, events
        assert prompts[0] - start >= LANDING_SETTLE_S - 1e-9  # the prompt came after the settle time
        # the Enter written before the prompt was discarded, the prompt's own line consumed: nothing is
        # left to be taken for the next throw's landing
        assert not unread(reader) and operator.pending == b""
    finally:
        os.close(writer)
        os.close(reader)


def test_the_terminal_says_what_to_do_at_the_terminal_not_a_dashboard_button(world):
    reader, writer = os.pipe()
    operator = OperatorInput(reader)
    said: list[str] = []
    tries: list[int] = []

    def say(line: str) -> None:
        said.append(line)
        if "press Enter" in line:
            os.write(writer, b"\n")

    def measure() -> np.ndarray:  # the session's Measure landing: the dashboard's words in its error
        tries.append(1)
        if len(tries) == 1:
            raise LandingNotMeasured("the rig does not see a marker: " + PLACE_MARKER)
        return np.array([1.0, 0.0, 0.0])

    try:
        operator_measures_landing(world, "the throw", measure=measure, operator=operator, say=say, settle_s=0.0)
    finally:
        os.close(writer)
        os.close(reader)
    assert len(tries) == 2 and sum("press Enter" in line for line in said) == 2, said
    assert not any("Measure landing" in line for line in said), said
    assert any("does not see" in line for line in said), said
    assert "put the IR marker where the ball first touched down" in said[0] and "cover the target" in said[0]


def test_the_end_of_input_and_an_unseen_marker_are_one_line_each(world):
    reader, writer = os.pipe()
    os.close(writer)  # nobody at the terminal
    with pytest.raises(LandingNotMeasured, match="end of input"):
        operator_measures_landing(
            world, "the throw", measure=lambda: np.zeros(3), operator=OperatorInput(reader), say=lambda _: None,
            settle_s=0.0,
        )  # fmt: skip
    os.close(reader)

    reader, writer = os.pipe()

    def say(line: str) -> None:
        if "press Enter" in line:
            os.write(writer, b"\n")

    try:
        with pytest.raises(LandingNotMeasured, match=f"no landing marker in {LANDING_LOOKS} looks"):
            operator_measures_landing(
                world, "the throw", measure=lambda: np.full(3, np.nan), operator=OperatorInput(reader), say=say,
                settle_s=0.0,
            )  # fmt: skip
    finally:
        os.close(writer)
        os.close(reader)
