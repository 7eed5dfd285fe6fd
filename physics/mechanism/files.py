"""Reading a mechanism file (TOML or JSON) into a validated :class:`~physics.mechanism.description.Mechanism`.

The file is the user's; every refusal is one line that names the file, the element (the body or joint by its
name, not by its position in a list) and the field, so the command line can print it and the app can show it
as a notice. Size is bounded before parsing.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from ..errors import LinkageError
from ..file_io import read_limited
from .description import Body, Driver, Mechanism
from .joints import KINDS

MAX_FILE_BYTES = 1_000_000
_SURROGATE = re.compile("[\ud800-\udfff]")
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")  # JSON's escape of one (a pair's halves included)


def _element_name(document: Any, location: tuple) -> str:
    """``bodies[2].mass`` reads ``body 'rod': mass`` when the element has a name."""
    parts: list[str] = []
    node = document
    index = 0
    while index < len(location):
        key = location[index]
        if isinstance(key, str) and key in ("bodies", "joints", "drivers") and index + 1 < len(location):
            position = location[index + 1]
            element = node.get(key, []) if isinstance(node, dict) else []
            item = element[position] if isinstance(position, int) and position < len(element) else None
            label = {"bodies": "body", "joints": "joint", "drivers": "driver"}[key]
            name = item.get("name", item.get("joint")) if isinstance(item, dict) else None
            parts.append(f"{label} {name!r}" if name is not None else f"{label} {position + 1}")
            node = item
            index += 2
            continue
        if isinstance(key, str) and key not in KINDS:
            parts.append(key)
        node = node.get(key) if isinstance(node, dict) else None
        index += 1
    return ": ".join(parts)


def _lone_surrogate(node: Any, location: tuple = ()) -> tuple[tuple, str] | None:
    """Where the first text (a key or a value) holding a lone surrogate is, and that text; None when none does.
    JSON may escape one (``"\\ud800"``): it is no character, so no UTF-8 file, TOML or CSV can write it back."""
    if isinstance(node, str):
        return (location, node) if _SURROGATE.search(node) else None
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        if isinstance(key, str) and _SURROGATE.search(key):
            return location, key
        found = _lone_surrogate(value, (*location, key))
        if found is not None:
            return found
    return None


def check_unicode(document: Any, source: str) -> None:
    """LinkageError naming the element and the text when JSON's escapes put a lone surrogate in ``document``.
    Called where JSON enters (a file, a design link), not for every document: a design's own are checked."""
    surrogate = _lone_surrogate(document)
    if surrogate is not None:
        location, text = surrogate
        where = _element_name(document, location)
        raise LinkageError(f"{source}: {where + ': ' if where else ''}{text!r}: not Unicode text (a lone surrogate "
                           "escape); a mechanism file is UTF-8 text")


def mechanism_from_document(document: Any, source: str = "mechanism") -> Mechanism:
    """A Mechanism from parsed JSON/TOML; LinkageError naming the element and the field."""
    if not isinstance(document, dict):
        raise LinkageError(f"{source}: expected a table of name, g, ground, bodies, joints, drivers")
    try:
        return Mechanism.model_validate(document)
    except ValidationError as error:
        item = error.errors()[0]
        where = _element_name(document, tuple(item.get("loc", ())))
        message = str(item.get("msg", "invalid")).removeprefix("Value error, ")
        if item.get("type") in ("finite_number", "float_type"):
            message = _number_message(tuple(item.get("loc", ())), item.get("input"), message)
        raise LinkageError(f"{source}: {where + ': ' if where else ''}{message}") from None


_MODELS: tuple[type[BaseModel], ...] = (Body, *(kind.model for kind in KINDS.values()), Driver, Mechanism)


def _allowed_range(field: str) -> str:
    """``0 <= mass <= 1e+06`` from the models' own bounds (the first model with that field)."""
    for model in _MODELS:
        info = model.model_fields.get(field)
        if info is None:
            continue
        low = next((getattr(m, "ge") for m in info.metadata if hasattr(m, "ge")), None)
        high = next((getattr(m, "le") for m in info.metadata if hasattr(m, "le")), None)
        if low is not None and high is not None:
            return f"{low:g} <= {field} <= {high:g}"
    return ""


def _number_message(location: tuple, value: Any, message: str) -> str:
    """NaN, infinity, text or a boolean where a number belongs: say it must be a finite number, with the range
    (pydantic's own words for NaN compared it with the upper bound)."""
    field = next((str(part) for part in reversed(location) if isinstance(part, str) and part not in
                  (*KINDS, "float")), "")
    allowed = _allowed_range(field)
    got = f"got {value!r}" if not isinstance(value, (dict, list)) else f"got {type(value).__name__}"
    return f"must be a finite number ({got})" + (f"; allowed range {allowed}" if allowed else "")


def load_mechanism(path: str | Path) -> Mechanism:
    """Read ``path`` (``.toml`` or ``.json``); one-line LinkageError for every problem. A device (``/dev/zero``),
    a FIFO or a folder is refused, and at most MAX_FILE_BYTES + 1 bytes are read whatever ``stat`` says
    (physics.files.read_limited): the command line and ``python -m app --mechanism`` both read through here."""
    path = Path(path)
    content = read_limited(path, MAX_FILE_BYTES, str(path))
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        raise LinkageError(f"{path}: not UTF-8 text") from None
    return mechanism_from_text(text, str(path))


def mechanism_from_bytes(content: bytes, name: str) -> Mechanism:
    """A file's content as uploaded (the app): the same checks as :func:`load_mechanism`, ``name`` its file
    name (its suffix chooses TOML or JSON)."""
    if len(content) > MAX_FILE_BYTES:
        raise LinkageError(f"{name}: {len(content)} bytes, more than the {MAX_FILE_BYTES} a mechanism file may hold")
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        raise LinkageError(f"{name}: not UTF-8 text") from None
    return mechanism_from_text(text, name)


def mechanism_from_text(text: str, name: str) -> Mechanism:
    """Parse ``text`` as TOML or JSON by the suffix of ``name`` (a path or file name) and validate it."""
    path = name
    suffix = Path(name).suffix.lower()
    try:
        if suffix == ".json":
            document = json.loads(text)
            if _SURROGATE_ESCAPE.search(text):
                check_unicode(document, path)
        elif suffix == ".toml":
            if sys.version_info < (3, 11):
                raise LinkageError(f"{path}: TOML files need Python 3.11 or newer; write it as JSON")
            import tomllib  # noqa: PLC0415 - standard library from Python 3.11 only

            document = tomllib.loads(text)
        else:
            raise LinkageError(f"{path}: expected a .toml or .json file")
    except (ValueError, RecursionError) as error:
        if isinstance(error, LinkageError):
            raise
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise LinkageError(f"{path}: not valid {suffix[1:].upper()} ({first})") from None
    return mechanism_from_document(document, str(path))
