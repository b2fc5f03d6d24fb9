"""Each browser's 3D scene lightened when it renders in software, or when its operator asks.

A browser that renders WebGL on the CPU (no GPU, a remote desktop; Chromium's SwiftShader, Mesa's
llvmpipe) pays for shadows and the environment map's reflections on the CPU, frame after frame:
the page then handles the server's messages and its own clicks late (`wiithrow.web.scene.plain_lighting`).
So each page is asked, once it connects, which renderer it has: the server sends it a small script
(`wiithrow.web.page_script.run_in_page`) that reads WebGL's
`UNMASKED_RENDERER_WEBGL` from a canvas of its own and keeps it in the page's localStorage under
`RENDERER_KEY`, then reads it back through viser's localStorage request (`ClientHandle.local_storage`;
again until it is there: viser's page answers a request as it arrives, and runs a script at its
next frame), in a thread of its own (`wiithrow-web-renderer`), so that nothing waits on a slow page. A renderer
that `is_software` names makes that browser's scene plain (its own lights and environment, sent to
it alone: the others keep theirs), and the page says so in a notification.

An operator's page also has the switch, *Light scene* (a checkbox at the top of the panel): on,
the plain scene; off, viser's lights with their shadows and its environment map. The automatic
choice sets the switch too, so that the page shows what it draws. (A guest's page has no switch:
a guest's GUI messages other than Stop are refused, `wiithrow.web.access.admit_message`; it is
lightened automatically all the same.)
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable
from typing import Literal

import viser

from wiithrow.web.page_script import run_in_page
from wiithrow.web.scene import default_lighting, plain_lighting

#: Where the page keeps its WebGL renderer's name (its localStorage; read back by the server), and
#: the prefix viser 1.1's page puts before the keys of its localStorage API (`viser/client/src`).
RENDERER_KEY = "wiithrow-webgl-renderer"
VISER_STORAGE_PREFIX = "viser-user:"
#: Renderers that draw on the CPU: Chromium's SwiftShader, Mesa's llvmpipe and softpipe, Windows'
#: Basic Render Driver, and any that says "software".
SOFTWARE = re.compile(r"swiftshader|llvmpipe|softpipe|software|basic render", re.IGNORECASE)
#: How long the server waits for a page to answer which renderer it has (s), asking again after
#: `ASK_PERIOD_S`, then twice as long each time.
ASK_TIMEOUT_S = 30.0
ASK_PERIOD_S = 0.25

#: The page's script: the renderer of a WebGL context of its own (released at once), in localStorage.
PROBE_SCRIPT = f"""
let renderer = "unknown";
try {{
  const canvas = document.createElement("canvas");
  const gl = canvas.getContext("webgl2") || canvas.getContext("webgl");
  if (!gl) {{
    renderer = "no WebGL";
  }} else {{
    const info = gl.getExtension("WEBGL_debug_renderer_info");
    renderer = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const lose = gl.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext();
  }}
}} catch (error) {{
  renderer = "unknown (" + String(error).slice(0, 100) + ")";
}}
try {{ window.localStorage.setItem("{VISER_STORAGE_PREFIX}{RENDERER_KEY}", renderer.slice(0, 300)); }} catch (error) {{}}
"""

#: What the page says when its scene was lightened for it.
LIGHTENED = (
    "This browser renders in software ({renderer}): its scene is drawn without shadows and reflections, "
    "so that clicks land at once."
)
#: What an operator's page adds: where the switch is.
SWITCH = " (Light scene, at the top of the panel, switches it.)"

Notify = Callable[[viser.ClientHandle, str, str, Literal["blue"]], None]


def is_software(renderer: str) -> bool:
    """True if the WebGL renderer's name is one that draws on the CPU (`SOFTWARE`)."""
    return bool(SOFTWARE.search(renderer))


def short_renderer(renderer: str) -> str:
    """The renderer's name as a notification says it: SwiftShader, llvmpipe, ... (else its first 40 characters)."""
    found = SOFTWARE.search(renderer)
    return found.group(0) if found else renderer[:40]


class LightScene:
    """One browser's scene lighting: the operator's switch (None for a guest) and the renderer check."""

    def __init__(
        self, client: viser.ClientHandle, notify: Notify, *, switch: bool, plain: bool, order: float = 0.5
    ) -> None:
        self.client = client
        self.notify = notify
        self.plain = plain  # what the browser draws now (the dashboard's own choice at start: --plain-scene)
        self.renderer: str | None = None  # the page's WebGL renderer, once it said
        self.checkbox: viser.GuiCheckboxHandle | None = None
        if switch:
            self.checkbox = client.gui.add_checkbox(
                "Light scene",
                plain,
                hint="draw the 3D scene without shadows and reflections: for a browser without a GPU, where they "
                "make clicks late (switched on by itself when this browser renders in software)",
                order=order,
            )
            self.checkbox.on_update(lambda _event: self.set_plain(bool(self.checkbox and self.checkbox.value)))

    def set_plain(self, plain: bool) -> None:
        """Draw this browser's scene plain (or with viser's shadows and environment map)."""
        if plain == self.plain:
            return
        self.plain = plain
        (plain_lighting if plain else default_lighting)(self.client.scene)
        if self.checkbox is not None and self.checkbox.value != plain:
            self.checkbox.value = plain  # type: ignore[misc]  # settable at run time; viser 1.1's type says read-only

    def ask_renderer(self) -> threading.Thread:
        """Send the page its probe and read its answer in a thread (`probe`); returns the thread."""
        thread = threading.Thread(target=self.probe, name="wiithrow-web-renderer", daemon=True)
        thread.start()
        return thread

    def probe(self) -> str | None:
        """Ask the page which WebGL renderer it has (blocks until it answers, `ASK_TIMEOUT_S` at
        most); lighten its scene if it renders in software. Returns the renderer (None: no answer)."""
        run_in_page(self.client, PROBE_SCRIPT)
        end = time.monotonic() + ASK_TIMEOUT_S
        renderer, asked = None, 0
        while renderer is None:  # the page answers a request at once, runs a script at its next frame
            left = end - time.monotonic()
            if left <= 0:
                return None
            try:
                renderer = self.client.local_storage.get_item(RENDERER_KEY, timeout=left)
            except (RuntimeError, TimeoutError):  # the page left, blocks localStorage, or never answered
                return None
            if renderer is None:  # asked again, less and less often (a client that is no browser never answers)
                time.sleep(min(ASK_PERIOD_S * 2**asked, left))
                asked += 1
        self.renderer = renderer
        if is_software(self.renderer) and not self.plain:
            self.set_plain(True)
            told = LIGHTENED.format(renderer=short_renderer(self.renderer)) + (SWITCH if self.checkbox else "")
            self.notify(self.client, "Light scene", told, "blue")
        return self.renderer
