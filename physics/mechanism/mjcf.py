"""A mechanism written as MJCF, the XML model format of MuJoCo (and of the tools that read it, e.g. Pinocchio).

Why: MuJoCo is the simulator most robotics users have; a Linkage Lab mechanism written as MJCF runs there with
the same bodies, masses and joints, so either tool's run can be checked against the other's
(tests/physics/test_formats_mjcf.py). The mapping (docs/mechanisms.md, "Other tools' formats"):

* the plane: our x is MuJoCo's x, our y (up) is MuJoCo's z, gravity ``0 0 -g``; our counter-clockwise
  rotation (about our z, out of the drawing) is a rotation about MuJoCo's -y, so every hinge axis is ``0 -1 0``
  and a positive hinge angle turns the way a positive angle turns here;
* the pose: the assembled pose (:mod:`.posed`) is MuJoCo's reference configuration (every ``qpos`` zero);
* the bodies: nested along a spanning tree of the joint graph rooted at the ground, each body's frame at its tree
  joint and parallel to the world's; the tree takes the sliders first, then the pins that carry a motor or
  damping, then the rest, so those are MuJoCo joints;
* the joints: a tree pin is a ``hinge``, a tree slider a ``slide`` (its body keeps its angle, as ours); a pin
  that closes a loop is an ``<equality><connect>`` (MuJoCo's constraints are soft: ``CONNECT_TIME_STEPS``); a
  slider that closes a loop, or a motor or damping on a loop-closing pin, is refused in one line naming it;
* the inertia: mass, centre of mass and the centroidal inertia about the normal axis exactly; the two in-plane
  principal inertias are half of it each (a flat body's, by the perpendicular-axis theorem): MuJoCo refuses
  inertias that break the triangle inequality ``A + B >= C``, so "tiny" values are not allowed, and no planar
  motion depends on them;
* the motors: a torque motor is a ``general`` actuator whose force is the constant bias ``biasprm[0]`` (no
  control needed); a speed motor is a velocity servo, force ``kv (speed - rate)`` with ``kv`` the driven bodies'
  inertia about the motor over ``SPEED_SERVO_STEPS`` time steps: it follows the speed after a short start from rest,
  not the exact angle our motor prescribes (MuJoCo has no time-dependent equality constraint);
* a gear pair: an ``<equality><joint>`` between its two hinges (``polycoef`` ``0 ratio 0 0 0``, the ratio
  signed by which side of each pin is the hinge's child); a geared pin that closes a loop is refused;
* damping: a joint's ``damping``; contacts: none (every geom ``contype = conaffinity = 0``); every named point
  is a ``site`` named ``body.point`` (``ground.X`` for ground points), so a run can be read by point name.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from ..errors import LinkageError
from .description import GROUND, Gear, Mechanism, Prismatic, Revolute
from .posed import at_assembled_pose

MJCF_TIMESTEP = 2e-4  # s: the file's default time step (``timestep=`` or ``--timestep`` for another)
MAX_TIMESTEP = 0.01  # s
MJCF_INTEGRATOR = "RK4"  # explicit fourth order: the closest to our adaptive runs at a small step
# A loop-closing pin's constraint is a critically damped spring (solref = time constant, damping ratio 1) of
# time constant CONNECT_TIME_STEPS time steps, the stiffest MuJoCo allows. MuJoCo's default, 0.02 s, let the
# slider-crank's points stray 0.19 mm from our run within 1 s at a 1e-4 s step; 2e-4 s, 0.1 micrometre.
CONNECT_TIME_STEPS = 2.0
CONNECT_SOLIMP = (0.99, 0.9999, 0.001)  # impedance close to 1: the constraint almost rigid
# A speed motor's velocity servo has the time constant of this many time steps (10 ms at the default step):
# about 20 steps made the crank-rocker's servo unstable (its inertia about the motor changes with the pose).
SPEED_SERVO_STEPS = 50
IN_PLANE_INERTIA_SHARE = 0.5  # each in-plane principal inertia as a share of the one about the normal
RESERVED_BODY_NAMES = ("world",)
HINGE_AXIS = "0 -1 0"  # our counter-clockwise rotation in MuJoCo's x-z plane


def _number(value: float) -> str:
    return repr(float(value))  # the shortest text that reads back as the same double


def _vector(x: float, y: float) -> str:
    """Our (x, y) as MuJoCo's (x, 0, z)."""
    return f"{_number(x)} 0 {_number(y)}"


