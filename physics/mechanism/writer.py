"""A Mechanism written in our own file format (docs/mechanisms.md), TOML or JSON, as :mod:`.files` reads it.

Why: a mechanism that came from elsewhere (a pylinkage file, a chain preset) becomes a file the user can read,
edit and run with ``python -m physics mechanism --file``. The standard library reads TOML but does not write it;
the format's few shapes (strings, numbers, points, tables of points, arrays of tables) are written here.
"""

from __future__ import annotations

import json
import re

from .description import Mechanism

_BEYOND_ASCII = re.compile(r"[^\x00-\x7e]")


def to_document(mechanism: Mechanism) -> dict:
    """The mechanism as the JSON document :func:`physics.mechanism.files.mechanism_from_document` reads."""
    return mechanism.model_dump(mode="json", exclude_none=True)


def to_json(mechanism: Mechanism) -> str:
    return json.dumps(to_document(mechanism), indent=2) + "\n"


def _string(text: str) -> str:
    r"""``text`` as a TOML basic string. JSON's escapes are TOML's but one: JSON writes a character beyond U+FFFF
    as two surrogates' escapes, which TOML refuses (a name the file format takes, saved as TOML that would not
    read back); TOML's escape for it is ``\UXXXXXXXX``. Every other character beyond ASCII, and DEL, is written
    ``\uXXXX`` (the file stays ASCII, as JSON's own escaping kept it)."""
    return _BEYOND_ASCII.sub(_escaped, json.dumps(text, ensure_ascii=False))


def _escaped(found: re.Match) -> str:
    code = ord(found[0])
    return f"\\U{code:08x}" if code > 0xFFFF else f"\\u{code:04x}"


def _value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(float(value))  # finite (the model refuses the rest); shortest text of the same double
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(item) for item in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_string(str(key))} = {_value(item)}" for key, item in value.items()) + " }"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def to_toml(mechanism: Mechanism) -> str:
    """The mechanism as a TOML file (top-level keys, ``[ground]``, then ``[[bodies]]``, ``[[joints]]`` and
    ``[[drivers]]``)."""
    document = to_document(mechanism)
    lines = [f"{key} = {_value(document[key])}" for key in ("name", "description", "g", "trace") if key in document]
    lines += ["", "[ground]"] + [f"{_string(name)} = {_value(xy)}" for name, xy in document["ground"].items()]
    for table in ("bodies", "joints", "drivers"):
        for item in document.get(table, []):
            lines += ["", f"[[{table}]]"] + [f"{key} = {_value(value)}" for key, value in item.items()]
    return "\n".join(lines) + "\n"
