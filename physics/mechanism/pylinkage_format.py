"""pylinkage's JSON (its ``mechanism_to_dict`` / ``mechanism_to_json``, pylinkage 1.x) read into a Mechanism, and
a Mechanism written as that JSON.

Why: pylinkage is the Python library for designing and optimising planar linkages by their kinematics; reading
its files lets a linkage designed there be simulated here with masses and gravity, and writing them lets ours be
optimised there. Its JSON is plain data, so neither direction imports pylinkage (the tests use it to make and
to read the files). The mapping (docs/mechanisms.md, "Other tools' formats"):

* a pylinkage *link* is a rigid body through its *joints*; a joint shared by links is a pin between them, a
  ``ground`` joint (or one the ground link lists) a fixed point with a pin to each link through it; a joint
  only one link lists is a point of that body;
* a ``tracker`` joint (a point at ``distance`` and ``angle`` from ``ref_joint1``, the angle measured from the
  line to ``ref_joint2``) is a point of the link that holds both, and the traced point;
* a ``prismatic`` joint is pylinkage's pin in a slot fixed to the ground: here a slider block (``BLOCK_MASS``,
  ``BLOCK_INERTIA``) on a prismatic joint along the slot, pinned to each link through the joint;
* a ``driver`` link turns about its ``motor_joint`` at ``angular_velocity`` radians per step: a speed motor of
  ``angular_velocity / STEP_SECONDS`` rad/s, so pylinkage's step k is our time ``k * STEP_SECONDS``;
  ``arc_driver`` links (a motor that swings back and forth) are refused;
* pylinkage has no masses: every link is a frame of uniform bars of ``LINE_DENSITY`` between its joints in the
  order it lists them (two joints: one bar; three or more: the closed polygon), lengths in metres
  (:data:`DENSITY_NOTE`, printed once by the command that imports).

Writing is the reverse for what pylinkage can hold: pins (grouped into shared joints), ground points, speed
motors on a pin to the ground turning a crank of two points, and sliders whose block carries only the pin at its
sliding point on a guide fixed to the ground. Masses, inertias, damping and gravity are not written (pylinkage
has none); a torque motor or any other slider is refused in one line naming it.
"""

from __future__ import annotations

import math
import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ..errors import LinkageError
from .description import GROUND, Body, Driver, Gear, Mechanism, Prismatic, Revolute
from .posed import at_assembled_pose
from .presets import LINEAR_DENSITY

STEP_SECONDS = 0.01  # s per pylinkage step: its default speed, tau/100 rad per step, is one turn a second
LINE_DENSITY = LINEAR_DENSITY  # kg per metre of bar, as the presets' bars
BLOCK_MASS = 0.1  # kg: a slider block, which pylinkage's file does not draw
BLOCK_INERTIA = 1e-5  # kg m^2: a 0.1 kg block about 3 cm across
DENSITY_NOTE = (f"note: pylinkage files hold no masses: each link is taken as uniform bars of {LINE_DENSITY:g} kg/m "
                f"between its joints (lengths in metres), each slider block {BLOCK_MASS:g} kg; one pylinkage step is "
                f"{STEP_SECONDS:g} s")
LEGACY_TYPES = {"Static", "Crank", "Revolute", "Fixed", "Prismatic", "Linear"}
NAME_LIMIT = 40


def _finite(value: Any) -> tuple[float, float]:
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise ValueError(f"expected [x, y] of finite numbers, got {value!r}")
    return (float(value[0]), float(value[1]))


class PyJoint(BaseModel):
    """One entry of the file's ``joints`` (unknown keys are ignored: a newer pylinkage may add some)."""

    model_config = ConfigDict(extra="ignore")

    id: str = Field(min_length=1, max_length=200)
    type: Literal["ground", "revolute", "prismatic", "tracker"] = "revolute"
    position: tuple[float, float] | None = None
    axis: tuple[float, float] = (1.0, 0.0)
    line_point: tuple[float, float] = (0.0, 0.0)
    ref_joint1_id: str = ""
    ref_joint2_id: str = ""
    distance: float = Field(0.0, ge=0.0, le=1e4, allow_inf_nan=False)
    angle: float = Field(0.0, ge=-1e3, le=1e3, allow_inf_nan=False)

    @field_validator("position", mode="before")
    @classmethod
    def _position(cls, value: Any) -> tuple[float, float] | None:
        if value is None or (isinstance(value, (list, tuple)) and all(v is None for v in value)):
            return None
        return _finite(value)

    @field_validator("axis", "line_point", mode="before")
    @classmethod
    def _pair(cls, value: Any) -> tuple[float, float]:
        return _finite(value)


