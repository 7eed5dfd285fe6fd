"""Design mode (issue 27): the Design tab and the scene's draggable points, a view of
:class:`physics.mechanism.design.Design` and its :class:`~physics.mechanism.design.History`.

Why a view of its own: the model (physics/mechanism/design.py, design_analysis.py) already holds every edit, its
refusals, undo and redo, the live topology, the drag re-assembled on its branch, the coupler curve and the files;
what is left is reading the browser. The panel's rows and the scene's clicks and drags call one method each
(:meth:`DesignView.add_ground`, :meth:`DesignView.click`, :meth:`DesignView.handle`, ...), so the tests drive the
same methods a browser does. Run loads ``design.to_mechanism()`` into the session as the mechanism menu loads a
preset: the same run, method menu, studies and downloads.

While designing (the tab's checkbox, or a link's ``?design=1``) the run is paused and hidden (its nodes are under
``/linkage``, hidden as one frame), the camera looks at the plane from the front, and the design is drawn under
``/design``: its points as balls a left-drag moves (viser's batched-mesh drags, as app/drag_start.py grabs bars),
its bodies' outlines, its sliders' guides, and the traced point's coupler curve over a motor's turn. A drag goes
through :func:`~physics.mechanism.design_analysis.drag` from the design shown, so the mechanism stays on its
branch; a drag that cannot close is one notice per drag and the last valid design is kept; the end of a drag is
one edit of the history. With an add tool chosen, a click on the plane places a point (snapped to the grid, or
onto an existing point near it, which the new body is then pinned to).
"""

from __future__ import annotations

import base64
import binascii
import json
import math
import re
import threading
import urllib.parse
import zlib
from pathlib import Path
from typing import Any, Callable

import numpy as np

from physics import LinkageError
from physics.mechanism.design import Design, History, default_mass_properties, design_from_mechanism
from physics.mechanism.design_analysis import coupler_curve, design_from_text, design_to_text, drag, topology_of
from physics.mechanism.files import check_unicode, mechanism_from_document
from physics.mechanism.presets import LINEAR_DENSITY
from physics.mechanism.writer import to_document

from .coalesce import CoalescingWorker
from .drag_start import plane_point
from .logs import quietly
from .scene import BAR_COLORS, GROUND_COLOR, instance_colors, pose_disc, to_world
from .shapes import UNIT_SPHERE
from .share import MAX_SKETCH_CHARS, flag_from  # a design link's length bound; the links' on/off switches
from .viser_compat import connection_open, update_node_props

TOOLS = ("Drag points", "Ground pivot", "Bar", "Plate", "Pin", "Slider")
TOOL_HINTS = {
    "Drag points": "Drag a point with the mouse; the mechanism re-assembles on its branch.",
    "Ground pivot": "Click in the plane to place a ground pivot.",
    "Bar": "Click two points; a click on an existing point pins the bar to it.",
    "Plate": "Click three or more points, then press Finish plate; a click on a point pins the plate to it.",
    "Pin": "Click the two points the pin joins (on one spot: the two points drawn there).",
    "Slider": "Click the sliding point (a body's), then a point of its guide; the direction is the row below.",
}
DEFAULT_GRID = 0.01  # m: the grid points snap to (0: no grid)
EMPTY_SIZE = 0.5  # m: the extent framed while the design has no point
HANDLE_SHARE = 0.022  # of the design's extent: a point's ball radius (a ground pivot's is larger)
PICK_SHARE = 0.03  # of the extent: a click this near an existing point picks it
MIN_INTERVAL = 0.05  # s between two re-assemblies of one drag (viser sends ~20 updates a second)
POINT_NAMES = "ABCDEFGHIJKLMNOP"  # a new body's points, in the order clicked
DESIGN_ROOT = "/design"
RUN_ROOT = "/linkage"  # the session's drawing of the run (app/mechanism_scene.py, trace, arrows): hidden as one
SKETCH = "sketch"  # a design's share link: ?sketch=<the design, compressed>
MAX_SKETCH_BYTES = 256 * 1024  # the decompressed design's size: a larger one is refused before it is read
SKETCH_ALPHABET = re.compile(r"^[A-Za-z0-9_-]*$")  # base64url without padding


def design_flag_from(setup: list[tuple[str, str]]) -> tuple[list[tuple[str, str]], bool, list[str]]:
    """A link's ``design=1`` (or ``0``) taken out of its setup: whether the session opens designing; see
    :func:`app.share.flag_from`."""
    return flag_from(setup, "design", False, "opens the page in Design mode")


def sketch_of(design: Design) -> str:
    """The design as a link's ``sketch=`` value: its mechanism file's JSON (compact), zlib-compressed, base64url
    without padding; LinkageError when it is incomplete (no body or no joint) or too long for a link."""
    text = json.dumps(to_document(design.to_mechanism()), separators=(",", ":"))
    value = base64.urlsafe_b64encode(zlib.compress(text.encode("utf-8"), 9)).rstrip(b"=").decode("ascii")
    if len(value) > MAX_SKETCH_CHARS:
        raise LinkageError(f"design link: the design compressed is {len(value)} characters; a link carries at "
                           f"most {MAX_SKETCH_CHARS}: save the design as a file instead (Save the design: TOML "
                           f"or JSON) and open it with 'Open a design file'")
    return value


