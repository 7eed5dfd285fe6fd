"""Share links: a page address whose query sets up a session (``?preset=double&L1=1.5&theta1=60&method=dae``), and
the link for the current setup.

How the query reaches the server: viser's client opens its websocket at the page's own address without the
query, so the page's loading screen (``static/page.html``) moves the setup into the websocket's path,
``/setup/<the query, percent-encoded>``, before viser's client starts; the server reads that path
(:func:`app.viser_compat.connection_path`) and applies each name through the session's command layer, as a
typed value: numbers in the panel's units (degrees, degrees per second, milliseconds), every bound the models'.
"""

from __future__ import annotations

import json
import math
import urllib.parse
from typing import Callable, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, StrictStr, ValidationError

from physics import LinkageError, preset_names
from physics.mechanism import MECHANISM_PRESETS

from . import commands
from .commands import CONTROL, DEG
from .parameters import SessionParameters, driving_count

SETUP_PATH = "/setup/"
MAX_SETUP_CHARS = 4000  # a share link a person could paste; anything longer is refused, not parsed
MAX_SETUP_NAMES = 80  # 12 bars x (L, d, m, I, theta, omega) and the settings
FIRST = ("preset", "links")  # the mechanism comes first: the other names are its bars and settings
SETTINGS = ("method", "integrator", "rtol", "step", "stabilization", "baumgarte_alpha", "baumgarte_beta", "damping")


def setup_from_path(path: str | None) -> list[tuple[str, str]] | None:
    """The ``(name, value)`` pairs a websocket path carries (None: not a setup path); LinkageError if the link is
    too long or has too many names."""
    if not path or not path.startswith(SETUP_PATH):
        return None
    encoded = path[len(SETUP_PATH):]
    if len(encoded) > MAX_SETUP_CHARS:
        raise LinkageError(f"link: {len(encoded)} characters; at most {MAX_SETUP_CHARS}")
    pairs = urllib.parse.parse_qsl(urllib.parse.unquote(encoded), keep_blank_values=True)
    if len(pairs) > MAX_SETUP_NAMES:
        raise LinkageError(f"link: {len(pairs)} values; at most {MAX_SETUP_NAMES}")
    return pairs


def start_of(pairs: list[tuple[str, str]], preset: str, links: int | None,
             mechanisms: bool = False) -> tuple[str, int | None, list[str]]:
    """The link's mechanism and number of bars (the session is made with them, before anything else), else
    ``preset`` and ``links``; with the refusals (one line each). ``mechanisms``: a general mechanism's preset
    (``jansen-leg``) is a start too (a new browser's link; a chain's setup file names chains only)."""
    values = dict(pairs)
    refused = []
    allowed = [*preset_names(), *(MECHANISM_PRESETS if mechanisms else ())]
    if "preset" in values:
        name = values["preset"]
        if name in allowed:
            preset, links = name, None
        else:
            refused.append(f"preset = {name!r}: allowed {', '.join(allowed)}")
    if "links" in values:
        if preset != "chain":
            refused.append("links: only the 'chain' mechanism has a variable number of bars")
        else:
            try:
                links = commands.parse_links(values["links"])
            except LinkageError as error:
                refused.append(str(error))
    return preset, links, refused


def apply_setup(pairs: list[tuple[str, str]], set_value: Callable[[str, str], None]) -> list[str]:
    """Apply each pair except the mechanism (see :func:`start_of`) with ``set_value(name, text)`` (the session's
    ``set(name, text, units=CONTROL)``), in the link's order; returns the refusals (one line each), the rest
    applied."""
    refused = []
    for name, text in pairs:
        if name in FIRST:
            continue
        try:
            set_value(name, text)
        except LinkageError as error:
            refused.append(str(error))
    return refused


def check_setup(pairs: list[tuple[str, str]], preset: str, links: int | None) -> SessionParameters:
    """The parameters ``pairs`` set up from ``preset``; LinkageError naming the first value refused (a setup
    file given on the command line must be right as a whole)."""
    preset, links, refused = start_of(pairs, preset, links)
    if refused:
        raise LinkageError(refused[0])
    params = SessionParameters.from_preset(preset, links=links)
    for name, text in pairs:
        if name not in FIRST:
            params = commands.apply(params, name, text, CONTROL).params
    return params