class PyLink(BaseModel):
    """One entry of the file's ``links``."""

    model_config = ConfigDict(extra="ignore")

    id: str = Field(min_length=1, max_length=200)
    type: Literal["ground", "driver", "arc_driver", "link"] = "link"
    joints: list[str] = Field(default_factory=list, max_length=16)
    angular_velocity: float = Field(math.tau / 360, ge=-10.0, le=10.0, allow_inf_nan=False,
                                    description="rad per step")
    initial_angle: float | None = Field(None, allow_inf_nan=False)
    motor_joint: str | None = None


class PyDocument(BaseModel):
    model_config = ConfigDict(extra="ignore")

    name: str = Field("pylinkage", max_length=80)
    joints: list[PyJoint] = Field(min_length=1, max_length=200)
    links: list[PyLink] = Field(min_length=1, max_length=100)


def _names(ids: list[str], prefix: str) -> dict[str, str]:
    """pylinkage ids (any text, e.g. ``coupler.1_rocker.0``) as our names: letters, digits, ``_`` and ``-``,
    starting with a letter, at most 40 characters, each one different."""
    out: dict[str, str] = {}
    taken: set[str] = {GROUND, "world"}
    for identifier in ids:
        name = re.sub(r"[^A-Za-z0-9_-]", "_", identifier)
        if not name or not name[0].isalpha():
            name = f"{prefix}{name}"
        name = name[:NAME_LIMIT]
        base, k = name, 2
        while name in taken:
            suffix = f"-{k}"
            name = base[: NAME_LIMIT - len(suffix)] + suffix
            k += 1
        taken.add(name)
        out[identifier] = name
    return out


def _frame_of_bars(name: str, points: dict[str, tuple[float, float]], order: list[str]) -> Body:
    """Uniform bars of LINE_DENSITY between consecutive joints of ``order`` (closed when three or more): mass,
    centre of mass and centroidal inertia, each bar ``m L^2 / 12`` about its midpoint plus ``m d^2``."""
    corners = [points[p] for p in order]
    edges = [(corners[0], corners[1])] if len(corners) == 2 else list(zip(corners, corners[1:] + corners[:1]))
    bars = [(LINE_DENSITY * math.dist(p, q), math.dist(p, q), ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2)) for p, q in edges]
    mass = sum(m for m, _, _ in bars)
    if mass <= 0:
        raise LinkageError(f"link {name!r}: its joints coincide, so its bars have no length (and no mass)")
    centre = (sum(m * c[0] for m, _, c in bars) / mass, sum(m * c[1] for m, _, c in bars) / mass)
    inertia = sum(m * length**2 / 12 + m * math.dist(c, centre) ** 2 for m, length, c in bars)
    return Body(name=name, points=points, mass=mass, com=centre, inertia=inertia)


def _parse(document: Any, source: str) -> PyDocument:
    if not isinstance(document, dict):
        raise LinkageError(f"{source}: expected pylinkage's JSON object of name, joints and links")
    joints = document.get("joints")
    if isinstance(joints, list) and any(isinstance(j, dict) and j.get("type") in LEGACY_TYPES for j in joints):
        raise LinkageError(f"{source}: pylinkage's legacy format (joint types {', '.join(sorted(LEGACY_TYPES))}) is "
                           "not read; load it in pylinkage 1.x and save it with mechanism_to_json")
    try:
        return PyDocument.model_validate(document)
    except ValidationError as error:
        item = error.errors()[0]
        location = list(item.get("loc", ()))
        where = []
        if len(location) >= 2 and location[0] in ("joints", "links") and isinstance(location[1], int):
            entries = document.get(location[0], [])
            entry = entries[location[1]] if location[1] < len(entries) else None
            label = "joint" if location[0] == "joints" else "link"
            ident = entry.get("id") if isinstance(entry, dict) else None
            where.append(f"{label} {ident!r}" if ident is not None else f"{label} {location[1] + 1}")
            location = location[2:]
        where += [str(part) for part in location]
        message = str(item.get("msg", "invalid")).removeprefix("Value error, ")
        raise LinkageError(f"{source}: {': '.join(where) + ': ' if where else ''}{message}") from None


