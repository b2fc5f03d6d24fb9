"""Strict JSON for the tests: what any JSON parser accepts (no NaN, no Infinity)."""

import json


def _refuse(constant):
    raise ValueError(f"{constant} is not JSON")


def loads_strict(text: str):
    """The one JSON document in `text`; ValueError on NaN/Infinity, on anything before or after it."""
    return json.loads(text, parse_constant=_refuse)