def merged(saved: list[tuple[str, str]], link: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """A server's saved setup (``--state``) with a link's on top; a link that names its own mechanism replaces
    the saved setup (whose values belong to another mechanism)."""
    if any(name == "preset" for name, _ in link):
        return list(link)
    return [*saved, *link]


def _number(value: float) -> str:
    return f"{value:.12g}"


def link_query(params: SessionParameters) -> str:
    """The query for ``params``: the preset and every value that differs from the preset's own (so a link stays
    short and reads as what was changed), numbers in the panel's units."""
    base = SessionParameters.from_preset(params.preset, links=params.links if params.preset == "chain" else None)
    pairs: list[tuple[str, str]] = [("preset", params.preset)]
    if params.preset == "chain":
        pairs.append(("links", str(params.n)))
    for name in SETTINGS:
        value, default = getattr(params, name if name != "rtol" else "tolerance"), getattr(
            base, name if name != "rtol" else "tolerance")
        if value != default:
            shown = value * 1e3 if name == "step" else value
            pairs.append((name, _number(shown) if isinstance(value, float) else str(value)))
    if params.g != base.g:
        pairs.append(("g", _number(params.g)))
    for field in ("L", "d", "m", "I"):
        for k, (value, default) in enumerate(zip(getattr(params, field), getattr(base, field)), start=1):
            if value != default:
                pairs.append((f"{field}{k}", _number(value)))
    if params.pin is not None and base.pin is not None:
        for axis, value, default in zip(("pin_x", "pin_y"), params.pin, base.pin):
            if value != default:
                pairs.append((axis, _number(value)))
    for k in range(driving_count(params.n, params.pinned)):
        if not math.isclose(params.theta0[k], base.theta0[k], abs_tol=1e-12):
            pairs.append((f"theta{k + 1}", _number(params.theta0[k] * DEG)))
    if not params.pinned:
        for k in range(params.n):
            if params.omega0[k] != base.omega0[k]:
                pairs.append((f"omega{k + 1}", _number(params.omega0[k] * DEG)))
    return "?" + urllib.parse.urlencode(pairs)


UNITS = CONTROL  # the units a link's numbers are in

# ------------------------------------------------------------------------------------------ setup files
MAX_STATE_BYTES = 65536
STATE_NAME = "linkage-lab-setup.json"


class SetupFile(BaseModel):
    """A saved setup: the names and values of a share link, as JSON (numbers in the panel's units)."""

    model_config = ConfigDict(extra="forbid")

    linkage_lab_setup: Literal[1] = Field(description="the format's version")
    values: dict[StrictStr, Union[StrictInt, StrictFloat, StrictStr]] = Field(max_length=MAX_SETUP_NAMES)


def state_document(params: SessionParameters) -> bytes:
    """The current setup as a JSON file that :func:`pairs_from_state` reads back."""
    values: dict[str, float | str] = {}
    for name, text in urllib.parse.parse_qsl(link_query(params)[1:]):
        try:
            values[name] = int(text) if name == "links" else float(text)
        except ValueError:  # a name: preset, method, integrator, stabilization
            values[name] = text
    return (json.dumps({"linkage_lab_setup": 1, "values": values}, indent=2) + "\n").encode()


def pairs_from_state(data: bytes, where: str = "setup file") -> list[tuple[str, str]]:
    """The ``(name, value)`` pairs of a saved setup; LinkageError (one line naming what is wrong) otherwise."""
    if len(data) > MAX_STATE_BYTES:  # the reader stops one byte past the limit: the size is not known here
        raise LinkageError(f"{where}: over {MAX_STATE_BYTES} bytes; a setup file is at most {MAX_STATE_BYTES}")
    try:
        document = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise LinkageError(f"{where}: not UTF-8 text") from None
    except json.JSONDecodeError as error:
        raise LinkageError(f"{where}: not valid JSON ({error.msg}, line {error.lineno})") from None
    except RecursionError:
        raise LinkageError(f"{where}: nested too deeply") from None
    try:
        setup = SetupFile.model_validate(document)
    except ValidationError as error:
        first = error.errors()[0]
        field = ".".join(str(part) for part in first.get("loc", ())) or "the file"
        raise LinkageError(f"{where}: {field}: {first.get('msg', 'invalid')} "
                           f"(expected {{\"linkage_lab_setup\": 1, \"values\": {{\"L1\": 1.5, ...}}}})") from None
    return [(name, value if isinstance(value, str) else repr(value)) for name, value in setup.values.items()]
