"""The messages a dashboard page sends, as typed schemas: decoding a client's message is bounded.

Owns `decode_client_message`, which `wiithrow.web.access.admit_message` applies to every message
a client sends before anything else looks at it. viser's own decoding (`Message.deserialize`) is
msgpack to Python objects of any depth, then the message's constructor: a message nested 1 000
deep (2 KB) raised RecursionError, a camera message without its fields a TypeError in viser's
consumer, each a traceback. Here every message is decoded by msgspec against the schema of its
type (`tag_field="type"`), with every field a scalar, a short string or a tuple of numbers of fixed
length, unknown fields refused at their name (before their value is read): what decodes has at
most three levels, and what does not is one line (msgspec's own reason, e.g. ``Expected `float`,
got `array` - at `$.wxyz[0]```).

The types are those viser 1.1's page sends for what this dashboard shows (its client source,
`viser/client/src`: the camera, GUI values, the transform gizmo's drag, the answer to a
localStorage request (the renderer check of `wiithrow.web.light_scene`); measured in Chromium: a
camera message is 231 bytes, a click 82) and the share-tunnel requests (decoded so that they are
refused by name). A message of any other type is refused. Numbers are finite and within
`LIMIT` (NaN and inf are refused); strings at most `MAX_TEXT` characters.

One case recurses in msgspec itself: a map whose fields before `type` must be skipped to find it
(msgspec skips them recursively, up to the interpreter's recursion limit, then raises
RecursionError); that is caught and refused in one line too (viser's page sends `type` first).
"""

from __future__ import annotations

from typing import Annotated

import msgspec

#: The largest magnitude of a number in a client message (metres, pixels, radians).
LIMIT = 1e6
#: The longest string in a client message (uuids are 36 characters, node names short).
MAX_TEXT = 1000

Number = Annotated[float, msgspec.Meta(ge=-LIMIT, le=LIMIT)]
Count = Annotated[int, msgspec.Meta(ge=0, le=int(LIMIT))]
Text = Annotated[str, msgspec.Meta(max_length=MAX_TEXT)]
Vec3 = tuple[Number, Number, Number]
Quaternion = tuple[Number, Number, Number, Number]
#: A GUI element's value in this dashboard: a button's True, a number, a dropdown's option.
Value = bool | Annotated[int, msgspec.Meta(ge=-int(LIMIT), le=int(LIMIT))] | Number | Text | None


class ClientMessage(msgspec.Struct, tag_field="type", tag=True, forbid_unknown_fields=True):
    """A message from a client; the class name is its `type`."""


class ViewerCameraMessage(ClientMessage):
    wxyz: Quaternion
    position: Vec3
    fov: Number
    near: Number
    far: Number
    image_height: Count
    image_width: Count
    look_at: Vec3
    up_direction: Vec3


class GuiUpdateMessage(ClientMessage):
    uuid: Text
    updates: dict[Text, Value]


class TransformControlsUpdateMessage(ClientMessage):
    name: Text
    wxyz: Quaternion
    position: Vec3
    owner: Text = ""


class TransformControlsDragStartMessage(ClientMessage):
    name: Text
    owner: Text = ""


class TransformControlsDragEndMessage(ClientMessage):
    name: Text
    owner: Text = ""


class LocalStorageGetItemResponseMessage(ClientMessage):
    """The page's answer to the server's localStorage request (`wiithrow.web.light_scene`)."""

    value: Text | None
    error: Text | None
    request_uuid: Text


class ShareUrlRequest(ClientMessage):
    pass


class ShareUrlDisconnect(ClientMessage):
    pass


AnyClientMessage = (
    ViewerCameraMessage
    | GuiUpdateMessage
    | TransformControlsUpdateMessage
    | TransformControlsDragStartMessage
    | TransformControlsDragEndMessage
    | LocalStorageGetItemResponseMessage
    | ShareUrlRequest
    | ShareUrlDisconnect
)
#: The `type`s a client may send (any other is refused).
KNOWN_TYPES = frozenset(
    t.__name__
    for t in (
        ViewerCameraMessage,
        GuiUpdateMessage,
        TransformControlsUpdateMessage,
        TransformControlsDragStartMessage,
        TransformControlsDragEndMessage,
        LocalStorageGetItemResponseMessage,
        ShareUrlRequest,
        ShareUrlDisconnect,
    )
)
_DECODER = msgspec.msgpack.Decoder(AnyClientMessage)


def decode_client_message(raw: bytes) -> ClientMessage | str:
    """The message, or a one-line reason why it is not one a dashboard page sends."""
    try:
        return _DECODER.decode(raw)
    except msgspec.ValidationError as exc:
        return f"a message not of the page's schema ({exc})"
    except msgspec.DecodeError:
        return "an undecodable message"
    except RecursionError:
        return "a message nested deeper than the interpreter's recursion limit"