def mechanism_from_pylinkage(document: Any, source: str = "pylinkage file") -> Mechanism:
    """A Mechanism from pylinkage's JSON (already parsed); one-line LinkageError naming the joint or link."""
    parsed = _parse(document, source)
    joints = {joint.id: joint for joint in parsed.joints}
    if len(joints) != len(parsed.joints):
        raise LinkageError(f"{source}: two joints share an id")
    for link in parsed.links:
        for ident in link.joints:
            if ident not in joints:
                raise LinkageError(f"{source}: link {link.id!r}: no joint {ident!r}")
        if link.type == "arc_driver":
            raise LinkageError(f"{source}: link {link.id!r}: an arc driver (a motor that swings back and forth) has "
                               "no counterpart here; motors turn at a constant speed")
    grounded = {ident for link in parsed.links if link.type == "ground" for ident in link.joints}
    grounded |= {link.motor_joint for link in parsed.links if link.type == "driver" and link.motor_joint}
    grounded |= {joint.id for joint in parsed.joints if joint.type == "ground"}
    positions: dict[str, tuple[float, float]] = {}
    for joint in parsed.joints:
        if joint.type != "tracker":
            if joint.position is None:
                raise LinkageError(f"{source}: joint {joint.id!r}: position: no position given")
            positions[joint.id] = joint.position
    point_name = _names([joint.id for joint in parsed.joints], "j")
    moving = [link for link in parsed.links if link.type != "ground"]
    body_name = _names([link.id for link in moving], "L")
    points: dict[str, dict[str, tuple[float, float]]] = {}
    for link in moving:
        members = [ident for ident in dict.fromkeys(link.joints) if joints[ident].type != "tracker"]
        if len(members) < 2:
            raise LinkageError(f"{source}: link {link.id!r}: a link needs at least two joints (it has "
                               f"{len(members)})")
        points[link.id] = {point_name[ident]: positions[ident] for ident in members}
    trace = None
    for joint in parsed.joints:
        if joint.type != "tracker":
            continue
        holder = next((link for link in moving
                       if joint.ref_joint1_id in link.joints and joint.ref_joint2_id in link.joints), None)
        if holder is None or joint.ref_joint1_id not in positions or joint.ref_joint2_id not in positions:
            raise LinkageError(f"{source}: joint {joint.id!r}: a tracker must refer to two joints of one link")
        (x1, y1), (x2, y2) = positions[joint.ref_joint1_id], positions[joint.ref_joint2_id]
        direction = math.atan2(y2 - y1, x2 - x1) + joint.angle
        points[holder.id][point_name[joint.id]] = (x1 + joint.distance * math.cos(direction),
                                                  y1 + joint.distance * math.sin(direction))
        trace = trace or f"{body_name[holder.id]}.{point_name[joint.id]}"
    bodies = [_frame_of_bars(body_name[link.id], points[link.id],
                             [point_name[i] for i in dict.fromkeys(link.joints) if joints[i].type != "tracker"])
              for link in moving]
    ground: dict[str, tuple[float, float]] = {}
    pins: list[Revolute | Prismatic] = []
    drivers: list[Driver] = []
    motor_pins: dict[tuple[str, str], str] = {}  # (joint id, link id) -> pin name
    for joint in parsed.joints:
        if joint.type == "tracker":
            continue
        holders = [link for link in moving if joint.id in link.joints]
        name = point_name[joint.id]
        if joint.id in grounded:
            ground[name] = positions[joint.id]
            anchor = f"{GROUND}.{name}"
        elif joint.type == "prismatic":
            block = _names([f"{name}-block"], "b")[f"{name}-block"]
            ground[f"{name}-slot"] = joint.line_point
            bodies.append(Body(name=block, points={name: positions[joint.id]}, mass=BLOCK_MASS,
                               com=positions[joint.id], inertia=BLOCK_INERTIA))
            pins.append(Prismatic(name=f"{name}-slot", body=block, point=name, on=GROUND, through=f"{name}-slot",
                                  direction=joint.axis))
            anchor = f"{block}.{name}"
        elif holders:
            anchor, holders = f"{body_name[holders[0].id]}.{name}", holders[1:]
        else:
            continue
        for k, link in enumerate(holders):
            pin_name = name if len(holders) == 1 else f"{name}-{k + 1}"
            pins.append(Revolute(name=pin_name, a=anchor, b=f"{body_name[link.id]}.{name}"))
            motor_pins[(joint.id, link.id)] = pin_name
    for link in moving:
        if link.type != "driver":
            continue
        if link.motor_joint is None or (link.motor_joint, link.id) not in motor_pins:
            raise LinkageError(f"{source}: link {link.id!r}: a driver needs a motor_joint among its joints")
        drivers.append(Driver(joint=motor_pins[(link.motor_joint, link.id)],
                              speed=link.angular_velocity / STEP_SECONDS))
    document_out = {
        "name": parsed.name[:80] or "pylinkage",
        "description": f"Imported from pylinkage's JSON ({DENSITY_NOTE.removeprefix('note: ')}).",
        "g": 9.81,
        "ground": ground,
        "bodies": [body.model_dump() for body in bodies],
        "joints": [pin.model_dump() for pin in pins],
        "drivers": [driver.model_dump(exclude_none=True) for driver in drivers],
        "trace": trace,
    }
    try:
        return Mechanism.model_validate(document_out)
    except ValidationError as error:
        message = str(error.errors()[0].get("msg", "invalid")).removeprefix("Value error, ")
        raise LinkageError(f"{source}: {message}") from None


