"""The Training panel without a browser, on a simulated clock: what it shows of a run, that a
click from no operator's browser starts nothing, and that a guest's buttons all say why."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from wiithrow.app.session import Operation, simulated_session
from wiithrow.throwing import Area
from wiithrow.web.access import Role, Token
from wiithrow.web.controls import GUEST_REASON
from wiithrow.web.training_panel import OPERATIONS, area_ring, training_states, training_text

TOKEN = Token("0123456789abcdef-training-token", "--token")


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory):
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=4, calibration="true", quiet=True)
    session.train_to(tmp_path_factory.mktemp("training") / "lib.json")
    dash = Dashboard(session, port=0, token=TOKEN, derived_figures=False, analysis_process=False)
    yield dash
    dash.close()
    session.close()


def test_the_panel_shows_how_to_start_then_the_run(dashboard):
    session = dashboard.session
    dashboard.refresh()
    assert "press **Start training**" in dashboard.training.status.content
    states = training_states(session, Role.OPERATOR, GUEST_REASON)
    assert states[Operation.TRAIN_START] == ""
    assert states[Operation.TRAIN_SKIP] == session.refusal(Operation.TRAIN_SKIP) != ""
    assert training_states(session, Role.GUEST, GUEST_REASON) == dict.fromkeys(OPERATIONS, GUEST_REASON)

    session.start_training(Area((1.1, 1.5), (0.0, 0.3)), 6)
    dashboard.refresh()
    text = dashboard.training.status.content
    assert "throw 1/6 · measured 0 · skipped 0" in text and "target of this throw: x 1.100 m, z 0.000 m" in text
    assert text == training_text(session.snapshot())
    names = [node.name for node in dashboard.training._run_nodes]
    assert names == ["/link1/training_area", "/link1/training_targets"]
    preview = session.preview_training_throw()
    dashboard.refresh()
    assert dashboard.scene._preview is not None and dashboard.scene._preview.id == preview.id  # the ghost shows it


def test_a_click_from_no_operators_browser_starts_nothing(dashboard):
    started, logged = dashboard.runner.started, dashboard.refusals.counts["message"]
    event = SimpleNamespace(client=None)
    for op in OPERATIONS:
        dashboard.training._clicked(op, event, Area((1.0, 1.6), (0.0, 0.4)), 25)  # type: ignore[arg-type]
    assert dashboard.runner.started == started
    assert dashboard.refusals.counts["message"] == logged + len(OPERATIONS)


def test_the_area_outline_lies_in_the_throw_plane():
    ring = area_ring(Area((1.0, 1.6), (0.0, 0.4)))
    assert np.allclose(ring[0], ring[-1]) and np.allclose(ring[:, 1], 0.0)
    assert np.allclose(ring[:, [0, 2]].min(axis=0), (1.0, 0.0)) and np.allclose(ring[:, [0, 2]].max(axis=0), (1.6, 0.4))


def test_serve_and_demo_say_where_training_writes(dashboard, capsys, tmp_path):
    from wiithrow.app.cli.main import main
    from wiithrow.app.cli.serving import train_to_from_args
    from wiithrow.app.throws.training_file import TrainingFileError

    for command in ("serve", "demo"):
        assert main([command, "--help"]) == 0
        assert "--train-to" in capsys.readouterr().out
    session = dashboard.session
    before, run = session.training_library, session.snapshot().training
    (tmp_path / "lib.training.json").write_text("{")
    with pytest.raises(TrainingFileError, match="lib.training.json"):
        train_to_from_args(SimpleNamespace(train_to=str(tmp_path / "lib.json")), session)  # type: ignore[arg-type]
    assert session.training_library == before and session.snapshot().training is run  # nothing changed


def test_a_dragged_corner_moves_its_numbers_and_a_typed_one_its_handle(dashboard):
    """Through a real websocket with the operator token: the operator's own inputs and handles."""
    import viser
    from websockets.sync.client import connect

    from tests.conftest import wait_for
    from wiithrow.app.cli.bench import viser_client

    before = set(dashboard.clients.roles)
    url = f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}"
    with connect(url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None) as operator:
        operator.send(viser_client.camera_message())
        new = wait_for(lambda: set(dashboard.clients.roles) - before, 10.0, "the client to connect")
        inputs = wait_for(lambda: dashboard.training._inputs.get(next(iter(new))), 10.0, "its training inputs")
        near, far = inputs._handles
        near.position = (1.234, 0.0, 0.05)  # as the browser's drag sets it; then its update callback runs
        inputs._dragged()
        assert [float(c.value) for c in inputs.corners] == [1.234, 1.6, 0.05, 0.4]
        inputs.corners[1].value = 1.05  # typed (the server sets it: viser runs the callback at once)
        assert np.allclose(far.position, (1.05, 0.0, 0.4))
        assert inputs.area() == Area((1.05, 1.234), (0.05, 0.4))  # corners in either order
        dashboard.refresh()  # a run is under way (the first test's): the inputs say so
        why = dashboard.session.refusal(Operation.TRAIN_START)
        assert why and all(c.disabled and why in c.hint for c in (*inputs.corners, inputs.count))
        assert np.allclose(inputs._proposed.points.reshape(-1, 3)[:, [0, 2]].min(axis=0), (1.05, 0.05), atol=1e-6)
