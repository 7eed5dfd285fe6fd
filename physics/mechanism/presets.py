"""Mechanisms a lecturer shows, written in the file format of :mod:`physics.mechanism.description`.

Each sketch is computed from the mechanism's link lengths by intersecting circles (one dyad at a time), so the
drawing is exactly assembled and on the branch the textbooks show; the bodies are uniform bars (mass
proportional to length, ``I = m L^2 / 12``) or triangular plates of one stated model (:data:`PLATE_MODEL`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .description import Body, Driver, Gear, Mechanism, Prismatic, Revolute

Point = tuple[float, float]
LINEAR_DENSITY = 1.0  # kg per metre of bar
# A ternary plate's mass model, one of PLATE_MODELS: "frame", its three edges as uniform bars of LINEAR_DENSITY
# (the presets' plates: the same mass as the three bars it replaces, and the same stock as every other link), or
# "lamina", a uniform triangle of AREAL_DENSITY. Mass, centre of mass and inertia all follow from the one model.
PLATE_MODELS = ("frame", "lamina")
PLATE_MODEL = "frame"
AREAL_DENSITY = 10.0  # kg per square metre of lamina (a steel sheet about 1.3 mm thick)


def circle_intersection(centre_a: Point, radius_a: float, centre_b: Point, radius_b: float, side: int) -> Point:
    """The intersection of two circles left (``side = +1``) or right (``-1``) of the line from a to b."""
    ax, ay = centre_a
    bx, by = centre_b
    distance = math.hypot(bx - ax, by - ay)
    along = (radius_a**2 - radius_b**2 + distance**2) / (2 * distance)
    across_sq = radius_a**2 - along**2
    if across_sq < 0:
        raise ValueError("circles do not meet: the dyad cannot close")
    across = math.sqrt(across_sq)
    ux, uy = (bx - ax) / distance, (by - ay) / distance
    return (ax + along * ux - side * across * uy, ay + along * uy + side * across * ux)


def bar(name: str, first: tuple[str, Point], second: tuple[str, Point], extra: dict[str, Point] | None = None) -> Body:
    """A uniform bar between two named points (``extra`` points ride on it, e.g. a traced coupler point)."""
    (name_a, a), (name_b, b) = first, second
    length = math.dist(a, b)
    mass = LINEAR_DENSITY * length
    points = {name_a: a, name_b: b, **(extra or {})}
    centre = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
    return Body(name=name, points=points, mass=mass, com=centre, inertia=mass * length**2 / 12)


def rods_mass_properties(edges) -> tuple[float, Point, float]:
    """Mass, centre of mass and centroidal inertia of uniform rods of LINEAR_DENSITY along ``edges`` (pairs of
    points): each rod ``m_k = LINEAR_DENSITY L_k`` with ``I = m_k L_k^2 / 12`` about its midpoint ``c_k``; G is the
    length-weighted mean of the midpoints and ``I_G = sum (m_k L_k^2 / 12 + m_k |c_k - G|^2)``."""
    lengths = [math.dist(p, q) for p, q in edges]
    masses = [LINEAR_DENSITY * length for length in lengths]
    mass = sum(masses)
    midpoints = [((p[0] + q[0]) / 2, (p[1] + q[1]) / 2) for p, q in edges]
    centre = (sum(m * x for m, (x, _) in zip(masses, midpoints)) / mass,
              sum(m * y for m, (_, y) in zip(masses, midpoints)) / mass)
    inertia = sum(m * length**2 / 12 + m * math.dist(mid, centre) ** 2
                  for m, length, mid in zip(masses, lengths, midpoints))
    return mass, centre, inertia


def plate(name: str, corners: dict[str, Point], model: str = PLATE_MODEL) -> Body:
    """A triangular plate through three named points, its mass, centre of mass and centroidal inertia from one
    model: ``"frame"``, three uniform bars along its edges (each ``m_k = LINEAR_DENSITY L_k`` with ``I = m_k L_k^2 /
    12`` about its midpoint ``c_k``; G is the length-weighted mean of the midpoints and ``I_G = sum (m_k L_k^2 / 12
    + m_k |c_k - G|^2)``), or ``"lamina"``, a uniform triangle (``m = AREAL_DENSITY * area``, G the mean of the
    corners, ``I_G = m (a^2 + b^2 + c^2) / 36``)."""
    a, b, c = (tuple(map(float, xy)) for xy in corners.values())
    edges = ((a, b), (b, c), (c, a))
    lengths = [math.dist(p, q) for p, q in edges]
    if model == "frame":
        mass, centre, inertia = rods_mass_properties(edges)
    elif model == "lamina":
        area = abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])) / 2
        mass = AREAL_DENSITY * area
        centre = ((a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3)
        inertia = mass * sum(length * length for length in lengths) / 36
    else:
        raise ValueError(f"plate model = {model!r}: allowed {', '.join(PLATE_MODELS)}")
    return Body(name=name, points=dict(corners), mass=mass, com=centre, inertia=inertia)


def pin(name: str, a: str, b: str) -> Revolute:
    return Revolute(name=name, a=a, b=b)


def slider_crank(crank: float = 0.05, rod: float = 0.2, angle_deg: float = 60.0) -> Mechanism:
    o = (0.0, 0.0)
    a = (crank * math.cos(math.radians(angle_deg)), crank * math.sin(math.radians(angle_deg)))
    b = (a[0] + math.sqrt(rod**2 - a[1] ** 2), 0.0)
    piston = Body(name="piston", points={"B": b}, mass=0.3, com=b, inertia=1e-4)
    return Mechanism(
        name="slider-crank",
        description=(
            "The engine's slider-crank: a crank, a connecting rod and a piston on a straight guide (a prismatic "
            "joint). Teaches the piston's position, velocity and acceleration in closed form, and a loop closed by "
            "a slider instead of a pin. One degree of freedom."
        ),
        ground={"O": o},
        bodies=[bar("crank", ("O", o), ("A", a)), bar("rod", ("A", a), ("B", b)), piston],
        joints=[
            pin("O", "ground.O", "crank.O"),
            pin("A", "crank.A", "rod.A"),
            pin("B", "rod.B", "piston.B"),
            Prismatic(name="guide", body="piston", point="B", on="ground", through="O", direction=(1.0, 0.0)),
        ],
        trace="piston.B",
    )


def crank_rocker(speed: float = 2 * math.pi) -> Mechanism:
    o2, o4 = (0.0, 0.0), (0.3, 0.0)
    a = (0.0, 0.1)
    b = circle_intersection(a, 0.35, o4, 0.25, side=+1)
    coupler_point = (a[0] + 0.5 * (b[0] - a[0]) - 0.08 * (b[1] - a[1]) / 0.35,
                     a[1] + 0.5 * (b[1] - a[1]) + 0.08 * (b[0] - a[0]) / 0.35)
    return Mechanism(
        name="crank-rocker",
        description=(
            "A Grashof crank-rocker (crank 0.10, coupler 0.35, rocker 0.25, ground 0.30 m) driven by a motor at "
            "one turn per second: the crank turns fully, the rocker swings. Teaches the driving torque over one "
            "turn (inverse dynamics) and the coupler curve of a point off the coupler's line."
        ),
        ground={"O2": o2, "O4": o4},
        bodies=[
            bar("crank", ("O2", o2), ("A", a)),
            bar("coupler", ("A", a), ("B", b), extra={"P": coupler_point}),
            bar("rocker", ("O4", o4), ("B", b)),
        ],
        joints=[pin("O2", "ground.O2", "crank.O2"), pin("A", "crank.A", "coupler.A"), pin("B", "coupler.B", "rocker.B"),
                pin("O4", "ground.O4", "rocker.O4")],
        drivers=[Driver(joint="O2", speed=speed)],
        trace="coupler.P",
    )


def chebyshev_lambda(speed: float = 2.0) -> Mechanism:
    """Chebyshev's lambda linkage in units of the crank: crank 1, ground 2, rocker 2.5, coupler 2.5 extended to
    a point P at 5 from the crank pin, which moves on a nearly straight line over half the turn."""
    scale = 0.1
    o, q = (0.0, 0.0), (2 * scale, 0.0)
    angle = math.radians(200.0)
    a = (scale * math.cos(angle), scale * math.sin(angle))
    b = circle_intersection(a, 2.5 * scale, q, 2.5 * scale, side=+1)
    p = (a[0] + 2 * (b[0] - a[0]), a[1] + 2 * (b[1] - a[1]))
    return Mechanism(
        name="chebyshev-lambda",
        description=(
            "Chebyshev's lambda linkage (1878): a four-bar whose coupler, extended to twice its length, carries a "
            "point that moves on a nearly straight line for half of each turn. Teaches approximate straight-line "
            "mechanisms and coupler curves; motor driven."
        ),
        ground={"O": o, "Q": q},
        bodies=[
            bar("crank", ("O", o), ("A", a)),
            Body(name="coupler", points={"A": a, "B": b, "P": p}, mass=LINEAR_DENSITY * math.dist(a, p),
                 com=b, inertia=LINEAR_DENSITY * math.dist(a, p) ** 3 / 12),
            bar("rocker", ("Q", q), ("B", b)),
        ],
        joints=[pin("O", "ground.O", "crank.O"), pin("A", "crank.A", "coupler.A"), pin("B", "coupler.B", "rocker.B"),
                pin("Q", "ground.Q", "rocker.Q")],
        drivers=[Driver(joint="O", speed=speed)],
        trace="coupler.P",
    )


def watt_six_bar() -> Mechanism:
    """Two four-bar loops in series: the first loop's rocker is a ternary link that drives the second loop
    (a Watt chain: the two ternary links, ground and rocker, share a joint)."""
    o2, o4, o6 = (0.0, 0.0), (0.4, 0.0), (0.75, 0.05)
    a = (0.0, 0.12)
    b = circle_intersection(a, 0.42, o4, 0.3, side=+1)
    c = circle_intersection(o4, 0.25, b, 0.2, side=-1)
    d = circle_intersection(c, 0.35, o6, 0.3, side=+1)
    return Mechanism(
        name="watt-six-bar",
        description=(
            "A Watt six-bar: two four-bar loops in series, the first loop's rocker a ternary plate that drives the "
            "second. Teaches mechanisms with several loops, the Grübler count (3 x 5 - 2 x 7 = 1) and how one "
            "crank sets every other link."
        ),
        ground={"O2": o2, "O4": o4, "O6": o6},
        bodies=[
            bar("crank", ("O2", o2), ("A", a)),
            bar("coupler", ("A", a), ("B", b)),
            plate("rocker", {"O4": o4, "B": b, "C": c}),
            bar("link", ("C", c), ("D", d)),
            bar("output", ("O6", o6), ("D", d)),
        ],
        joints=[
            pin("O2", "ground.O2", "crank.O2"), pin("A", "crank.A", "coupler.A"), pin("B", "coupler.B", "rocker.B"),
            pin("O4", "ground.O4", "rocker.O4"), pin("C", "rocker.C", "link.C"), pin("D", "link.D", "output.D"),
            pin("O6", "ground.O6", "output.O6"),
        ],
        trace="link.D",
    )


def stephenson_six_bar() -> Mechanism:
    """A four-bar whose coupler is a ternary plate driving a dyad to ground (a Stephenson chain: the two
    ternary links, ground and coupler, do not share a joint)."""
    o2, o4, o6 = (0.0, 0.0), (0.4, 0.0), (0.2, 0.45)
    a = (0.0, 0.12)
    b = circle_intersection(a, 0.42, o4, 0.3, side=+1)
    c = circle_intersection(a, 0.3, b, 0.3, side=+1)
    d = circle_intersection(c, 0.25, o6, 0.22, side=-1)
    return Mechanism(
        name="stephenson-six-bar",
        description=(
            "A Stephenson six-bar: a four-bar whose coupler is a ternary plate, its third corner driving a dyad to "
            "the ground. Teaches ternary links, the difference between Watt and Stephenson chains, and loops "
            "that share a body."
        ),
        ground={"O2": o2, "O4": o4, "O6": o6},
        bodies=[
            bar("crank", ("O2", o2), ("A", a)),
            plate("coupler", {"A": a, "B": b, "C": c}),
            bar("rocker", ("O4", o4), ("B", b)),
            bar("link", ("C", c), ("D", d)),
            bar("output", ("O6", o6), ("D", d)),
        ],
        joints=[
            pin("O2", "ground.O2", "crank.O2"), pin("A", "crank.A", "coupler.A"), pin("B", "coupler.B", "rocker.B"),
            pin("O4", "ground.O4", "rocker.O4"), pin("C", "coupler.C", "link.C"), pin("D", "link.D", "output.D"),
            pin("O6", "ground.O6", "output.O6"),
        ],
        trace="coupler.C",
    )


# Jansen's published lengths (the "holy numbers"), in centimetres: crank m, fixed pivot offset a (horizontal)
# and l (vertical), and the links b..k.
JANSEN_CM = {"a": 38.0, "b": 41.5, "c": 39.3, "d": 40.1, "e": 55.8, "f": 39.4, "g": 36.7, "h": 65.7, "i": 49.0,
             "j": 50.0, "k": 61.9, "l": 7.8, "m": 15.0}


def jansen_points(crank_angle: float, lengths: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """Every joint of Jansen's leg at one crank angle, by plain position analysis (one dyad at a time), metres.

    O crank axle, C crank pin, P fixed pivot, U and L the upper and lower joints of the links from the crank
    pin, W the outer corner of the upper triangle (|PW| = d, |UW| = e), T the top of the foot triangle
    (|WT| = f, |LT| = g), F the foot (|TF| = h, |LF| = i)."""
    n = {key: value / 100.0 for key, value in (lengths or JANSEN_CM).items()}
    o = (0.0, 0.0)
    p = (-n["a"], -n["l"])
    c = (n["m"] * math.cos(crank_angle), n["m"] * math.sin(crank_angle))
    u = circle_intersection(p, n["b"], c, n["j"], side=+1)  # upper joint: left of the line P -> C
    low = circle_intersection(p, n["c"], c, n["k"], side=-1)  # lower joint: right of it
    w = circle_intersection(p, n["d"], u, n["e"], side=+1)  # outer corner of the triangle b-d-e
    t = circle_intersection(w, n["f"], low, n["g"], side=-1)  # top of the foot triangle
    f = circle_intersection(low, n["i"], t, n["h"], side=+1)  # the foot, below
    joints = {"O": o, "P": p, "C": c, "U": u, "L": low, "W": w, "T": t, "F": f}
    return {name: np.array(xy) for name, xy in joints.items()}


def jansen_leg(speed: float = 2.0, crank_angle_deg: float = 0.0) -> Mechanism:
    pts = {name: (float(xy[0]), float(xy[1])) for name, xy in jansen_points(math.radians(crank_angle_deg)).items()}
    return Mechanism(
        name="jansen-leg",
        description=(
            "One leg of Theo Jansen's Strandbeest, with his published link lengths: seven bodies and ten pins "
            "(two triangles), one crank turned by a motor. The foot traces a path with a long, nearly flat "
            "bottom: walking without lifting the hip. Teaches multi-loop linkages and designing a path."
        ),
        ground={"O": pts["O"], "P": pts["P"]},
        bodies=[
            bar("crank", ("O", pts["O"]), ("C", pts["C"])),
            bar("upper", ("C", pts["C"]), ("U", pts["U"])),
            bar("lower", ("C", pts["C"]), ("L", pts["L"])),
            plate("triangle", {"P": pts["P"], "U": pts["U"], "W": pts["W"]}),
            bar("rocker", ("P", pts["P"]), ("L", pts["L"])),
            bar("tie", ("W", pts["W"]), ("T", pts["T"])),
            plate("foot", {"L": pts["L"], "T": pts["T"], "F": pts["F"]}),
        ],
        joints=[
            pin("O", "ground.O", "crank.O"),
            pin("C-upper", "crank.C", "upper.C"),
            pin("C-lower", "crank.C", "lower.C"),
            pin("U", "upper.U", "triangle.U"),
            pin("P-triangle", "ground.P", "triangle.P"),
            pin("P-rocker", "ground.P", "rocker.P"),
            pin("L-rocker", "lower.L", "rocker.L"),
            pin("L-foot", "rocker.L", "foot.L"),
            pin("W", "triangle.W", "tie.W"),
            pin("T", "tie.T", "foot.T"),
        ],
        drivers=[Driver(joint="O", speed=speed)],
        trace="foot.F",
    )


def geared_five_bar(speed: float = 2 * math.pi, ratio: float = -1.0, crank: float = 0.08,
                    couplers: tuple[float, float] = (0.28, 0.32), crank_angles_deg: tuple[float, float] = (90.0, 30.0)
                    ) -> Mechanism:
    """Two cranks on pivots 0.3 m apart, meshed by a gear pair (``ratio``: the second crank's turn per turn of
    the first), their couplers pinned together at C; a motor turns the first crank."""
    o1, o2 = (0.0, 0.0), (0.3, 0.0)
    first, second = (math.radians(angle) for angle in crank_angles_deg)
    a = (o1[0] + crank * math.cos(first), o1[1] + crank * math.sin(first))
    b = (o2[0] + crank * math.cos(second), o2[1] + crank * math.sin(second))
    c = circle_intersection(a, couplers[0], b, couplers[1], side=+1)
    return Mechanism(
        name="geared-five-bar",
        description=(
            "A geared five-bar: two cranks on ground pivots 0.3 m apart, meshed by two equal gears (ratio -1: "
            "they turn opposite ways at one speed), with two couplers pinned together at C. The gear pair makes "
            "the five-bar's two degrees of freedom one, so one motor drives it and C traces a closed curve. "
            "Teaches mobility (3 x 4 - 2 x 5 - 1 = 1) and a coupling joint's contact torque."
        ),
        ground={"O1": o1, "O2": o2},
        bodies=[
            bar("crank1", ("O1", o1), ("A", a)),
            bar("crank2", ("O2", o2), ("B", b)),
            bar("coupler1", ("A", a), ("C", c)),
            bar("coupler2", ("B", b), ("C", c)),
        ],
        joints=[
            pin("O1", "ground.O1", "crank1.O1"),
            pin("O2", "ground.O2", "crank2.O2"),
            pin("A", "crank1.A", "coupler1.A"),
            pin("B", "crank2.B", "coupler2.B"),
            pin("C", "coupler1.C", "coupler2.C"),
            Gear(kind="gear", name="gears", joints=("O1", "O2"), ratio=ratio),
        ],
        drivers=[Driver(joint="O1", speed=speed)],
        trace="coupler1.C",
    )


MECHANISM_PRESETS: dict[str, Callable[[], Mechanism]] = {
    "slider-crank": slider_crank,
    "crank-rocker": crank_rocker,
    "chebyshev-lambda": chebyshev_lambda,
    "watt-six-bar": watt_six_bar,
    "stephenson-six-bar": stephenson_six_bar,
    "jansen-leg": jansen_leg,
    "geared-five-bar": geared_five_bar,
}
