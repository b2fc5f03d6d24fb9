"""The ROS 2 type hash (`RIHS01_<sha256 hex>`) of a message type, as rosidl computes it (REP 2011,
"Type Description Distribution"; ROS 2 Iron and later put it in each endpoint's USER_DATA:
`user_data`).

A message's hash is the SHA-256 of a JSON text: its type description (its name `pkg/msg/Name` and,
in order, each field's name and type) and the descriptions of every type it refers to, directly
or not, sorted by name (`type_description_interfaces/msg/TypeDescription`). A field's type is
`type_id` (`type_description_interfaces/msg/FieldType`: `FIELD_TYPE_IDS` for a single value;
+48 for a fixed array, +96 for a bounded sequence, +144 for an unbounded one), `capacity` (the
array's length or the sequence's bound, else 0), `string_capacity` (a bounded string's bound, else
0) and `nested_type_name` (a message field's type name, else ''). Comments, constants and default
values are not part of it. The JSON is Python's `json.dumps` with its default separators (', ',
': '), keys in the order written here: what `rosidl_generator_type_description` hashes.

The description is read from the message's cyclonedds class (`messages`, `discovery`): field by
field in declaration order, `types.int32` -> int32, Python `float` -> float64, `str` -> string,
`types.bounded_str[N]` -> string<=N, `types.array[T, N]` -> T[N], `types.sequence[T]` -> T[],
another IdlStruct -> nested, its DDS name `pkg::msg::dds_::Name_` read as `pkg/msg/Name`. A `.msg`
`char` is `uint8` in rosidl's IDL, and hashed as such (`rmw_dds_common/msg/Gid`).
"""

from __future__ import annotations

import hashlib
import json
import typing
from functools import cache
from typing import Any

#: type_description_interfaces/msg/FieldType's ids of the single-value types (REP 2011).
FIELD_TYPE_IDS = {
    "int8": 2,
    "uint8": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "bool": 15,
    "byte": 16,
    "string": 17,
    "bounded_string": 21,
}
NESTED_TYPE = 1
ARRAY_OFFSET, BOUNDED_SEQUENCE_OFFSET, UNBOUNDED_SEQUENCE_OFFSET = 48, 96, 144
HASH_PREFIX = "RIHS01_"


def ros_type_name(kind: type) -> str:
    """`pkg/msg/Name` of a cyclonedds message class whose DDS name is `pkg::msg::dds_::Name_`."""
    package, interface, _dds, name = kind.__idl_typename__.replace("::", ".").split(".")  # type: ignore[attr-defined]
    return f"{package}/{interface}/{name.removesuffix('_')}"


def _element(annotation: Any) -> tuple[int, int, str]:
    """(type id, string capacity, nested type name) of one element type."""
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl import types as t

    if isinstance(annotation, type) and issubclass(annotation, IdlStruct):
        return NESTED_TYPE, 0, ros_type_name(annotation)
    plain = {float: "float64", str: "string", bool: "bool"}.get(annotation)
    if plain is not None:
        return FIELD_TYPE_IDS[plain], 0, ""
    if typing.get_origin(annotation) is typing.Annotated:
        tag = typing.get_args(annotation)[1]
        if isinstance(tag, t.bounded_str):
            return FIELD_TYPE_IDS["bounded_string"], tag.max_length, ""
        if isinstance(tag, str) and tag in FIELD_TYPE_IDS:
            return FIELD_TYPE_IDS[tag], 0, ""
    raise TypeError(f"no ROS 2 field type for {annotation!r}")


def _field(name: str, annotation: Any) -> dict[str, Any]:
    from cyclonedds.idl import types as t

    offset, capacity, element = 0, 0, annotation
    if typing.get_origin(annotation) is typing.Annotated:
        holder = typing.get_args(annotation)[1]
        if isinstance(holder, t.array):
            offset, capacity, element = ARRAY_OFFSET, holder.length, holder.subtype
        elif isinstance(holder, t.sequence):
            bounded = holder.max_length is not None
            offset = BOUNDED_SEQUENCE_OFFSET if bounded else UNBOUNDED_SEQUENCE_OFFSET
            capacity, element = holder.max_length or 0, holder.subtype
    type_id, string_capacity, nested = _element(element)
    return {
        "name": name,
        "type": {
            "type_id": offset + type_id,
            "capacity": capacity,
            "string_capacity": string_capacity,
            "nested_type_name": nested,
        },
    }


def _nested(annotation: Any) -> type | None:
    """The message class a field refers to (itself, or its array's or sequence's element), if any."""
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl import types as t

    if typing.get_origin(annotation) is typing.Annotated:
        holder = typing.get_args(annotation)[1]
        if isinstance(holder, (t.array, t.sequence)):
            annotation = holder.subtype
    return annotation if isinstance(annotation, type) and issubclass(annotation, IdlStruct) else None


def type_description(kind: type) -> dict[str, Any]:
    """The hashed form of `kind`'s TypeDescription (module docstring): its own description and
    those of the types it refers to, sorted by name."""
    described: dict[str, dict[str, Any]] = {}

    def describe(message: type) -> None:
        name = ros_type_name(message)
        if name in described:
            return
        hints = typing.get_type_hints(message, include_extras=True)
        described[name] = {"type_name": name, "fields": [_field(f, a) for f, a in hints.items()]}
        for annotation in hints.values():
            nested = _nested(annotation)
            if nested is not None:
                describe(nested)

    describe(kind)
    top = described.pop(ros_type_name(kind))
    return {"type_description": top, "referenced_type_descriptions": [described[n] for n in sorted(described)]}


@cache
def type_hash(kind: type) -> str:
    """`RIHS01_` and the SHA-256 (hex) of `kind`'s type description (module docstring)."""
    text = json.dumps(type_description(kind))  # separators (', ', ': '): rosidl's
    return HASH_PREFIX + hashlib.sha256(text.encode()).hexdigest()
