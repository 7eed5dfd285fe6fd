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
from dataclasses import dataclass
from typing import Any, Callable, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, StrictStr, ValidationError

from physics import LinkageError, preset_names
from physics.mechanism import MECHANISM_PRESETS, Mechanism
from physics.mechanism.files import mechanism_from_document

from . import commands
from .commands import CONTROL, DEG
from .parameters import SessionParameters, driving_count

SETUP_PATH = "/setup/"
MAX_SETUP_CHARS = 4000  # a share link a person could paste; anything longer is refused, not parsed
MAX_SKETCH_CHARS = 6000  # a design's link (sketch=, app/design_view.py): its compressed design, counted apart
MAX_SETUP_NAMES = 80  # 12 bars x (L, d, m, I, theta, omega) and the settings
FIRST = ("preset", "links")  # the mechanism comes first: the other names are its bars and settings
SETTINGS = ("method", "integrator", "rtol", "step", "stabilization", "baumgarte_alpha", "baumgarte_beta", "damping")


def flag_from(setup: list[tuple[str, str]], key: str, default: bool,
              meaning: str) -> tuple[list[tuple[str, str]], bool, list[str]]:
    """A link's on/off switch ``key=1`` (or ``0``) taken out of its setup: the setup without it, whether it is on
    (``default`` when the link does not say), and the reason a value other than 0 or 1 is not applied, which
    says what ``key=1`` does (``meaning``)."""
    values = [value for name, value in setup if name == key]
    rest = [(name, value) for name, value in setup if name != key]
    if not values:
        return rest, default, []
    value = values[-1].strip().lower()
    if value in ("1", "true", "on", ""):
        return rest, True, []
    if value in ("0", "false", "off"):
        return rest, False, []
    return rest, default, [f"{key}: {values[-1][:20]!r} is not 0 or 1 ({key}=1 {meaning})"]


def setup_from_path(path: str | None) -> list[tuple[str, str]] | None:
    """The ``(name, value)`` pairs a websocket path carries (None: not a setup path); LinkageError if the link is
    too long or has too many names."""
    if not path or not path.startswith(SETUP_PATH):
        return None
    encoded = path[len(SETUP_PATH):]
    if len(encoded) > MAX_SETUP_CHARS + MAX_SKETCH_CHARS + 100:  # not parsed: over any link's length
        raise LinkageError(f"link: {len(encoded)} characters; at most {MAX_SETUP_CHARS} (a design's link: "
                           f"sketch= up to {MAX_SKETCH_CHARS} more)")
    pairs = urllib.parse.parse_qsl(urllib.parse.unquote(encoded), keep_blank_values=True)
    # a design's sketch is bounded by its reader (it names it); the rest of the link as any link is
    sketch_chars = sum(len(value) for name, value in pairs if name == "sketch")
    if len(encoded) - sketch_chars > MAX_SETUP_CHARS:
        raise LinkageError(f"link: {len(encoded)} characters; at most {MAX_SETUP_CHARS}")
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
    """A saved setup: the names and values of a share link, as JSON (numbers in the panel's units); a general
    mechanism loaded from a file carries its description too (``mechanism``: the JSON of docs/mechanisms.md,
    read by its pydantic models, never evaluated), since no preset names it."""

    model_config = ConfigDict(extra="forbid")

    linkage_lab_setup: Literal[1] = Field(description="the format's version")
    mechanism: Optional[dict[StrictStr, Any]] = Field(None, description="a mechanism file's description")
    values: dict[StrictStr, Union[StrictInt, StrictFloat, StrictStr]] = Field(max_length=MAX_SETUP_NAMES)


@dataclass(frozen=True)
class SavedSetup:
    """A setup file as read: its ``(name, value)`` pairs and, for a mechanism from a file, the mechanism
    (validated, not yet assembled) with the name its menu shows; ``where`` names the file in messages."""

    pairs: list[tuple[str, str]]
    mechanism: Mechanism | None = None
    label: str | None = None
    where: str = "setup file"

    @property
    def preset(self) -> str | None:
        """The preset the setup names (a chain's or a mechanism's), if any."""
        return dict(self.pairs).get("preset")

    @property
    def names_a_mechanism(self) -> bool:
        """Whether it sets up a general mechanism (a description, or a mechanism preset), not a chain."""
        return self.mechanism is not None or self.preset in MECHANISM_PRESETS


TEXT_VALUES = ("preset", "method", "integrator", "stabilization", "trace")  # kept as text in a setup file


def setup_document(pairs: list[tuple[str, str]], mechanism: Mechanism | None = None) -> bytes:
    """A setup file holding ``pairs`` (numbers as JSON numbers) and, for a mechanism from a file, its
    description; LinkageError when it would be over MAX_STATE_BYTES (a setup that cannot be read back)."""
    values: dict[str, float | str] = {}
    for name, text in pairs:
        try:
            values[name] = text if name in TEXT_VALUES else int(text) if name == "links" else float(text)
        except ValueError:  # a name: preset, method, integrator, stabilization
            values[name] = text
    document: dict[str, Any] = {"linkage_lab_setup": 1}
    if mechanism is not None:
        document["mechanism"] = mechanism.model_dump(mode="json")
    document["values"] = values
    data = (json.dumps(document, indent=2) + "\n").encode()
    if len(data) > MAX_STATE_BYTES:
        raise LinkageError(f"setup file: {len(data)} bytes with the mechanism's description; a setup file is at "
                           f"most {MAX_STATE_BYTES}: share the mechanism file itself")
    return data


def state_document(params: SessionParameters) -> bytes:
    """The current setup as a JSON file that :func:`pairs_from_state` reads back."""
    return setup_document(urllib.parse.parse_qsl(link_query(params)[1:]))


def setup_from_state(data: bytes, where: str = "setup file") -> SavedSetup:
    """A saved setup, a chain's or a general mechanism's; LinkageError (one line naming what is wrong)
    otherwise. A description is checked by the mechanism's models here (assembly is the session's)."""
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
    pairs = [(name, value if isinstance(value, str) else repr(value)) for name, value in setup.values.items()]
    if setup.mechanism is None:
        return SavedSetup(pairs, where=where)
    if "preset" in setup.values:
        raise LinkageError(f"{where}: values.preset: a setup with its own mechanism names no preset "
                           f"(got {setup.values['preset']!r})")
    mechanism = mechanism_from_document(setup.mechanism, f"{where}: mechanism")
    taken = {*preset_names(), *MECHANISM_PRESETS}  # the menu's entries: a file's name never passes for a preset
    name = mechanism.name.strip()[:60] or "mechanism"
    label = name if name not in taken else f"{name} (file)"
    return SavedSetup(pairs, mechanism, label, where)


def pairs_from_state(data: bytes, where: str = "setup file") -> list[tuple[str, str]]:
    """The ``(name, value)`` pairs of a saved chain setup; LinkageError (one line naming what is wrong)
    otherwise, also for a setup that carries a mechanism's description (:func:`setup_from_state` reads it)."""
    saved = setup_from_state(data, where)
    if saved.mechanism is not None:
        raise LinkageError(f"{where}: mechanism: holds a general mechanism's description, not a chain's setup")
    return saved.pairs
