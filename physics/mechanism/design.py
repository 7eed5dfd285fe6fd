"""An editable mechanism for Design mode: ground pivots, bars, plates, pins, sliders and motors added, moved,
renamed and deleted one edit at a time, each edit giving a new immutable :class:`Design` or one LinkageError.

Why a model of its own: a :class:`~physics.mechanism.description.Mechanism` must already be whole (at least one
body and one joint, every reference resolved), while a design grows from nothing. A design converts to a
Mechanism (:meth:`Design.to_mechanism`) for everything that computes (assembly, runs, files) and back
(:func:`design_from_mechanism`), so a design saves in the file format of docs/mechanisms.md and a preset opens as
a design. It imports neither app/ nor viser: the browser's Design tab is a view of it.

Mass properties a designer has not given come from one stated model, the presets' own: a bar is a uniform rod of
:data:`~physics.mechanism.presets.LINEAR_DENSITY` kg per metre (``m = rho L``, ``I = m L^2 / 12`` about its
midpoint); a plate is a frame of uniform rods of the same density along its outline (its polygon's edges, in
the order its points were given: for three points exactly the presets' ``"frame"`` plate). A body taken from a
file or a preset keeps its own mass, centre of mass and inertia until its points are moved.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Any

from pydantic import ValidationError

from ..errors import LinkageError
from .description import GROUND, MAX_BODIES, MAX_POINTS_PER_BODY, Body, Driver, Mechanism, Prismatic, Revolute
from .files import mechanism_from_document
from .presets import rods_mass_properties

Point = tuple[float, float]
NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,39}$")
NAME_FORM = "a letter then up to 39 letters, digits, _ or -"  # NAME in words, for refusals
# An item's kinds and the written form that names one of its kind alone (a motor is ``motor:PIN``)
ITEM_FORMS = {"ground point": "ground.{}", "body": "body:{}", "joint": "joint:{}"}
MAX_COORDINATE = 1e3  # metres: a sketch point's largest |x| or |y|


@dataclass(frozen=True)
class DesignBody:
    """A rigid body of the design: its named points in the sketch and, when given, its own mass properties
    (``None``: the density model of the module's text)."""

    name: str
    points: tuple[tuple[str, Point], ...]
    mass: float | None = None
    com: Point | None = None
    inertia: float | None = None

    def point(self, name: str) -> Point | None:
        return dict(self.points).get(name)


@dataclass(frozen=True)
class Design:
    """A design: ground points, bodies, joints (pins, sliders, and any gear a file brought), motors, a traced
    point. Immutable: every edit returns a new design, so undo is keeping the old one."""

    name: str = "design"
    description: str = ""
    g: float = 9.81
    ground: tuple[tuple[str, Point], ...] = ()
    bodies: tuple[DesignBody, ...] = ()
    joints: tuple[Any, ...] = ()  # the description's joint models (Revolute, Prismatic, Gear)
    drivers: tuple[Driver, ...] = ()
    trace: str | None = None

    # -- reading ------------------------------------------------------------------------------------------
    def names(self) -> set[str]:
        """Every name an item holds (ground points, bodies, joints). As in the file format, each kind is a
        namespace of its own (a pin may share its ground point's name, as the crank-rocker's ``O2``); a name
        free in all three (:func:`app.design_view.free_name`) names one item wherever it is written."""
        return set(self._names_of("ground point")) | set(self._names_of("body")) | set(self._names_of("joint"))

    def item(self, written: str, action: str) -> tuple[str, str]:
        """``(kind, name)`` of the ground point, body or joint ``written`` names: ``ground.NAME``, ``body:NAME``
        or ``joint:NAME`` one of that kind, a bare name the one item of any kind holding it. LinkageError (one
        line with the forms to write) when none holds it or more than one does (the crank-rocker's ``O2`` names
        a ground point and a pin)."""
        for kind, form in ITEM_FORMS.items():
            prefix = form.format("")
            if written.startswith(prefix) and written.removeprefix(prefix) in self._names_of(kind):
                return kind, written.removeprefix(prefix)
        held = [kind for kind in ITEM_FORMS if written in self._names_of(kind)]
        if not held:
            raise LinkageError(f"{action} {written!r}: no ground point, body or joint of that name")
        if len(held) > 1:
            forms = " or ".join(ITEM_FORMS[kind].format(written) for kind in held)
            raise LinkageError(f"{action} {written!r}: names a {' and a '.join(held)}; write {forms}")
        return held[0], written

    def body(self, name: str) -> DesignBody:
        for body in self.bodies:
            if body.name == name:
                return body
        raise LinkageError(f"body {name!r}: no such body (bodies: {', '.join(b.name for b in self.bodies) or 'none'})")

    def point(self, reference: str) -> Point:
        """The sketch position of ``body.point`` or ``ground.point``; LinkageError naming what is missing."""
        owner, _, name = reference.partition(".")
        if owner == GROUND:
            found = dict(self.ground).get(name)
            if found is None:
                known = ", ".join(n for n, _ in self.ground) or "none"
                raise LinkageError(f"point {reference!r}: no ground point {name!r} (ground points: {known})")
            return found
        found = self.body(owner).point(name)
        if found is None:
            raise LinkageError(f"point {reference!r}: body {owner!r} has no point {name!r}")
        return found

    def is_complete(self) -> bool:
        """True when it converts to a Mechanism (at least one body and one joint)."""
        return bool(self.bodies) and bool(self.joints)

    def to_mechanism(self) -> Mechanism:
        """The design as the file format's Mechanism (default masses from the density model); LinkageError when
        it has no body or no joint yet, or a reference the description refuses."""
        if not self.bodies:
            raise LinkageError("design: add a bar or a plate first (a mechanism needs at least one body)")
        if not self.joints:
            raise LinkageError("design: add a pin or a slider first (a mechanism needs at least one joint)")
        document = {
            "name": self.name, "description": self.description, "g": self.g,
            "ground": {name: list(xy) for name, xy in self.ground},
            "bodies": [_body_document(body) for body in self.bodies],
            "joints": [joint.model_dump() for joint in self.joints],
            "drivers": [driver.model_dump(exclude_none=True) for driver in self.drivers],
        }
        if self.trace is not None:
            document["trace"] = self.trace
        return mechanism_from_document(document, "design")

    # -- edits: each returns a new design or raises one LinkageError ---------------------------------------
    def add_ground(self, name: str, xy: Point) -> Design:
        """A fixed pivot point ``ground.name`` at ``xy``."""
        self._new_name(name, "ground point", "ground point")
        return replace(self, ground=(*self.ground, (name, _point(xy, f"ground point {name!r}"))))

    def add_bar(self, name: str, first: tuple[str, Point], second: tuple[str, Point]) -> Design:
        """A bar: a body of two named points."""
        return self._add_body(name, (first, second), "bar")

    def add_plate(self, name: str, corners: list[tuple[str, Point]] | tuple[tuple[str, Point], ...]) -> Design:
        """A plate: a body of three or more named points (at most 16)."""
        if len(corners) < 3:
            raise LinkageError(f"plate {name!r}: needs at least 3 points, got {len(corners)}")
        return self._add_body(name, tuple(corners), "plate")

    def add_pin(self, name: str, a: str, b: str) -> Design:
        """A pin holding point ``a`` on point ``b`` (``body.point`` or ``ground.point``)."""
        self._new_name(name, "pin", "joint")
        self.point(a)
        self.point(b)
        if a.partition(".")[0] == b.partition(".")[0]:
            raise LinkageError(f"pin {name!r}: joins {a.partition('.')[0]!r} to itself")
        if {a.partition(".")[0], b.partition(".")[0]} == {GROUND}:
            raise LinkageError(f"pin {name!r}: both points are on the ground")
        return self._with_joints((*self.joints, _built(f"pin {name!r}", Revolute, name=name, a=a, b=b)))

    def add_slider(self, name: str, point: str, through: str, direction: Point) -> Design:
        """A slider: ``point`` (``body.point``) slides on the line through ``through`` (a point of the ground or
        of another body) along ``direction``."""
        self._new_name(name, "slider", "joint")
        self.point(point)
        self.point(through)
        body, _, point_name = point.partition(".")
        on, _, through_name = through.partition(".")
        if body == GROUND:
            raise LinkageError(f"slider {name!r}: the sliding point {point!r} must be a body's, not the ground's")
        if body == on:
            raise LinkageError(f"slider {name!r}: its guide {through!r} is on the sliding body {body!r} itself")
        dx, dy = _point(direction, f"slider {name!r}: direction")
        if math.hypot(dx, dy) == 0.0:
            raise LinkageError(f"slider {name!r}: direction must not be [0, 0]")
        joint = _built(f"slider {name!r}", Prismatic, name=name, body=body, point=point_name, on=on,
                       through=through_name, direction=(dx, dy))
        return self._with_joints((*self.joints, joint))

    def add_motor(self, pin: str, speed: float | None = None, torque: float | None = None) -> Design:
        """A motor on pin ``pin``: a speed (rad/s) or a torque (N m), exactly one."""
        joint = next((j for j in self.joints if j.name == pin), None)
        if joint is None or joint.kind != "revolute":
            raise LinkageError(f"motor on {pin!r}: no pin of that name (pins: {', '.join(self._pins()) or 'none'})")
        if any(driver.joint == pin for driver in self.drivers):
            raise LinkageError(f"motor on {pin!r}: that pin already has a motor")
        driver = _built(f"motor on {pin!r}", Driver, joint=pin, speed=speed, torque=torque)
        return replace(self, drivers=(*self.drivers, driver))

    def set_trace(self, reference: str | None) -> Design:
        """The traced point (``body.point``) whose coupler curve is drawn, or None."""
        if reference is not None:
            if reference.partition(".")[0] == GROUND:
                raise LinkageError(f"trace {reference!r}: a ground point does not move; trace a body's point")
            self.point(reference)
        return replace(self, trace=reference)

    def set_mass(self, body: str, mass: float | None, inertia: float | None = None,
                 com: Point | None = None) -> Design:
        """Give body ``body`` its own mass (kg), centroidal inertia (kg m^2) and centre of mass (a sketch point;
        None: the mean of its points), checked as a file's body is; ``mass=None`` returns it to the density
        model. Moving one of its points later returns it to the density model too."""
        found = self.body(body)
        if mass is None:
            own = replace(found, mass=None, com=None, inertia=None)
        else:
            if inertia is None:
                raise LinkageError(f"body {body!r}: inertia: give the centroidal inertia (kg m^2) with the mass")
            checked = _built(f"body {body!r}", Body, name=body, points=dict(found.points), mass=mass,
                             com=com, inertia=inertia)
            own = replace(found, mass=checked.mass, com=checked.com, inertia=checked.inertia)
        return replace(self, bodies=tuple(own if b.name == body else b for b in self.bodies))

    def delete(self, written: str) -> Design:
        """Delete a ground point, a body, a joint (named as :meth:`item` reads it) or (``motor:PIN``) a motor;
        joints on a deleted body or ground point go with it, and their motors with them."""
        if written.startswith("motor:"):
            pin = written.removeprefix("motor:")
            if not any(driver.joint == pin for driver in self.drivers):
                raise LinkageError(f"motor on {pin!r}: no such motor")
            return replace(self, drivers=tuple(d for d in self.drivers if d.joint != pin))
        kind, name = self.item(written, "delete")
        ground = tuple((n, xy) for n, xy in self.ground if kind != "ground point" or n != name)
        bodies = tuple(body for body in self.bodies if kind != "body" or body.name != name)
        gone_owner = {"ground point": GROUND + "." + name, "body": name + "."}.get(kind)
        joints = tuple(j for j in self.joints if not (kind == "joint" and j.name == name)
                       and (gone_owner is None or not _touches(j, gone_owner)))
        joints = _without_orphan_gears(joints)
        kept = {j.name for j in joints}
        drivers = tuple(d for d in self.drivers if d.joint in kept)
        gone_trace = kind == "body" and self.trace is not None and self.trace.partition(".")[0] == name
        return replace(self, ground=ground, bodies=bodies, joints=joints, drivers=drivers,
                       trace=None if gone_trace else self.trace)

    def rename(self, written: str, new: str) -> Design:
        """Rename a ground point, a body or a joint (named as :meth:`item` reads it); every reference to it
        follows. The new name must be free among items of its kind only."""
        kind, old = self.item(written, "rename")
        if old == new:
            return self
        self._new_name(new, f"rename {written!r}: new name", kind)
        if kind == "ground point":
            ground = tuple((new if n == old else n, xy) for n, xy in self.ground)
            joints = tuple(_renamed_reference(j, GROUND, old, new) for j in self.joints)
            return replace(self, ground=ground, joints=joints)
        if kind == "body":
            bodies = tuple(replace(b, name=new) if b.name == old else b for b in self.bodies)
            joints = tuple(_renamed_body(j, old, new) for j in self.joints)
            trace = self.trace
            if trace is not None and trace.partition(".")[0] == old:
                trace = new + "." + trace.partition(".")[2]
            return replace(self, bodies=bodies, joints=joints, trace=trace)
        joints = tuple(j.model_copy(update={"name": new}) if j.name == old else _renamed_gear_joint(j, old, new)
                       for j in self.joints)
        drivers = tuple(d.model_copy(update={"joint": new}) if d.joint == old else d for d in self.drivers)
        return replace(self, joints=joints, drivers=drivers)

    def move_point(self, reference: str, xy: Point, grid: float | None = None) -> Design:
        """Move one sketch point to ``xy`` (rounded to the nearest multiple of ``grid`` metres when given). A
        moved body point drops the body's own mass properties (the density model recomputes them)."""
        self.point(reference)
        x, y = _point(xy, f"point {reference!r}")
        if grid is not None:
            if not (isinstance(grid, (int, float)) and math.isfinite(grid) and 1e-6 <= grid <= 10.0):
                raise LinkageError(f"grid = {grid!r}: allowed 1e-06 <= grid <= 10 metres")
            x, y = round(x / grid) * grid, round(y / grid) * grid
        owner, _, name = reference.partition(".")
        if owner == GROUND:
            return replace(self, ground=tuple((n, (x, y) if n == name else p) for n, p in self.ground))
        points = tuple((n, (x, y) if n == name else p) for n, p in self.body(owner).points)
        if _outline_length(tuple(xy for _, xy in points)) == 0.0:
            raise LinkageError(f"point {reference!r}: moved to {[x, y]}, every point of body {owner!r} would "
                               "coincide (a body needs a length)")
        bodies = tuple(replace(b, points=points, mass=None, com=None, inertia=None) if b.name == owner else b
                       for b in self.bodies)
        return replace(self, bodies=bodies)

    # -- helpers -----------------------------------------------------------------------------------------
    def _pins(self) -> list[str]:
        return [j.name for j in self.joints if j.kind == "revolute"]

    def _names_of(self, kind: str) -> list[str]:
        """The names of the items of ``kind`` (a key of ITEM_FORMS): one namespace of the file format."""
        if kind == "ground point":
            return [name for name, _ in self.ground]
        if kind == "body":
            return [body.name for body in self.bodies]
        return [joint.name for joint in self.joints]

    def _new_name(self, name: str, what: str, kind: str) -> None:
        """A new ``kind``'s name: of NAME's form (one every field of the file format takes and a pin's
        ``body.point`` can name), ``ground`` for no body (the file format's reserved word: ``ground.X`` is a
        ground point), and free among the items of its kind (the file format's namespaces)."""
        if not isinstance(name, str) or not NAME.match(name):
            raise LinkageError(f"{what} {name!r}: name: allowed {NAME_FORM}")
        if kind == "body" and name == GROUND:
            raise LinkageError(f"{what} {name!r}: name: {GROUND!r} is reserved for the fixed frame; allowed "
                               f"{NAME_FORM}, not {GROUND!r}")
        if name in self._names_of(kind):
            raise LinkageError(f"{what} {name!r}: name: a {kind} of that name exists (names are unique among "
                               f"{'bodies' if kind == 'body' else kind + 's'})")

    def _add_body(self, name: str, points: tuple[tuple[str, Point], ...], what: str) -> Design:
        self._new_name(name, what, "body")
        if len(self.bodies) >= MAX_BODIES:
            raise LinkageError(f"{what} {name!r}: a design holds at most {MAX_BODIES} bodies")
        if len(points) > MAX_POINTS_PER_BODY:
            raise LinkageError(f"{what} {name!r}: at most {MAX_POINTS_PER_BODY} points, got {len(points)}")
        checked = []
        for point_name, xy in points:
            if not isinstance(point_name, str) or not NAME.match(point_name):
                raise LinkageError(f"{what} {name!r}: point {point_name!r}: name: allowed {NAME_FORM}")
            checked.append((point_name, _point(xy, f"{what} {name!r}: point {point_name!r}")))
        if len({n for n, _ in checked}) != len(checked):
            raise LinkageError(f"{what} {name!r}: two points have the same name")
        if _outline_length(tuple(xy for _, xy in checked)) == 0.0:
            raise LinkageError(f"{what} {name!r}: its points all coincide (a body needs a length)")
        return replace(self, bodies=(*self.bodies, DesignBody(name=name, points=tuple(checked))))

    def _with_joints(self, joints: tuple[Any, ...]) -> Design:
        if len(joints) > 4 * MAX_BODIES:
            raise LinkageError(f"joint {joints[-1].name!r}: a design holds at most {4 * MAX_BODIES} joints")
        return replace(self, joints=joints)


def _built(what: str, model: Any, **fields: Any) -> Any:
    """``model(**fields)``, or one LinkageError naming ``what``, the field and the model's own reason."""
    try:
        return model(**fields)
    except ValidationError as error:
        item = error.errors()[0]
        where = ".".join(str(part) for part in item.get("loc", ()))
        message = str(item.get("msg", "invalid")).removeprefix("Value error, ")
        raise LinkageError(f"{what}: {where + ': ' if where else ''}{message}") from None


def _point(xy: Any, what: str) -> Point:
    if not isinstance(xy, (list, tuple)) or len(xy) != 2:
        raise LinkageError(f"{what}: expected [x, y], got {xy!r}")
    out = []
    for number in xy:
        if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(float(number)) \
                or abs(float(number)) > MAX_COORDINATE:
            raise LinkageError(f"{what}: coordinates must be finite numbers within ±{MAX_COORDINATE:g} m, got {xy!r}")
        out.append(float(number))
    return (out[0], out[1])


def _outline_length(points: tuple[Point, ...]) -> float:
    """The length of the closed polygon through ``points`` (a bar: twice its length)."""
    return sum(math.dist(points[k], points[(k + 1) % len(points)]) for k in range(len(points)))


def default_mass_properties(points: tuple[Point, ...]) -> tuple[float, Point, float]:
    """Mass, centre of mass and centroidal inertia of a body drawn as uniform rods of LINEAR_DENSITY along its
    outline: a bar (two points) is one rod, a plate its polygon's edges."""
    edges = [(points[0], points[1])] if len(points) == 2 else [
        (points[k], points[(k + 1) % len(points)]) for k in range(len(points))]
    return rods_mass_properties(edges)


def _body_document(body: DesignBody) -> dict:
    if body.mass is not None and body.inertia is not None:
        mass, centre, inertia = body.mass, body.com, body.inertia
    else:
        mass, centre, inertia = default_mass_properties(tuple(xy for _, xy in body.points))
    document: dict = {"name": body.name, "points": {n: list(xy) for n, xy in body.points}, "mass": mass,
                      "inertia": inertia}
    if centre is not None:
        document["com"] = list(centre)
    return document


def _references(joint: Any) -> list[str]:
    if joint.kind == "revolute":
        return [joint.a, joint.b]
    if joint.kind == "prismatic":
        return [f"{joint.body}.{joint.point}", f"{joint.on}.{joint.through}"]
    return []


def _touches(joint: Any, owner_prefix: str) -> bool:
    """True when a joint refers to the deleted owner: ``body.`` (any of its points) or ``ground.point``."""
    if owner_prefix.startswith(GROUND + "."):
        return owner_prefix in _references(joint)
    return any(ref.startswith(owner_prefix) for ref in _references(joint))


def _without_orphan_gears(joints: tuple[Any, ...]) -> tuple[Any, ...]:
    names = {j.name for j in joints}
    return tuple(j for j in joints if j.kind != "gear" or set(j.joints) <= names)


def _renamed_reference(joint: Any, owner: str, old: str, new: str) -> Any:
    """A joint with ``owner.old`` (a ground point) renamed ``owner.new``."""
    old_ref, new_ref = f"{owner}.{old}", f"{owner}.{new}"
    if joint.kind == "revolute":
        return joint.model_copy(update={"a": new_ref if joint.a == old_ref else joint.a,
                                        "b": new_ref if joint.b == old_ref else joint.b})
    if joint.kind == "prismatic" and joint.on == owner and joint.through == old:
        return joint.model_copy(update={"through": new})
    return joint


def _renamed_body(joint: Any, old: str, new: str) -> Any:
    def swap(reference: str) -> str:
        owner, _, point = reference.partition(".")
        return f"{new}.{point}" if owner == old else reference

    if joint.kind == "revolute":
        return joint.model_copy(update={"a": swap(joint.a), "b": swap(joint.b)})
    if joint.kind == "prismatic":
        return joint.model_copy(update={"body": new if joint.body == old else joint.body,
                                        "on": new if joint.on == old else joint.on})
    return joint


def _renamed_gear_joint(joint: Any, old: str, new: str) -> Any:
    if joint.kind != "gear":
        return joint
    return joint.model_copy(update={"joints": tuple(new if name == old else name for name in joint.joints)})


def _opened_body(body: Body) -> DesignBody:
    """A file's body as a design body: its own mass properties, unless they are exactly the density model's
    (a saved design's body), so a design saved and opened again is the same design."""
    points = tuple(body.points.items())
    sketch = tuple(xy for _, xy in points)
    # a body of one point (the slider-crank's piston) has no outline, so no density model: its own mass stays
    if _outline_length(sketch) > 0.0 and (body.mass, body.com, body.inertia) == default_mass_properties(sketch):
        return DesignBody(name=body.name, points=points)
    return DesignBody(name=body.name, points=points, mass=body.mass, com=body.com, inertia=body.inertia)


def design_from_mechanism(mechanism: Mechanism) -> Design:
    """A preset or a file opened as a design: every body keeps its own mass, centre of mass and inertia."""
    bodies = tuple(_opened_body(b) for b in mechanism.bodies)
    return Design(name=mechanism.name, description=mechanism.description, g=mechanism.g,
                  ground=tuple(mechanism.ground.items()), bodies=bodies, joints=tuple(mechanism.joints),
                  drivers=tuple(mechanism.drivers), trace=mechanism.trace)


@dataclass
class History:
    """Undo and redo of a design's edits: the designs before and after, kept whole (they are immutable)."""

    current: Design = field(default_factory=Design)
    undone: list[Design] = field(default_factory=list)
    done: list[Design] = field(default_factory=list)
    limit: int = 200

    def apply(self, design: Design) -> Design:
        """Make ``design`` (an edit's result) current; the redo list is dropped."""
        self.done.append(self.current)
        del self.done[:-self.limit]
        self.undone.clear()
        self.current = design
        return design

    def undo(self) -> Design:
        if not self.done:
            raise LinkageError("undo: nothing to undo")
        self.undone.append(self.current)
        self.current = self.done.pop()
        return self.current

    def redo(self) -> Design:
        if not self.undone:
            raise LinkageError("redo: nothing to redo")
        self.done.append(self.current)
        self.current = self.undone.pop()
        return self.current
