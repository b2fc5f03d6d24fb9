"""DDS types built from the IDL files wiithrow ships (app/ros2/idl/), not from its Python classes.

A reader of the subset those files use (modules, structs, primitive members, `sequence<T>`,
scoped names, `#include`), turned into cyclonedds IdlStruct classes with `make_idl_struct`: what a
ROS 2 user without wiithrow would compile with idlc. (The idlc of the cyclonedds wheel crashes on
this machine, so the tests read the IDL themselves.)
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from cyclonedds.idl import make_idl_struct, types

IDL_DIR = Path(__file__).resolve().parents[2] / "app" / "ros2" / "idl"

_PRIMITIVES: dict[str, Any] = {
    "int8": types.int8,
    "uint8": types.uint8,
    "int16": types.int16,
    "uint16": types.uint16,
    "int32": types.int32,
    "uint32": types.uint32,
    "int64": types.int64,
    "uint64": types.uint64,
    "float": types.float32,
    "double": types.float64,
    "boolean": bool,
    "string": str,
}
_TOKEN = re.compile(r"::|[A-Za-z_][A-Za-z0-9_]*|[{}<>;]")


def load_types(idl_dir: Path = IDL_DIR) -> dict[str, type]:
    """Every struct of the IDL files in `idl_dir`, by its scoped name (`pkg::msg::dds_::Name_`)."""
    structs: dict[str, type] = {}
    done: set[str] = set()

    def read(name: str) -> None:
        if name in done:
            return
        done.add(name)
        text = (idl_dir / name).read_text()
        for include in re.findall(r'#include\s+"([^"]+)"', text):
            read(include)
        text = re.sub(r"//[^\n]*|#[^\n]*", "", text)
        _parse(_TOKEN.findall(text), structs)

    for path in sorted(idl_dir.glob("*.idl")):
        read(path.name)
    return structs


def _parse(tokens: list[str], structs: dict[str, type]) -> None:
    scope: list[str] = []
    opened: list[str] = []  # "module" or "struct" per open brace
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token == "module":
            scope.append(tokens[i + 1])
            opened.append("module")
            i += 3  # module NAME {
        elif token == "struct":
            name = tokens[i + 1]
            i += 3  # struct NAME {
            fields: dict[str, Any] = {}
            while tokens[i] != "}":
                kind, i = _type(tokens, i, scope, structs)
                fields[tokens[i]] = kind
                i += 2  # NAME ;
            i += 2  # } ;
            full = "::".join([*scope, name])
            structs[full] = make_idl_struct(name, full.replace("::", "."), fields)
        elif token == "}":
            if opened.pop() == "module":
                scope.pop()
            i += 2  # } ;
        else:
            raise ValueError(f"unexpected IDL token {token!r}")


def _type(tokens: list[str], i: int, scope: list[str], structs: dict[str, type]) -> tuple[Any, int]:
    if tokens[i] == "sequence":
        inner, i = _type(tokens, i + 2, scope, structs)  # sequence <
        return types.sequence[inner], i + 1  # >
    name = tokens[i]
    i += 1
    while i < len(tokens) and tokens[i] == "::":
        name += "::" + tokens[i + 1]
        i += 2
    if name in _PRIMITIVES:
        return _PRIMITIVES[name], i
    for depth in range(len(scope), -1, -1):  # the innermost scope that names it
        full = "::".join([*scope[:depth], name])
        if full in structs:
            return structs[full], i
    raise ValueError(f"IDL type {name!r} is not defined before its use")
