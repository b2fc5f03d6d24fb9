"""A viser client without a browser: what the benchmarks' websocket clients (and the access tests)
send and read.

Owns viser 1.1's wire format as a client sees it: a client message is one msgpack map with a
`type` (`encode`; `camera_message` is what a browser sends first, from when viser counts it as
connected; `click` is what a button sends); a server message is a window: two little-endian
lengths (msgpack, compressed), the zstd-compressed msgpack `{"messages": [...]}`, then raw binary
buffers (`decode_window`, which leaves the buffers out). `Buttons` follows the windows of one
connection and knows each button's uuid by its label (the newest of that label: a throw's
confirmation is a new button each time), and whether it is disabled.
"""

from __future__ import annotations

from typing import Any

import msgspec
import viser
import zstandard

#: The websocket subprotocol viser's client offers (viser refuses another version).
PROTOCOL = f"viser-v{viser.__version__}"
CAMERA = {
    "type": "ViewerCameraMessage",
    "wxyz": [1.0, 0.0, 0.0, 0.0],
    "position": [-1.6, -2.6, 2.1],
    "fov": 1.0,
    "near": 0.01,
    "far": 100.0,
    "image_height": 800,
    "image_width": 1280,
    "look_at": [0.9, 0.0, 0.4],
    "up_direction": [0.0, 0.0, 1.0],
}


def encode(message: dict[str, Any]) -> bytes:
    return msgspec.msgpack.encode(message)


def camera_message() -> bytes:
    """A browser's first message: its camera (viser counts the client as connected from then on)."""
    return encode(CAMERA)


def click(uuid: str) -> bytes:
    """What a button sends when clicked."""
    return encode({"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": True}})


def decode_window(data: bytes) -> list[dict[str, Any]]:
    """The messages of one server window (binary buffers left out)."""
    inner = int.from_bytes(data[0:8], "little")
    compressed = int.from_bytes(data[8:16], "little")
    body = zstandard.ZstdDecompressor().decompress(data[16 : 16 + compressed], max_output_size=inner)
    messages = msgspec.msgpack.decode(body).get("messages", [])
    return [m for m in messages if isinstance(m, dict)]


class Buttons:
    """The buttons one connection was sent: label -> uuid (the newest), uuid -> disabled."""

    def __init__(self) -> None:
        self.uuid: dict[str, str] = {}
        self.disabled: dict[str, bool] = {}

    def read(self, data: bytes) -> None:
        for m in decode_window(data):
            kind = m.get("type")
            if kind == "GuiButtonMessage":
                props = m.get("props", {})
                self.uuid[str(props.get("label"))] = m["uuid"]
                self.disabled[m["uuid"]] = bool(props.get("disabled"))
            elif kind == "GuiUpdateMessage":
                updates = m.get("updates", {})
                if "disabled" in updates:
                    self.disabled[m["uuid"]] = bool(updates["disabled"])
                if "label" in updates:  # a relabelled button (Record / Stop recording)
                    self.uuid[str(updates["label"])] = m["uuid"]
            elif kind == "GuiRemoveMessage":
                self.disabled.pop(str(m.get("uuid")), None)

    def enabled(self, label: str) -> bool:
        uuid = self.uuid.get(label)
        return uuid is not None and uuid in self.disabled and not self.disabled[uuid]