def design_from_sketch(value: str) -> Design:
    """A link's ``sketch=`` value read back as a design: decoded, decompressed to at most MAX_SKETCH_BYTES (a
    small value that inflates to more is refused), parsed as JSON and validated by the file format's models
    (never evaluated); LinkageError naming ``sketch`` and what is wrong otherwise."""
    if len(value) > MAX_SKETCH_CHARS:
        raise LinkageError(f"{SKETCH}: {len(value)} characters; at most {MAX_SKETCH_CHARS}")
    if not value or not SKETCH_ALPHABET.match(value):
        raise LinkageError(f"{SKETCH}: not a design link's value (expected base64url letters, digits, - and _)")
    try:
        packed = base64.urlsafe_b64decode(value + "=" * (-len(value) % 4))
    except (binascii.Error, ValueError):
        raise LinkageError(f"{SKETCH}: not a design link's value (its base64url is cut short)") from None
    inflate = zlib.decompressobj()
    try:
        data = inflate.decompress(packed, MAX_SKETCH_BYTES + 1)
    except zlib.error:
        raise LinkageError(f"{SKETCH}: not a design link's value (not compressed data)") from None
    if len(data) > MAX_SKETCH_BYTES or inflate.unconsumed_tail:
        raise LinkageError(f"{SKETCH}: decompresses to over {MAX_SKETCH_BYTES // 1024} KB; a design is at most "
                           f"{MAX_SKETCH_BYTES // 1024} KB")
    if not inflate.eof:
        raise LinkageError(f"{SKETCH}: not a design link's value (its compressed data is cut short)")
    try:
        document = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise LinkageError(f"{SKETCH}: not a design link's value (not a mechanism's JSON)") from None
    except RecursionError:
        raise LinkageError(f"{SKETCH}: nested too deeply") from None
    check_unicode(document, SKETCH)
    return design_from_mechanism(mechanism_from_document(document, SKETCH))


def sketch_from(setup: list[tuple[str, str]]) -> tuple[list[tuple[str, str]], Design | None, list[str]]:
    """A link's ``sketch=`` taken out of its setup: the setup without it, the design it carries (None: none, or
    refused) and the reason it is refused (one line naming ``sketch``)."""
    values = [value for key, value in setup if key == SKETCH]
    rest = [(key, value) for key, value in setup if key != SKETCH]
    if not values:
        return rest, None, []
    try:
        return rest, design_from_sketch(values[-1]), []
    except LinkageError as error:
        return rest, None, [str(error)]


def handles_of(design: Design) -> list[tuple[str, tuple[float, float]]]:
    """Every point a designer can grab, ``(reference, xy)``: the ground points, then each body's points."""
    out = [(f"ground.{name}", xy) for name, xy in design.ground]
    for body in design.bodies:
        out += [(f"{body.name}.{name}", xy) for name, xy in body.points]
    return out