def _pin_ends(joint: Revolute) -> tuple[str, str]:
    return joint.a, joint.b


def to_pylinkage(mechanism: Mechanism) -> dict:
    """pylinkage's JSON (as ``mechanism_to_dict`` writes it) of ``mechanism`` at its assembled pose; LinkageError
    naming the motor or slider pylinkage cannot hold."""
    posed = at_assembled_pose(mechanism)
    pins = [joint for joint in posed.joints if isinstance(joint, Revolute)]
    dropped: set[str] = set()  # slider blocks: pylinkage's prismatic joint is the pin in the slot itself
    slots: dict[str, Prismatic] = {}  # "body.point" of the block's pin on the other link -> the slider
    driven = {driver.joint for driver in posed.drivers}
    for joint in posed.joints:
        if not isinstance(joint, Prismatic):
            continue
        block_pins = [pin for pin in pins if joint.body in (pin.a.split(".")[0], pin.b.split(".")[0])]
        sliding = f"{joint.body}.{joint.point}"
        others = [j for j in posed.joints if j is not joint and isinstance(j, Prismatic)
                  and joint.body in (j.body, j.on)]
        if (joint.on != GROUND or len(block_pins) != 1 or sliding not in _pin_ends(block_pins[0])
                or block_pins[0].name in driven or others):
            raise LinkageError(
                f"joint {joint.name!r}: pylinkage's slider is a pin in a slot fixed to the ground; this slider is "
                "not (its guide must be on the ground and its body carry only one pin, at its sliding point)")
        dropped.add(joint.body)
        pin = block_pins[0]
        slots[pin.b if pin.a == sliding else pin.a] = joint
    for joint in posed.joints:
        if not isinstance(joint, (Revolute, Prismatic)):
            what = "a gear pair" if isinstance(joint, Gear) else f"a {joint.kind} joint"
            raise LinkageError(f"joint {joint.name!r}: {what} has no pylinkage counterpart (pylinkage's joints are "
                               "pins, cranks and slots)")
    for driver in posed.drivers:
        if driver.torque is not None:
            raise LinkageError(f"driver on {driver.joint!r}: a torque motor has no pylinkage counterpart (pylinkage "
                               "turns its cranks at a set speed)")
    # every point, joined into one pylinkage joint by the pins through it
    root: dict[str, str] = {}

    def find(ref: str) -> str:
        root.setdefault(ref, ref)
        while root[ref] != ref:
            root[ref] = root[root[ref]]
            ref = root[ref]
        return ref

    for name in posed.ground:
        find(f"{GROUND}.{name}")
    for body in posed.bodies:
        if body.name not in dropped:
            for point in body.points:
                find(f"{body.name}.{point}")
    for pin in pins:
        if pin.a.split(".")[0] in dropped or pin.b.split(".")[0] in dropped:
            continue
        root[find(pin.a)] = find(pin.b)
    groups: dict[str, list[str]] = {}
    for ref in list(root):
        groups.setdefault(find(ref), []).append(ref)
    position = {f"{GROUND}.{name}": xy for name, xy in posed.ground.items()}
    for body in posed.bodies:
        position.update({f"{body.name}.{point}": xy for point, xy in body.points.items()})
    pin_through = {ref: pin.name for pin in pins for ref in (pin.a, pin.b)}
    # a point no pin uses is a tracker (pylinkage's coupler point) of two pinned joints of its body, when it has two
    shared = {top for top, members in groups.items()
              if len(members) > 1 or any(ref.startswith(f"{GROUND}.") or ref in slots for ref in members)}
    pinned_of = {body.name: [find(f"{body.name}.{point}") for point in body.points
                             if find(f"{body.name}.{point}") in shared] for body in posed.bodies}
    ident: dict[str, str] = {}
    taken: set[str] = set()
    joints_out = []
    trackers = []
    for top, members in groups.items():
        grounds = [ref for ref in members if ref.startswith(f"{GROUND}.")]
        named = [pin_through[ref] for ref in members if ref in pin_through]
        # a ground point's name, else the first pin's, else (a point of one body) the point's own name
        base = grounds[0].removeprefix(f"{GROUND}.") if grounds else named[0] if named else members[0].split(".", 1)[1]
        name, k = base, 2
        while name in taken:
            name, k = f"{base}-{k}", k + 1
        taken.add(name)
        ident[top] = name
        px, py = position[(grounds or members)[0]]
        entry: dict[str, Any] = {"id": name, "type": "ground" if grounds else "revolute", "position": [px, py]}
        slot = next((slots[ref] for ref in members if ref in slots), None)
        refs = list(dict.fromkeys(pinned_of[members[0].split(".")[0]])) if top not in shared else []
        if slot is not None:
            if grounds:
                raise LinkageError(f"joint {slot.name!r}: its block is pinned to the ground, so it cannot slide")
            ux, uy = slot.direction
            norm = math.hypot(ux, uy)
            lx, ly = posed.point_of(f"{GROUND}.{slot.through}", slot.name)
            entry.update({"type": "prismatic", "axis": [ux / norm, uy / norm], "line_point": [lx, ly],
                          "slide_distance": ((px - lx) * ux + (py - ly) * uy) / norm})
        elif len(refs) >= 2:
            (x1, y1), (x2, y2) = position[groups[refs[0]][0]], position[groups[refs[1]][0]]
            angle = math.atan2(py - y1, px - x1) - math.atan2(y2 - y1, x2 - x1)
            entry.update({"type": "tracker", "ref_joint1_id": refs[0], "ref_joint2_id": refs[1],
                          "distance": math.dist((px, py), (x1, y1)), "angle": math.remainder(angle, math.tau)})
            trackers.append(top)
        joints_out.append(entry)
    for entry in joints_out:  # the references by name, now that every group has one
        if entry["type"] == "tracker":
            entry["ref_joint1_id"], entry["ref_joint2_id"] = ident[entry["ref_joint1_id"]], ident[entry["ref_joint2_id"]]
    if posed.trace is not None and find(posed.trace) in trackers:  # the traced point first: read back as the trace
        first = ident[find(posed.trace)]
        joints_out.sort(key=lambda entry: entry["id"] != first)
    motors: dict[str, tuple[str, float]] = {}  # body -> (its ground point's reference, its speed, signed)
    for driver in posed.drivers:
        pin = next(p for p in pins if p.name == driver.joint)
        a_body, b_body = pin.a.split(".")[0], pin.b.split(".")[0]
        if GROUND not in (a_body, b_body):
            raise LinkageError(f"driver on {driver.joint!r}: pylinkage's motors turn a crank about a ground joint; "
                               "this motor joins two moving bodies")
        assert driver.speed is not None
        crank, anchor, sign = (b_body, pin.b, 1.0) if a_body == GROUND else (a_body, pin.a, -1.0)
        motors[crank] = (anchor, sign * driver.speed)
    ground_joints = list(dict.fromkeys(ident[find(f"{GROUND}.{name}")] for name in posed.ground))
    links_out: list[dict[str, Any]] = [{"id": GROUND, "type": "ground", "joints": ground_joints}]
    for body in posed.bodies:
        if body.name in dropped:
            continue
        members = list(dict.fromkeys(ident[find(f"{body.name}.{point}")] for point in body.points
                                     if find(f"{body.name}.{point}") not in trackers))
        link: dict[str, Any] = {"id": body.name, "type": "link", "joints": members}
        if body.name in motors:
            anchor, speed = motors[body.name]
            if len(members) != 2:
                raise LinkageError(f"body {body.name!r}: pylinkage drives a crank of exactly two joints; this one "
                                   f"has {len(members)}")
            motor = ident[find(anchor)]
            output = next(m for m in members if m != motor)
            (mx, my), (ox, oy) = (next(j["position"] for j in joints_out if j["id"] == i) for i in (motor, output))
            link.update({"type": "driver", "angular_velocity": speed * STEP_SECONDS,
                         "initial_angle": math.atan2(oy - my, ox - mx), "motor_joint": motor})
        links_out.append(link)
    return {"name": posed.name, "joints": joints_out, "links": links_out, "ground": GROUND}
