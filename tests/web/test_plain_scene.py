"""`--plain-scene` (serve, demo, replay): the dashboard's scene without shadows or reflections, as a
connecting browser is told (`wiithrow.web.scene.plain_lighting`), and its progress bar without
moving stripes; the default keeps viser's own lights, shadows and environment map, and the stripes.
Read from the websocket as a browser would (no browser)."""

from __future__ import annotations

import time

import pytest
from websockets.sync.client import connect

from tests.web.test_access import TOKEN
from tests.web.test_refused_clicks import received_messages
from wiithrow.app.cli.bench import viser_client
from wiithrow.app.cli.bench.viser_client import PROTOCOL
from wiithrow.app.cli.main import build_parser
from wiithrow.app.session import demo_target_base, simulated_session
from wiithrow.web.light_scene import RENDERER_KEY, is_software
from wiithrow.web.page_script import STOP_NEVER_COVERED
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


# -- each browser's own: lightened when it renders in software, or at the operator's switch -------------


def test_software_renderers_are_told_from_gpu_ones():
    for renderer in (
        "ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero) (0x0000C0DE)), SwiftShader driver)",
        "llvmpipe (LLVM 15.0.6, 256 bits)",
        "Microsoft Basic Render Driver",
        "Software Rasterizer",
    ):
        assert is_software(renderer), renderer
    for renderer in (
        "ANGLE (NVIDIA, NVIDIA GeForce RTX 3060 Direct3D11 vs_5_0 ps_5_0)",
        "Apple M2",
        "Mesa Intel(R) UHD",
    ):
        assert not is_software(renderer), renderer


def answer_renderer(connection, seconds: float, renderer: str | None) -> list[dict]:
    """Read what the server sends for `seconds`, answering each localStorage request for the
    renderer with `renderer` (a page that has not run the probe yet: None); returns what was sent."""
    seen: list[dict] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            data = connection.recv(timeout=max(0.05, end - time.monotonic()))
        except TimeoutError:
            break
        if not isinstance(data, bytes):
            continue
        for m in viser_client.decode_window(data):
            seen.append(m)
            if m.get("type") == "LocalStorageGetItemRequestMessage" and m.get("key") == RENDERER_KEY:
                answer = {"type": "LocalStorageGetItemResponseMessage", "value": renderer, "error": None}
                connection.send(viser_client.encode({**answer, "request_uuid": m["request_uuid"]}))
    return seen


@pytest.mark.parametrize("role", ["operator", "guest"])
def test_a_page_that_renders_in_software_gets_a_plain_scene_and_is_told(role):
    """The page is sent the probe script, asked for its renderer (again while it has none), and a
    software renderer's page, a guest's too, is sent plain lights and no environment map, to it
    alone, with a notification; an operator's Light scene switch shows it on."""
    session = simulated_session(seed=4, calibration=None, quiet=True)
    dashboard = Dashboard(session, port=0, token=TOKEN, analysis_process=False, derived_figures=False)
    query = f"?token={TOKEN.value}" if role == "operator" else ""
    try:
        origin = f"http://127.0.0.1:{dashboard.port}"  # a guest is a browser: it gives its Origin
        with connect(f"ws://127.0.0.1:{dashboard.port}/{query}", subprotocols=[PROTOCOL], origin=origin) as client:
            client.send(viser_client.camera_message())
            first = answer_renderer(client, 1.0, None)  # not run yet: asked again
            scripts = [m["source"] for m in first if m.get("type") == "RunJavascriptMessage"]
            assert sum("UNMASKED_RENDERER_WEBGL" in source for source in scripts) == 1, scripts
            assert STOP_NEVER_COVERED in scripts, "a dialog's overlay never takes Stop's click"
            assert sum(m.get("type") == "LocalStorageGetItemRequestMessage" for m in first) >= 2
            seen = answer_renderer(client, 2.0, "ANGLE (Google, SwiftShader Device (Subzero), SwiftShader driver)")
            (light,) = dashboard.light_scenes.values()
            assert light.plain and "SwiftShader" in (light.renderer or "")
            if role == "operator":  # the switch shows it on; off, viser's shadows and environment map come back
                assert light.checkbox is not None and light.checkbox.value is True
                off = {"type": "GuiUpdateMessage", "uuid": light.checkbox._impl.uuid, "updates": {"value": False}}
                client.send(viser_client.encode(off))
                back = received_messages(client, 1.5)
                lit = [m for m in back if m.get("type") == "EnableLightsMessage"]
                assert lit and lit[-1]["cast_shadow"] is True and not light.plain
                assert [m for m in back if m.get("type") == "EnvironmentMapMessage"][-1]["hdri_data"] is not None
            else:
                assert light.checkbox is None
        lights = [m for m in seen if m.get("type") == "EnableLightsMessage"]
        environment = [m for m in seen if m.get("type") == "EnvironmentMapMessage"]
        assert lights and lights[-1]["cast_shadow"] is False and environment[-1]["hdri_data"] is None
        told = [m["props"] for m in seen if m.get("type") == "NotificationShowMessage"]
        assert any(p["title"] == "Light scene" and "renders in software (SwiftShader)" in p["body"] for p in told)
    finally:
        dashboard.close()
        session.close()
