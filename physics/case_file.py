"""The ``accelerations --input cases.json`` file: a list of cases, each validated by its own pydantic model.

A file a user wrote by hand, or a script generated, is outside input: every shape is checked (numbers where
numbers belong, one angle per bar, whole-number link counts) and sized (the file, the number of cases) before
anything is allocated from it, and every refusal names the case and the field: ``case 7: theta: ...``.
"""

from __future__ import annotations

import json
import math
from typing import Optional

from pydantic import BaseModel, ConfigDict, Field, StrictInt, ValidationError, field_validator, model_validator

from .errors import LinkageError
from .file_io import read_limited
from .model import MAX_LINKS

MAX_FILE_BYTES = 16 * 1024 * 1024
MAX_CASES = 100_000


def _finite_number(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a number, got {type(value).__name__}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, got {value}")
    return number


class Case(BaseModel):
    """One state of one chain: ``links``, ``params`` (``L1..Ln d1..dn m1..mn I1..In`` and optionally ``g``),
    ``theta`` and optionally ``omega`` (one entry per bar) and ``pin`` (``[x, y]``, a closed chain)."""

    model_config = ConfigDict(extra="forbid")

    links: StrictInt = Field(ge=1, le=MAX_LINKS)
    params: dict[str, float]
    theta: list[float]
    omega: Optional[list[float]] = None
    pin: Optional[tuple[float, float]] = None

    @field_validator("params", mode="before")
    @classmethod
    def _params_are_numbers(cls, value):
        if not isinstance(value, dict):
            raise ValueError("expected an object of name: number, e.g. {\"L1\": 1.0, ...}")
        return {str(key): _finite_number(item, str(key)) for key, item in value.items()}

    @field_validator("theta", "omega", mode="before")
    @classmethod
    def _angles_are_numbers(cls, value, info):
        if value is None and info.field_name == "omega":
            return None
        if not isinstance(value, list):
            raise ValueError("expected a list of numbers, one per bar")
        return [_finite_number(item, f"{info.field_name}[{i}]") for i, item in enumerate(value)]

    @field_validator("pin", mode="before")
    @classmethod
    def _pin_is_a_point(cls, value):
        if value is None:
            return None
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise ValueError("expected [x, y]")
        return tuple(_finite_number(item, "pin") for item in value)

    @model_validator(mode="after")
    def _one_entry_per_bar(self) -> "Case":
        n = self.links
        for name in ("theta", "omega"):
            values = getattr(self, name)
            if values is not None and len(values) != n:
                raise ValueError(f"{name}: expected {n} numbers (one per bar), got {len(values)}")
        expected = {f"{f}{i}" for f in "LdmI" for i in range(1, n + 1)}
        missing = sorted(expected - set(self.params))
        unknown = sorted(set(self.params) - expected - {"g"})
        if missing:
            raise ValueError(f"params: missing {', '.join(missing)}")
        if unknown:
            raise ValueError(f"params: unknown {', '.join(unknown)} (allowed L1..L{n}, d, m, I likewise, and g)")
        return self


def _case_error(index: int, error: ValidationError) -> LinkageError:
    item = error.errors()[0]
    location = ".".join(str(part) for part in item.get("loc", ()))
    message = str(item.get("msg", "invalid")).removeprefix("Value error, ")
    return LinkageError(f"case {index}: {location + ': ' if location else ''}{message}")


def read_cases(path: str) -> list[Case]:
    """The validated cases of the file at ``path``; LinkageError (one line) for anything else."""
    content = read_limited(path, MAX_FILE_BYTES, f"--input {path}")
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError as error:
        raise LinkageError(f"--input {path}: not UTF-8 text (byte {error.start}); save the file as UTF-8") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise LinkageError(f"--input {path}: not valid JSON ({error.msg} at line {error.lineno})") from None
    except RecursionError:
        raise LinkageError(f"--input {path}: JSON nested too deeply") from None
    if not isinstance(data, list):
        raise LinkageError(f"--input {path}: expected a JSON list of cases, got {type(data).__name__}")
    if len(data) > MAX_CASES:
        raise LinkageError(f"--input {path}: {len(data)} cases, more than the {MAX_CASES} allowed")
    cases = []
    for index, item in enumerate(data):
        if not isinstance(item, dict):
            raise LinkageError(f"case {index}: expected an object with links, params, theta, omega")
        try:
            cases.append(Case.model_validate(item))
        except ValidationError as error:
            raise _case_error(index, error) from None
        except RecursionError:
            raise LinkageError(f"case {index}: nested too deeply") from None
    return cases