def _gears(mechanism: Mechanism) -> list[Gear]:
    return [joint for joint in mechanism.joints if isinstance(joint, Gear)]


def _linking(mechanism: Mechanism) -> list[Revolute | Prismatic]:
    """The joints that join two bodies (a gear joins none: it couples two pins' angles)."""
    return [joint for joint in mechanism.joints if isinstance(joint, (Revolute, Prismatic))]


def _priority(mechanism: Mechanism, joint: Revolute | Prismatic) -> int:
    driven = {driver.joint for driver in mechanism.drivers}
    driven |= {name for gear in _gears(mechanism) for name in gear.joints}
    if isinstance(joint, Prismatic):
        return 0
    if joint.name in driven or joint.damping > 0:
        return 1
    return 2


def _ends(joint: Revolute | Prismatic) -> tuple[str, str]:
    if isinstance(joint, Revolute):
        return joint.a.split(".")[0], joint.b.split(".")[0]
    return joint.on, joint.body


def spanning_tree(mechanism: Mechanism) -> tuple[dict[str, tuple[Revolute | Prismatic, str]], list[Revolute | Prismatic]]:
    """``(parent, cut)``: each body's tree joint and parent body, and the joints that close loops. Sliders enter
    the tree first, then pins with a motor or damping, then the other pins (each group in the file's order)."""
    root = {name: name for name in [GROUND, *(body.name for body in mechanism.bodies)]}

    def find(name: str) -> str:
        while root[name] != name:
            root[name] = root[root[name]]
            name = root[name]
        return name

    tree: list[Revolute | Prismatic] = []
    cut: list[Revolute | Prismatic] = []
    for joint in sorted(_linking(mechanism), key=lambda j: _priority(mechanism, j)):
        first, second = (find(end) for end in _ends(joint))
        if first == second:
            cut.append(joint)
        else:
            root[first] = second
            tree.append(joint)
    parent: dict[str, tuple[Revolute | Prismatic, str]] = {}
    frontier = [GROUND]
    while frontier:
        node = frontier.pop(0)
        for joint in tree:
            first, second = _ends(joint)
            for here, there in ((first, second), (second, first)):
                if here == node and there != GROUND and there not in parent:
                    parent[there] = (joint, node)
                    frontier.append(there)
    missing = [body.name for body in mechanism.bodies if body.name not in parent]
    if missing:
        raise LinkageError(f"body {missing[0]!r}: not connected to the ground by any chain of joints")
    order = {joint.name: k for k, joint in enumerate(mechanism.joints)}
    return parent, sorted(cut, key=lambda joint: order[joint.name])


def _joint_point(mechanism: Mechanism, joint: Revolute | Prismatic, body: str) -> tuple[float, float]:
    """Where ``joint`` holds ``body`` (the pin's point, the slider's sliding point or guide point)."""
    if isinstance(joint, Revolute):
        side = joint.a if joint.a.split(".")[0] == body else joint.b
        return mechanism.point_of(side, joint.name)
    if body == joint.body:
        return mechanism.point_of(f"{joint.body}.{joint.point}", joint.name)
    return mechanism.point_of(f"{joint.on}.{joint.through}", joint.name)


def _servo_gain(mechanism: Mechanism, pivot: tuple[float, float], moving: set[str], timestep: float) -> float:
    """``kv`` of a speed motor's servo: the moving bodies' inertia about the motor's pin over its time constant,
    SPEED_SERVO_STEPS time steps."""
    inertia = sum(body.inertia + body.mass * math.dist(body.centre, pivot) ** 2
                  for body in mechanism.bodies if body.name in moving)
    return max(inertia, 1e-9) / (SPEED_SERVO_STEPS * timestep)