def extent_of(design: Design) -> float:
    """The design's size (m): the largest distance between two of its points, at least a tenth of EMPTY_SIZE."""
    points = np.array([xy for _, xy in handles_of(design)], dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return EMPTY_SIZE
    return max(float(np.max(np.ptp(points, axis=0))), 0.1 * EMPTY_SIZE)


def nearest_point(design: Design, xy, radius: float, other_than: str | None = None) -> str | None:
    """The reference of the point nearest ``xy`` within ``radius`` (the first listed on a tie: a ground pivot
    before the body points drawn on it), skipping the points of ``other_than``'s owner; None when none is near."""
    owner = None if other_than is None else other_than.partition(".")[0]
    best, best_distance = None, radius
    for reference, at in handles_of(design):
        if reference.partition(".")[0] == owner:
            continue
        distance = math.dist(at, (float(xy[0]), float(xy[1])))
        if distance <= best_distance and (best is None or distance < best_distance):
            best, best_distance = reference, distance
    return best


def free_name(design: Design, stem: str) -> str:
    """``stem1``, ``stem2``, ...: the first not taken in ``design``."""
    taken = design.names()
    k = 1
    while f"{stem}{k}" in taken:
        k += 1
    return f"{stem}{k}"


def snapped(xy, grid: float | None) -> tuple[float, float]:
    """``xy`` rounded to the grid as :meth:`Design.move_point` rounds it."""
    x, y = float(xy[0]), float(xy[1])
    if grid:
        x, y = round(x / grid) * grid, round(y / grid) * grid
    return (x, y)


def masses_text(design: Design) -> str:
    """Each body's mass and inertia, and whose they are: ``bar1 0.1 kg, 8.33e-05 kg m² (density model)``."""
    rows = []
    for body in design.bodies:
        if body.mass is not None and body.inertia is not None:
            mass, inertia, whose = body.mass, body.inertia, "own"
        else:
            mass, _, inertia = default_mass_properties(tuple(xy for _, xy in body.points))
            whose = f"density model, {LINEAR_DENSITY:g} kg/m"
        rows.append(f"{body.name} {mass:.4g} kg, {inertia:.3g} kg m² ({whose})")
    return "Masses: " + "; ".join(rows) if rows else ""


def parse_pair(text: object, what: str) -> tuple[float, float]:
    """``"1, 0"`` -> (1.0, 0.0); LinkageError naming ``what`` otherwise."""
    parts = str(text).replace(";", ",").split(",")
    try:
        x, y = (float(part) for part in parts)
    except ValueError:
        raise LinkageError(f"{what} = {str(text)[:40]!r}: expected two numbers, as 1, 0") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise LinkageError(f"{what} = {str(text)[:40]!r}: expected finite numbers")
    return (x, y)


class DesignView:
    """One session's Design tab and its drawing (``session``: a :class:`~app.session.Session`)."""

    def __init__(self, session) -> None:
        self.session = session
        self.history = History()
        self.on = False  # designing: the design drawn and grabbed in the scene, the run hidden
        self.grid: float | None = DEFAULT_GRID
        self.tool = TOOLS[0]
        self.pending: list[tuple[str | None, tuple[float, float]]] = []  # the add tool's clicks so far
        self.shown: Design = self.history.current  # the design drawn: during a drag, ahead of the history
        self.curve: np.ndarray | None = None  # the coupler curve drawn, (n, 2), None when there is none
        self.drags_applied = 0  # re-assemblies shown (tests)
        self._grab: dict[str, Any] | None = None
        self._nodes: dict[str, Any] = {}
        self._layout: tuple | None = None
        self._view_before: str | None = None
        self._disc_before: tuple | None = None
        self._run_frame: Any = None
        self._lock = threading.RLock()
        # (phase, instance, end world, camera, client id), handled on a thread of its own; not through the session's
        # guard: a move that is refused again says nothing (one notice per drag), and the guard would take the
        # drag's refusal down as if a value had been applied
        self._worker: CoalescingWorker[tuple] = CoalescingWorker(
            lambda event: self._handle_quietly(*event), lambda event: event[0] == "update", name="design-drag",
            what="dragging a design point", min_interval=MIN_INTERVAL)
        self._closed = False
        self._quiet = False
        self._build_tab()
        self._show_topology()

    @property
    def design(self) -> Design:
        return self.history.current

    # ------------------------------------------------------------------ the tab
    def _build_tab(self) -> None:
        session = self.session
        gui = session.target.gui

        def bind(handle, action: Callable[[Any], object], kind: str = "on_click") -> None:
            # a viewer's update never reaches here (the session's check refuses it before viser); the view's own
            # writes to its controls (viser calls back at once) are muted
            getattr(handle, kind)(lambda event: None if self._quiet else session.guard(lambda: action(event)))

        with session.tabs.add_tab("Design"):
            self.designing_box = gui.add_checkbox(
                "Design in the scene", False, hint="Draw and drag the design's points in the plane (the run is "
                "paused and hidden meanwhile; also ?design=1)")
            bind(self.designing_box, lambda event: self.set_designing(bool(self.designing_box.value)), "on_update")
            self.topology_line = gui.add_markdown("")
            self.tool_menu = gui.add_dropdown("Tool", list(TOOLS), initial_value=TOOLS[0],
                                              hint="What a click in the plane adds")
            bind(self.tool_menu, lambda event: self.set_tool(str(self.tool_menu.value)), "on_update")
            self.tool_hint = gui.add_markdown(TOOL_HINTS[TOOLS[0]])
            self.name_box = gui.add_text("Name", "", hint="The next item's name (empty: named for you)")
            self.grid_box = gui.add_number("Grid (m)", DEFAULT_GRID, min=0.0, max=10.0, step=0.001,
                                           hint="Points snap to multiples of this (0: no grid)")
            bind(self.grid_box, lambda event: self.set_grid(self.grid_box.value), "on_update")
            self.finish_plate = gui.add_button("Finish plate")
            bind(self.finish_plate, lambda event: self.finish())
            self.join_box = gui.add_text("Join points", "", hint="Two points: body.point or ground.point, "
                                         "comma between (a slider: the sliding point, then its guide's)")
            self.direction_box = gui.add_text("Slider direction", "1, 0", hint="The guide's direction: x, y")
            self.join_buttons = gui.add_button_group("Add joint", ("Pin", "Slider"))
            bind(self.join_buttons, lambda event: self.join(str(self.join_buttons.value)))
            self.motor_pin = gui.add_text("Motor on pin", "", hint="The name of a pin")
            self.motor_kind = gui.add_dropdown("Motor", ["speed (rad/s)", "torque (N m)"],
                                               initial_value="speed (rad/s)")
            self.motor_value = gui.add_number("Motor value", 6.283, min=-1e4, max=1e4, step=0.001)
            self.motor_button = gui.add_button("Add motor")
            bind(self.motor_button, lambda event: self.add_motor_from_panel())
            self.item_box = gui.add_text("Item", "", hint="A ground point (ground.NAME), body or joint (a name "
                                         "two hold: body:NAME, joint:NAME; a motor: motor:PIN); a body's "
                                         "point to trace")
            self.new_name_box = gui.add_text("New name", "")
            self.item_buttons = gui.add_button_group("Item", ("Delete", "Rename", "Trace"))
            bind(self.item_buttons, lambda event: self.item_action(str(self.item_buttons.value)))
            self.mass_box = gui.add_number("Mass (kg)", 1.0, min=0.0, max=1e6, step=0.001,
                                           hint="The Item body's own mass")
            self.inertia_box = gui.add_number("Inertia (kg m²)", 0.01, min=0.0, max=1e6, step=0.0001,
                                              hint="The Item body's own centroidal inertia")
            self.mass_buttons = gui.add_button_group("Body mass", ("Set", "Density model"),
                                                     hint=f"Set: the Item body's own mass and inertia (centre: "
                                                     f"the mean of its points); Density model: uniform rods of "
                                                     f"{LINEAR_DENSITY:g} kg/m along its outline")
            bind(self.mass_buttons, lambda event: self.mass_action(str(self.mass_buttons.value)))
            self.masses_line = gui.add_markdown("")
            self.history_buttons = gui.add_button_group("Edits", ("Undo", "Redo"))
            bind(self.history_buttons, lambda event: self.undo() if self.history_buttons.value == "Undo"
                 else self.redo())
            self.run_buttons = gui.add_button_group("Design", ("Run", "Start from preset"),
                                                    hint="Run: load the design as any preset; or open the "
                                                    "mechanism shown as a design")
            bind(self.run_buttons, lambda event: self.run() if self.run_buttons.value == "Run"
                 else self.start_from_preset())
            self.save_buttons = gui.add_button_group("Save the design", ("TOML", "JSON"),
                                                     hint="The file format of docs/mechanisms.md (--mechanism)")
            bind(self.save_buttons, lambda event: self.save(str(self.save_buttons.value).lower(),
                                                            getattr(event, "client", None)))
            self.link_button = gui.add_button("Link to this design",
                                              hint="A link that opens this design, designing, in a new page")
            bind(self.link_button, lambda event: self.show_link())
            self.link_line = gui.add_markdown("")
            self.open_button = gui.add_upload_button("Open a design file (TOML or JSON)",
                                                     hint="A mechanism file; at most 1 MB")
            bind(self.open_button, lambda event: self.open_upload(getattr(event, "client_id", None),
                                                                  self.open_button.value.name,
                                                                  self.open_button.value.content), "on_upload")

    def _write(self, handle, value: object) -> None:
        """Show ``value`` in a control of the tab without acting on it."""
        self._quiet = True
        try:
            if handle.value != value:
                handle.value = value
        finally:
            self._quiet = False

    # ------------------------------------------------------------------ edits
    def _apply(self, design: Design) -> Design:
        """Make ``design`` current (one edit of the history) and show it."""
        with self._lock:
            self.history.apply(design)
            self.shown = design
            self.pending = []
        self._show()
        return design

    def edit(self, change: Callable[[Design], Design]) -> Design | None:
        """One edit of the current design; a refusal (LinkageError) is one notice naming the item, and the
        design is unchanged."""
        try:
            with self._lock:  # two clicks handled at once (viser's thread pool) must not lose one
                design = change(self.design)
                self.history.apply(design)
                self.shown, self.pending = design, []
        except LinkageError as error:
            self.refuse(str(error))
            return None
        self._show()
        return design

    def refuse(self, message: str) -> None:
        self.session.show_notice("Not applied", message, color="yellow")

    def _next_name(self, stem: str) -> str:
        """The Name row's text (then emptied) or ``stem`` numbered."""
        typed = str(self.name_box.value).strip()
        if typed:
            self._write(self.name_box, "")
            return typed
        return free_name(self.design, stem)

    def add_ground(self, name: str, xy) -> Design | None:
        return self.edit(lambda d: d.add_ground(name, snapped(xy, self.grid)))

    def add_bar(self, name: str, first, second) -> Design | None:
        return self.edit(lambda d: d.add_bar(name, first, second))

    def add_plate(self, name: str, corners) -> Design | None:
        return self.edit(lambda d: d.add_plate(name, list(corners)))

    def add_pin(self, name: str, a: str, b: str) -> Design | None:
        return self.edit(lambda d: d.add_pin(name, a, b))

    def add_slider(self, name: str, point: str, through: str, direction) -> Design | None:
        return self.edit(lambda d: d.add_slider(name, point, through, direction))

    def add_motor(self, pin: str, speed: float | None = None, torque: float | None = None) -> Design | None:
        return self.edit(lambda d: d.add_motor(pin, speed=speed, torque=torque))

    def set_trace(self, reference: str | None) -> Design | None:
        return self.edit(lambda d: d.set_trace(reference))

    def delete(self, name: str) -> Design | None:
        return self.edit(lambda d: d.delete(name))

    def rename(self, old: str, new: str) -> Design | None:
        return self.edit(lambda d: d.rename(old, new))

    def undo(self) -> None:
        self._step(self.history.undo)

    def redo(self) -> None:
        self._step(self.history.redo)

    def _step(self, move: Callable[[], Design]) -> None:
        try:
            with self._lock:
                self.shown = move()
                self.pending = []
        except LinkageError as error:
            self.refuse(str(error))
            return
        self._show()

    def set_grid(self, value: object) -> None:
        """The grid in metres (0: none); LinkageError naming the range."""
        try:
            grid = float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            grid = math.nan
        if not (grid == 0.0 or (math.isfinite(grid) and 1e-6 <= grid <= 10.0)):
            raise LinkageError(f"grid = {value!r}: allowed 0 (no grid) or 1e-06 <= grid <= 10 metres")
        self.grid = grid or None

    def set_tool(self, tool: str) -> None:
        if tool not in TOOLS:
            raise LinkageError(f"tool = {tool!r}: allowed {', '.join(TOOLS)}")
        self.tool, self.pending = tool, []
        self.tool_hint.content = TOOL_HINTS[tool]
        self._write(self.tool_menu, tool)

    def join(self, kind: str) -> Design | None:
        """The Join row: a pin or a slider between the two points typed."""
        parts = [part.strip() for part in str(self.join_box.value).split(",") if part.strip()]
        if len(parts) != 2:
            raise LinkageError(f"join points = {str(self.join_box.value)[:60]!r}: expected two points, as "
                               "crank.A, coupler.A")
        if kind == "Slider":
            direction = parse_pair(self.direction_box.value, "slider direction")
            return self.add_slider(self._next_name("slider"), parts[0], parts[1], direction)
        return self.add_pin(self._next_name("pin"), parts[0], parts[1])

    def add_motor_from_panel(self) -> Design | None:
        value = float(self.motor_value.value)
        pin = str(self.motor_pin.value).strip()
        if str(self.motor_kind.value).startswith("torque"):
            return self.add_motor(pin, torque=value)
        return self.add_motor(pin, speed=value)

    def set_mass(self, body: str, mass: float | None, inertia: float | None = None) -> Design | None:
        """Body ``body``'s own mass and centroidal inertia, or (``mass=None``) the density model again."""
        return self.edit(lambda d: d.set_mass(body, mass, inertia))

    def mass_action(self, action: str) -> Design | None:
        body = str(self.item_box.value).strip()
        if action == "Set":
            return self.set_mass(body, float(self.mass_box.value), float(self.inertia_box.value))
        return self.set_mass(body, None)

    def item_action(self, action: str) -> Design | None:
        item = str(self.item_box.value).strip()
        if action == "Delete":
            return self.delete(item)
        if action == "Rename":
            return self.rename(item, str(self.new_name_box.value).strip())
        return self.set_trace(item or None)

    # ------------------------------------------------------------------ clicks in the plane
    def pick_radius(self) -> float:
        return max(PICK_SHARE * extent_of(self.design), 0.5 * (self.grid or 0.0))

    def click(self, xy, client_id: int | None = None) -> Design | None:
        """A click at physics point ``xy`` with the tool in force: it places a point (snapped to the grid, or
        onto an existing point near it) or picks one; the item is added when its last click comes."""
        if not self.session.may_change(client_id):
            self.session.show_notice("Not applied", "the presenter controls this session", color="blue")
            return None
        tool = self.tool
        if tool == "Drag points":
            return None
        xy = (float(xy[0]), float(xy[1]))
        if tool == "Ground pivot":
            return self.add_ground(self._next_name("G"), xy)
        picked = nearest_point(self.design, xy, self.pick_radius(),
                               other_than=self.pending[-1][0] if tool in ("Pin", "Slider") and self.pending
                               else None)
        if tool in ("Pin", "Slider"):
            if picked is None:
                self.refuse(f"{tool.lower()}: no point within {self.pick_radius():.3g} m of "
                            f"({xy[0]:.3g}, {xy[1]:.3g}); click on a point")
                return None
            self.pending.append((picked, self.design.point(picked)))
            if len(self.pending) < 2:
                self._show_hint(f"{tool}: {picked} chosen; click the second point")
                return None
            a, b = (str(reference) for reference, _ in self.pending)
            self.pending = []
            if tool == "Pin":
                return self.add_pin(self._next_name("pin"), a, b)
            try:
                direction = parse_pair(self.direction_box.value, "slider direction")
            except LinkageError as error:
                self.refuse(str(error))
                return None
            return self.add_slider(self._next_name("slider"), a, b, direction)
        at = self.design.point(picked) if picked is not None else snapped(xy, self.grid)
        self.pending.append((picked, at))
        if tool == "Bar" and len(self.pending) == 2:
            return self.finish()
        if len(self.pending) == len(POINT_NAMES):
            return self.finish()
        self._show_hint(f"{tool}: {len(self.pending)} point(s); click the next"
                        + (" or press Finish plate" if tool == "Plate" and len(self.pending) >= 3 else ""))
        return None

    def finish(self) -> Design | None:
        """The body of the clicks so far (a bar: two; a plate: three or more), pinned to the points it was drawn
        on; one edit of the history."""
        clicks, tool = list(self.pending), self.tool
        self.pending = []
        if tool not in ("Bar", "Plate"):
            raise LinkageError("finish: choose the Bar or Plate tool and click its points first")
        self._show_hint(TOOL_HINTS[tool])

        def build(design: Design) -> Design:
            name = self._next_name("bar" if tool == "Bar" else "plate")
            points = [(POINT_NAMES[k], xy) for k, (_, xy) in enumerate(clicks)]
            design = design.add_bar(name, *points) if tool == "Bar" else design.add_plate(name, points)
            for k, (picked, _) in enumerate(clicks):
                if picked is not None:
                    design = design.add_pin(free_name(design, "pin"), f"{name}.{POINT_NAMES[k]}", picked)
            return design

        if tool == "Bar" and len(clicks) != 2:
            raise LinkageError(f"bar: needs 2 points, got {len(clicks)}")
        return self.edit(build)

    def _show_hint(self, text: str) -> None:
        self.tool_hint.content = text

    # ------------------------------------------------------------------ run, files, presets
    def run(self) -> None:
        """Load the design into the session as a preset is loaded: the same run, method menu and studies;
        designing ends so the run is seen."""
        mechanism = self.design.to_mechanism()  # LinkageError: no body or no joint yet
        label = f"{self.design.name} (design)"
        designing = self.on
        self.set_designing(False)  # first: the run's framing is the new mechanism's
        try:
            self.session._start_anew(mechanism, label)  # LinkageError naming the joint that stays open
        except LinkageError:
            self.set_designing(designing)
            raise

    def start_from_preset(self) -> Design | None:
        """The mechanism shown (a preset, a file, a design that ran) opened as a design."""
        design = design_from_mechanism(self.session.mechanism)
        self._apply(design)
        self._frame()
        return design

    def save_file(self, fmt: str) -> tuple[str, bytes]:
        """``(file name, content)`` of the design as a mechanism file (``toml`` or ``json``)."""
        text = design_to_text(self.design, fmt)
        stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in self.design.name) or "design"
        return f"{stem}.{fmt}", text.encode("utf-8")

    def save(self, fmt: str, client=None) -> None:
        """The design as a file sent to ``client``'s page (every page when None). A viewer of a lecture may save
        too: the file and a refusal ("add a bar first") go to that viewer's page alone, nothing shared changes."""
        client_id = getattr(client, "client_id", None)
        if client is not None and not self.session.may_change(client_id):
            try:
                name, content = self.save_file(fmt)
            except LinkageError as error:
                client.add_notification("Not saved", str(error), auto_close_seconds=8.0, color="yellow")
                return
            client.send_file_download(name, content)
            return
        name, content = self.save_file(fmt)
        (client or self.session.target).send_file_download(name, content)

    def link_query(self) -> str:
        """The query of the design's share link (``?sketch=...``); LinkageError when it cannot be one."""
        return "?" + urllib.parse.urlencode([(SKETCH, sketch_of(self.design))])

    def show_link(self) -> str:
        """The design's link under the button, from the server's root (``/``): it never carries the address of
        the page that asked (a presenter's secret one)."""
        query = self.link_query()
        self.link_line.content = (f"[Open this design](/{query}) (right-click to copy the link): it opens this "
                                  f"design in Design mode, in a new session on this server.")
        return query

    def open_design(self, design: Design) -> Design:
        """A design from elsewhere (a link) made current: one edit of the history, framed while designing."""
        self._apply(design)
        self._frame()
        return design

    def open_upload(self, client_id: int | None, name: object, content: object) -> Design | None:
        """A file chosen in the browser (an upload finishes after its sender may have gone: the sender is
        checked here, as the Mechanism tab's upload is; a viewer of a presenter's session may not open one)."""
        if not self.session.may_change(client_id):
            raise LinkageError("design file: the presenter controls this session")
        return self.open_file(name, content)

    def open_file(self, name: object, content: object) -> Design | None:
        """A mechanism file (TOML or JSON by its ending) opened as the design; one notice when it is not one."""
        label = Path(str(name)).name[:60] or "design.toml"
        if not isinstance(content, bytes):
            raise LinkageError(f"{label}: expected the file's content")
        if len(content) > 1_000_000:
            raise LinkageError(f"{label}: {len(content)} bytes; at most 1 MB")
        try:
            text = content.decode("utf-8")
        except UnicodeDecodeError:
            raise LinkageError(f"{label}: not UTF-8 text") from None
        design = self._apply(design_from_text(text, label))
        self._frame()
        return design

    # ------------------------------------------------------------------ designing in the scene
    def set_designing(self, on: bool) -> None:
        """Design in the scene, or back to the run: the run paused and hidden, the camera in front, the design's
        points grabbed by drags and the plane's clicks read."""
        with self._lock:
            self._set_designing(bool(on))

    def _set_designing(self, on: bool) -> None:
        self._write(self.designing_box, on)
        if on == self.on:
            return
        session = self.session
        scene = session.target.scene
        # paused at once and held before anything says designing: a start already installed (a page's first, about
        # to be shown) stops now, and one installed later stays paused (app/player.py hold)
        session.player.hold(on)
        self.on = on
        if on:
            if session.compare:
                session.set_compare(False)
            if session.player.restart_pending:  # a start about to play (a page just opened): it waits instead
                session.wait_at_start()
            else:
                session.pause()
            self._run_frame = scene.add_frame(RUN_ROOT, show_axes=False, visible=False)
            self._view_before, self._disc_before = session.camera.view, session.camera.disc
            session.set_camera_view("front")
            scene.on_click()(self._on_click)
            self.shown = self.design
            self._layout = None
            self._show()
            self._frame()
        else:
            quietly(lambda: scene.remove_click_callback(self._on_click), "unbinding the design's clicks")
            self._remove_nodes()
            if self._run_frame is not None:
                self._run_frame.visible = True
            session.camera.disc = self._disc_before  # the run's framing, as it was
            if self._view_before is not None:
                session.set_camera_view(self._view_before)

    def _frame(self) -> None:
        """Frame the camera on the design (its points, or a disc around the origin while it has none)."""
        if not self.on:
            return
        points = np.array([xy for _, xy in handles_of(self.design)], dtype=float).reshape(-1, 2)
        if len(points):
            centre, radius = pose_disc(points, margin=1.6)
            radius = max(radius, 0.25 * EMPTY_SIZE)
        else:
            centre, radius = np.zeros(2), EMPTY_SIZE
        camera = self.session.camera
        camera.disc = (centre, radius)
        camera.frame(np.array([radius]), None, force=True)

    def _on_click(self, event) -> None:
        """viser's click (its event loop): the ray meets the plane of the motion (world y = 0)."""
        origin, direction = np.asarray(event.ray_origin, float), np.asarray(event.ray_direction, float)
        if abs(direction[1]) < 1e-9:
            return
        hit = origin - origin[1] / direction[1] * direction
        self.session.guard(lambda: self.click((hit[0], hit[2]), event.client_id))

    # ------------------------------------------------------------------ drags
    async def _on_drag(self, event) -> None:
        camera = None
        try:
            camera = np.array(event.client.camera.position, dtype=float)
        except Exception:  # no camera message from this browser yet: the drag point flattened
            camera = None
        self.push(event.phase, event.instance_index, event.end_position, camera, event.client_id)

    def push(self, phase: str, instance: int | None, end_world, camera=None, client_id: int | None = None) -> None:
        """One drag event, queued for the worker (the newest update wins)."""
        self._worker.submit((phase, instance, end_world, camera, client_id))

    def _handle_quietly(self, phase: str, instance: int | None, end_world, camera, client_id: int | None) -> None:
        try:
            self.handle(phase, instance, end_world, camera, client_id)
        except LinkageError as error:
            self.refuse(str(error))

    def handle(self, phase: str, instance: int | None, end_world, camera=None, client_id: int | None = None) -> None:
        """One drag event of the design's point ``instance`` (the order of :func:`handles_of`); ``end_world``
        where the mouse is (viser's world point). The start grabs, each update re-assembles from the design
        shown, the end makes the last valid design one edit."""
        if phase == "start":
            if not self.session.may_change(client_id):
                self.session.show_notice("Not applied", "the presenter controls this session", color="blue")
                return
            references = [reference for reference, _ in handles_of(self.shown)]
            if instance is None or not 0 <= instance < len(references):
                return
            self._grab = {"reference": references[instance], "refused": False}
            return
        grab = self._grab
        if grab is None:
            return
        self.drag_to(plane_point(end_world, camera))
        if phase == "end":
            self._grab = None
            if self.shown != self.design:
                self._apply(self.shown)
            else:
                self._show_topology()

    def drag_to(self, xy) -> None:
        """The grabbed point to physics point ``xy``: :func:`drag` from the design shown (its branch kept); a
        refusal is one notice per drag and the design shown stays the last valid one."""
        grab = self._grab
        if grab is None:
            return
        self._worker.mark()
        try:
            moved = drag(self.shown, grab["reference"], (float(xy[0]), float(xy[1])), self.grid)
        except LinkageError as error:
            if not grab["refused"]:
                grab["refused"] = True
                self.refuse(str(error))
            return
        grab["refused"] = False
        with self._lock:
            self.shown = moved
        self.drags_applied += 1
        self._draw()

    # ------------------------------------------------------------------ drawing
    def _show(self) -> None:
        """The design as it is now: its topology line and, while designing, its drawing."""
        self._show_topology()
        self._draw()

    def _show_topology(self) -> None:
        design = self.design
        topology = topology_of(design)
        counts = f"{topology.bodies} bodies, {topology.joints} joints"
        if topology.loops:
            counts += f", {len(topology.loops)} loop{'s' if len(topology.loops) != 1 else ''}"
        if not design.is_complete():
            line = f"**{counts}.** {topology.notice}" if design.bodies or design.ground else \
                "**Empty design.** Choose a tool and click in the plane, or start from a preset."
        elif topology.mobility is None:
            line = f"**{counts}.** ⚠ {topology.notice}"
        else:
            line = f"**{counts}: {topology.text()}.**"
        self.topology = topology
        self.topology_line.content = line
        self.masses_line.content = masses_text(design)

    def _draw(self) -> None:
        if not self.on or self._closed:
            return
        design = self.shown
        try:
            self.curve = coupler_curve(design) if design.trace is not None and design.is_complete() else None
        except LinkageError:
            self.curve = None
        scene = self.session.target.scene
        handles = handles_of(design)
        xy = np.array([at for _, at in handles], dtype=float).reshape(-1, 2)
        size = extent_of(design)
        layout = (tuple(reference for reference, _ in handles), round(size, 6) if self._layout is None
                  else self._layout[1])
        with self.session.target.atomic():
            spheres = self._nodes.get("points")
            if layout[0] != (self._layout or ((), 0))[0] or spheres is None:
                self._remove_nodes()
                layout = (layout[0], size)
                if len(handles):
                    self._nodes["points"] = self._add_points(scene, design, xy, size)
            else:
                update_node_props(spheres, {"batched_positions": to_world(xy).astype(np.float32)})
            self._layout = layout
            self._draw_lines(scene, design, layout[1])
        quietly(self.session.target.flush, "flushing the design")

    def _add_points(self, scene, design: Design, xy: np.ndarray, size: float):
        radius = HANDLE_SHARE * size
        ground = len(design.ground)
        radii = np.full(len(xy), radius, dtype=np.float32)
        radii[:ground] = 1.4 * radius  # in front of the body points drawn on it: a grab there moves the pivot
        colors = [GROUND_COLOR] * ground
        for k, body in enumerate(design.bodies):
            colors += [BAR_COLORS[k % len(BAR_COLORS)]] * len(body.points)
        vertices, faces = UNIT_SPHERE
        node = scene.add_batched_meshes_simple(
            f"{DESIGN_ROOT}/points", vertices, faces,
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (len(xy), 1)),
            batched_positions=to_world(xy).astype(np.float32), batched_scales=radii,
            batched_colors=instance_colors(colors), lod="off", cast_shadow=False, receive_shadow=False)
        node.on_drag(self._on_drag)
        return node

    def _draw_lines(self, scene, design: Design, size: float) -> None:
        """The bodies' outlines, the sliders' guides and the coupler curve: line segments, replaced whole."""
        segments, colors = [], []
        for k, body in enumerate(design.bodies):
            points = [xy for _, xy in body.points]
            edges = [(points[0], points[1])] if len(points) == 2 else list(zip(points, points[1:] + points[:1]))
            segments += edges
            colors += [BAR_COLORS[k % len(BAR_COLORS)]] * len(edges)
        for joint in design.joints:
            if joint.kind == "prismatic":
                through = np.array(design.point(f"{joint.on}.{joint.through}"), dtype=float)
                direction = np.array(joint.direction, dtype=float)
                direction = direction / (np.hypot(*direction) or 1.0)
                segments.append((tuple(through - 0.6 * size * direction), tuple(through + 0.6 * size * direction)))
                colors.append(GROUND_COLOR)
        self._line_node("bodies", scene, segments, colors, 4.0)
        curve_segments: list = []
        if self.curve is not None:
            ok = np.all(np.isfinite(self.curve), axis=1)
            curve_segments = [(tuple(self.curve[k]), tuple(self.curve[k + 1])) for k in range(len(self.curve) - 1)
                              if ok[k] and ok[k + 1]]
        self._line_node("curve", scene, curve_segments, [(220, 30, 160)] * len(curve_segments), 2.5)

    def _line_node(self, name: str, scene, segments: list, colors: list, thickness: float) -> None:
        if not segments:
            node = self._nodes.pop(name, None)
            if node is not None:
                quietly(node.remove, "removing a design line")
            return
        points = to_world(np.array(segments, dtype=float)).astype(np.float32)
        rgb = np.repeat(np.array(colors, dtype=np.uint8)[:, None, :], 2, axis=1)
        self._nodes[name] = scene.add_line_segments(f"{DESIGN_ROOT}/{name}", points=points, colors=rgb,
                                                    thickness=thickness, thickness_units="screen")

    def _remove_nodes(self) -> None:
        for node in self._nodes.values():
            quietly(node.remove, "removing a design node")
        self._nodes = {}
        self._layout = None

    def close(self) -> None:
        """Stop the drag worker, remove the design's nodes and show the run's frame again (removing it would
        remove the run's nodes under it before the session does: viser warns of every second removal)."""
        self._closed = True
        self._worker.close()
        self._remove_nodes()
        frame = self._run_frame
        if frame is not None and not frame.visible and (self.session.shared or connection_open(self.session.target)):
            quietly(lambda: setattr(frame, "visible", True), "showing the run's frame")
