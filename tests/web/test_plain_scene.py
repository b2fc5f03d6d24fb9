"""`--plain-scene` (serve, demo, replay): the dashboard's scene without shadows or reflections, as a
connecting browser is told (`wiithrow.web.scene.plain_lighting`), and its progress bar without
moving stripes; the default keeps viser's own lights, shadows and environment map, and the stripes.
Read from the websocket as a browser would (no browser)."""

from __future__ import annotations

import pytest
from websockets.sync.client import connect

from tests.web.test_access import TOKEN
from tests.web.test_refused_clicks import received_messages
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.cli.bench.viser_client import PROTOCOL
from wiithrow.app.cli.main import build_parser
from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.web.server import Dashboard


def lighting_messages(plain: bool) -> list[dict]:
    """The lights, environment and progress bar messages a new operator's connection receives in
    its first second."""
    session = simulated_session(seed=4, calibration=None, quiet=True)
    session.set_target(demo_target_base())
    dashboard = Dashboard(
        session, port=0, token=TOKEN, analysis_process=False, derived_figures=False, plain_scene=plain
    )
    try:
        with connect(f"ws://127.0.0.1:{dashboard.port}/?token={TOKEN.value}", subprotocols=[PROTOCOL]) as client:
            client.send(viser_client.camera_message())
            seen = received_messages(client, 1.0)
        kinds = ("EnableLightsMessage", "EnvironmentMapMessage", "GuiProgressBarMessage")
        return [m for m in seen if m.get("type") in kinds]
    finally:
        dashboard.close()
        session.close()


def test_a_plain_scene_tells_the_browser_no_shadows_and_no_environment_map():
    messages = lighting_messages(plain=True)
    lights = [m for m in messages if m["type"] == "EnableLightsMessage"]
    environment = [m for m in messages if m["type"] == "EnvironmentMapMessage"]
    assert lights and lights[-1]["enabled"] is True and lights[-1]["cast_shadow"] is False, lights
    assert environment and environment[-1]["hdri_data"] is None, [m.get("hdri_data") is None for m in environment]
    (progress,) = [m for m in messages if m["type"] == "GuiProgressBarMessage"]
    assert progress["props"]["animated"] is False  # the stripes: a CSS animation redrawn every frame


def test_the_default_scene_keeps_viser_s_lights_and_environment():
    messages = lighting_messages(plain=False)
    (progress,) = [m for m in messages if m["type"] == "GuiProgressBarMessage"]
    assert progress["props"]["animated"] is True
    assert [m for m in messages if m is not progress] == []  # viser's defaults: shadows and the "warehouse" map


@pytest.mark.parametrize("command", ["serve", "demo", "replay"])
def test_plain_scene_is_a_flag_of_every_command_that_serves_the_dashboard(command):
    extra = ["x.mcap"] if command == "replay" else []
    assert build_parser().parse_args([command, *extra, "--plain-scene"]).plain_scene is True
    assert build_parser().parse_args([command, *extra]).plain_scene is False