def to_mjcf(mechanism: Mechanism, timestep: float = MJCF_TIMESTEP) -> str:
    """The MJCF document of ``mechanism`` (see the module's docstring for the mapping) for time steps of
    ``timestep`` seconds; LinkageError naming the joint, motor or body that has no counterpart."""
    if not (math.isfinite(timestep) and 0 < timestep <= MAX_TIMESTEP):
        raise LinkageError(f"timestep = {timestep!r}: allowed 0 < timestep <= {MAX_TIMESTEP} s")
    for body in mechanism.bodies:
        if body.name in RESERVED_BODY_NAMES:
            raise LinkageError(f"body {body.name!r}: MuJoCo reserves this name for the fixed frame; rename the body")
    for joint in mechanism.joints:
        if not isinstance(joint, (Revolute, Prismatic, Gear)):
            raise LinkageError(f"joint {joint.name!r}: a {joint.kind} joint has no MJCF counterpart here")
    posed = at_assembled_pose(mechanism)
    parent, cut = spanning_tree(posed)
    drivers = {driver.joint: driver for driver in posed.drivers}
    geared = {name for gear in _gears(posed) for name in gear.joints}
    for joint in cut:
        if joint.name in geared:
            raise LinkageError(f"joint {joint.name!r}: a geared pin closes a loop, and MuJoCo gears only joints of "
                               "its tree; remove a pin of its loop or gear another pin")
        if isinstance(joint, Prismatic):
            raise LinkageError(
                f"joint {joint.name!r}: a slider that closes a loop has no MJCF counterpart here (MuJoCo closes loops "
                "with point constraints); make it a tree joint by removing a pin of its loop")
        if joint.name in drivers:
            raise LinkageError(f"driver on {joint.name!r}: the motor's pin closes a loop, and MuJoCo drives only its "
                               "tree joints; drive a pin of the tree")
        if joint.damping > 0:
            raise LinkageError(f"joint {joint.name!r}: damping on a pin that closes a loop has no MJCF counterpart "
                               "(MuJoCo's point constraint carries none)")
    origin = {GROUND: (0.0, 0.0)}
    children: dict[str, list[str]] = {GROUND: []}
    for body in posed.bodies:
        children[body.name] = []
    for name, (joint, up) in parent.items():
        origin[name] = _joint_point(posed, joint, name)
        children[up].append(name)

    root = ET.Element("mujoco", model=posed.name)
    root.append(ET.Comment(
        " Written by Linkage Lab (python -m physics export; docs/mechanisms.md, 'Other tools' formats'): our x is "
        "x, our y is z, hinges turn about -y; the reference pose (qpos = 0) is the assembled pose. "))
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false")
    option = ET.SubElement(root, "option", timestep=_number(timestep), integrator=MJCF_INTEGRATOR,
                           gravity=f"0 0 {_number(-posed.g)}")
    ET.SubElement(option, "flag", contact="disable")
    size = max((math.dist(a, b) for body in posed.bodies for a in body.points.values() for b in body.points.values()),
               default=0.0) or 0.1
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0", size=_number(0.02 * size), rgba="0.3 0.5 0.8 1")
    ET.SubElement(default, "site", size=_number(0.01 * size))
    ET.SubElement(default, "equality", solref=f"{_number(CONNECT_TIME_STEPS * timestep)} 1",
                  solimp=" ".join(map(_number, CONNECT_SOLIMP)))

    world = ET.SubElement(root, "worldbody")
    for name, xy in posed.ground.items():
        ET.SubElement(world, "site", name=f"{GROUND}.{name}", pos=_vector(*xy))

    def write_body(element: ET.Element, name: str) -> None:
        body = posed.body(name)
        joint, up = parent[name]
        x0, y0 = origin[name]
        ux, uy = origin[up]
        node = ET.SubElement(element, "body", name=name, pos=_vector(x0 - ux, y0 - uy))
        gx, gy = body.centre
        share = IN_PLANE_INERTIA_SHARE * body.inertia
        ET.SubElement(node, "inertial", pos=_vector(gx - x0, gy - y0), mass=_number(body.mass),
                      diaginertia=f"{_number(share)} {_number(body.inertia)} {_number(share)}")
        if isinstance(joint, Revolute):
            ET.SubElement(node, "joint", name=joint.name, type="hinge", pos="0 0 0", axis=HINGE_AXIS,
                          damping=_number(joint.damping))
        else:
            ux_, uy_ = joint.direction
            norm = math.hypot(ux_, uy_)
            ET.SubElement(node, "joint", name=joint.name, type="slide", pos="0 0 0",
                          axis=_vector(ux_ / norm, uy_ / norm), damping=_number(joint.damping))
        others = [xy for xy in body.points.values() if math.dist(xy, (x0, y0)) > 1e-12 * size]
        ET.SubElement(node, "geom", type="sphere", pos="0 0 0")
        for x, y in others:
            ET.SubElement(node, "geom", type="capsule", fromto=f"0 0 0 {_vector(x - x0, y - y0)}")
        for point, (x, y) in body.points.items():
            ET.SubElement(node, "site", name=f"{name}.{point}", pos=_vector(x - x0, y - y0))
        for child in children[name]:
            write_body(node, child)

    for name in children[GROUND]:
        write_body(world, name)

    gears = _gears(posed)
    if cut or gears:
        equality = ET.SubElement(root, "equality")
        for joint in cut:
            assert isinstance(joint, Revolute)
            body_a = joint.a.split(".")[0]
            x, y = posed.point_of(joint.a, joint.name)
            ax, ay = origin[body_a]
            ET.SubElement(equality, "connect", name=joint.name,
                          body1="world" if body_a == GROUND else body_a,
                          body2="world" if joint.b.split(".")[0] == GROUND else joint.b.split(".")[0],
                          anchor=_vector(x - ax, y - ay))
        for pair in gears:
            ET.SubElement(equality, "joint", name=pair.name, joint1=pair.joints[1], joint2=pair.joints[0],
                          polycoef=f"0 {_number(_gear_coefficient(posed, parent, pair))} 0 0 0")
    if drivers:
        actuator = ET.SubElement(root, "actuator")
        for name, driver in drivers.items():
            pin = next(j for j in posed.joints if j.name == name)
            assert isinstance(pin, Revolute)
            child = next(body for body, (tree_joint, _) in parent.items() if tree_joint.name == name)
            # the hinge turns the child relative to its parent; our motor turns body b relative to body a
            gear = 1.0 if pin.b.split(".")[0] == child else -1.0
            if driver.torque is not None:
                ET.SubElement(actuator, "general", name=f"motor {name}", joint=name, gear=_number(gear),
                              gainprm="0", biastype="affine", biasprm=f"{_number(driver.torque)} 0 0")
            else:
                assert driver.speed is not None
                moving = _subtree(child, children)
                gain = _servo_gain(posed, origin[child], moving, timestep)
                ET.SubElement(actuator, "general", name=f"motor {name}", joint=name, gear=_number(gear),
                              gainprm="0", biastype="affine",
                              biasprm=f"{_number(gain * driver.speed)} 0 {_number(-gain)}")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def _gear_coefficient(posed: Mechanism, parent, gear: Gear) -> float:
    """MuJoCo's ``polycoef[1]`` of a gear: its ratio between the two hinges' angles, each hinge turning its child
    relative to its parent where our joint turns its body ``b`` relative to its ``a`` (offset zero at the
    assembled pose, MuJoCo's reference)."""
    coefficient = gear.ratio
    for name in gear.joints:
        child = next(body for body, (tree_joint, _) in parent.items() if tree_joint.name == name)
        joint = next(j for j in posed.joints if j.name == name)
        assert isinstance(joint, Revolute)
        coefficient *= 1.0 if joint.b.split(".")[0] == child else -1.0
    return coefficient


def _subtree(name: str, children: dict[str, list[str]]) -> set[str]:
    found = {name}
    for child in children[name]:
        found |= _subtree(child, children)
    return found
