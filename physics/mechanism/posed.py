"""A mechanism redrawn at its assembled pose, so every joint closes exactly in the sketch.

Why: another tool's format stores one configuration and expects its joints to meet there (MuJoCo computes a
loop-closing constraint's second anchor from the first at the model's reference pose; pylinkage stores the
joints' positions). A user's sketch may be rough (assembly pulls it together), so the exporters write the
assembled pose, not the sketch: every point, centre of mass and ground point where assembly puts it.
"""

from __future__ import annotations

from .assembly import assemble
from .constraints import Constraints
from .description import Body, Mechanism
from .joints import kind_of


def at_assembled_pose(mechanism: Mechanism) -> Mechanism:
    """The same mechanism with every body drawn where :func:`assemble` puts it (masses and inertias unchanged;
    a slider's guide direction turned with the body that carries it; a gear's offset zero, its angles now
    measured from this pose)."""
    assembled = assemble(mechanism)
    constraints = Constraints(mechanism)
    q = assembled.q
    bodies = []
    turn = {}
    for k, body in enumerate(mechanism.bodies):
        points = {name: _xy(constraints.body_point(q, k, xy)) for name, xy in body.points.items()}
        centre = _xy(constraints.body_point(q, k, body.centre))
        bodies.append(Body(name=body.name, points=points, mass=body.mass, com=centre, inertia=body.inertia))
        turn[body.name] = float(q[3 * k + 2])
    joints = [kind_of(joint).at_pose(joint, turn) for joint in mechanism.joints]
    return mechanism.model_copy(update={"bodies": bodies, "joints": joints})


def _xy(point) -> tuple[float, float]:
    return (float(point[0]), float(point[1]))
