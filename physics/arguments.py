"""Command-line argument parsing shared by ``python -m physics`` and the studies' commands.

Why a module of its own: the CLI and every study (``bench``, ``chaos-map``, ``physics.stability``) read
arguments the same way and must fail the same way (one line naming the option, exit status 2), so the parser
and the small value readers live here, below both, instead of in the CLI where the studies had to borrow a
private class.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterable, Sequence
from typing import NoReturn

from .errors import LinkageError


class Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument as one line (a LinkageError), like every other error here."""

    def error(self, message: str) -> NoReturn:
        raise LinkageError(f"{self.prog}: {message}")


def parse_set(items: Iterable[str] | None) -> dict[str, str]:
    """``--set NAME=VALUE`` items -> ``{NAME: VALUE}`` (values stay text; the models parse and bound them)."""
    overrides = {}
    for item in items or []:
        if "=" not in item:
            raise LinkageError(f"--set {item!r}: expected NAME=VALUE, e.g. --set L3=2")
        name, value = item.split("=", 1)
        overrides[name.strip()] = value.strip()
    return overrides


def parse_floats(text: str, field: str, count: int | None = None) -> list[float]:
    """Comma-separated finite numbers, exactly ``count`` of them when given."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise LinkageError(f"{field} = {text!r}: expected comma-separated numbers") from None
    if count is not None and len(values) != count:
        raise LinkageError(f"{field} = {text!r}: expected {count} comma-separated numbers, got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise LinkageError(f"{field} = {text!r}: every entry must be a finite number")
    return values


def parse_integers(text: str, field: str, low: int, high: int) -> list[int]:
    """Comma-separated whole numbers in ``low..high`` (``1.5`` is refused, not truncated)."""
    values = []
    for part in text.split(","):
        part = part.strip()
        if not part.lstrip("+").isdigit() or not low <= int(part) <= high:
            raise LinkageError(f"{field} = {text!r}: expected comma-separated whole numbers {low}..{high}")
        values.append(int(part))
    return values


def parse_names(text: str | None, allowed: Sequence[str], field: str) -> tuple[str, ...] | None:
    """Comma-separated names, each one of ``allowed``; ``None`` when the option was not given."""
    if text is None:
        return None
    values = [v.strip() for v in text.split(",") if v.strip()]
    for value in values:
        if value not in allowed:
            raise LinkageError(f"{field} = {value!r}: allowed {', '.join(allowed)}")
    return tuple(values)
