"""Whether a mechanism can run, checked in full before anything accepts it (the command line, the app).

The model (:mod:`physics.mechanism.model`) checks each field; :func:`~physics.mechanism.assembly.assemble`
checks the sketch closes at t = 0. Neither says the mechanism can *run*: a fully driven linkage may assemble at
the start and lock a quarter turn later (a crank too long for its loop: ``mechanism --file`` printed
"mobility 0" and exit 0), a massless body makes the equations of motion singular, a mass of 5e-324 kg
overflows ``1/m``, and a motor at 1000 rad/s turns a link 16 rad between two frames of a 60 Hz view.
:func:`check_mechanism` checks all of it and returns the assembled pose; every refusal is one line naming
the body, the joint or the motor, and the range.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import LinkageError
from .assembly import Assembled, assemble, sketch_size
from .dae import MechanismDAE
from .model import Mechanism

MAX_MOTOR_SPEED = 100.0  # rad/s, about 16 turns a second (a motor's speed in a file may be written up to 1e3)
MIN_MASS_RATIO = 1e-12  # smallest mass (or inertia / size^2) allowed beside the largest: a nonsingular matrix
SWEEP_POSES_PER_TURN = 72  # poses per turn of the fastest motor when a fully driven mechanism is swept
MAX_SWEEP_POSES = 2000


def check_mechanism(mechanism: Mechanism) -> Assembled:
    """The assembled pose of a mechanism that can run; LinkageError (one line) otherwise.

    Checks: every motor speed within ``MAX_MOTOR_SPEED``; the sketch assembles (joints close, no redundant
    constraint); every body has a positive mass and inertia, none negligible beside the largest
    (``MIN_MASS_RATIO``), so the mass matrix is positive definite; and a mechanism its motors fix (mobility 0)
    assembles through one turn of its slowest motor, so a run cannot lock partway."""
    for driver in mechanism.drivers:
        if driver.speed is not None and abs(driver.speed) > MAX_MOTOR_SPEED:
            raise LinkageError(f"driver on {driver.joint!r}: speed = {driver.speed:g} rad/s: allowed range "
                               f"-{MAX_MOTOR_SPEED:g} <= speed <= {MAX_MOTOR_SPEED:g} rad/s")
    assembled = assemble(mechanism)
    MechanismDAE(mechanism)  # refuses a body with no mass or no inertia, naming it
    size = sketch_size(mechanism)
    scaled = np.array([[body.mass, body.inertia / size**2] for body in mechanism.bodies])
    smallest = np.unravel_index(int(np.argmin(scaled)), scaled.shape)
    if scaled[smallest] < MIN_MASS_RATIO * float(np.max(scaled)):
        body = mechanism.bodies[int(smallest[0])]
        field, value, unit = ("mass", body.mass, "kg") if smallest[1] == 0 else ("inertia", body.inertia, "kg m^2")
        raise LinkageError(
            f"body {body.name!r}: {field} = {value:g} {unit} is negligible beside the heaviest body (below "
            f"{MIN_MASS_RATIO:g} of it): the mass matrix is singular in double precision; give it at least "
            f"{MIN_MASS_RATIO * float(np.max(scaled)) * (1.0 if smallest[1] == 0 else size**2):.3g} {unit}"
        )
    if assembled.mobility == 0:
        _sweep(mechanism, assembled)
    return assembled


def _sweep(mechanism: Mechanism, assembled: Assembled) -> None:
    """Follow a fully driven mechanism through one turn of its slowest motor, each pose assembled from the one
    before (as its run does); the first pose that does not close is refused with its time."""
    speeds = [abs(driver.speed) for driver in mechanism.drivers if driver.speed]
    if not speeds:
        return
    period = 2.0 * math.pi / min(speeds)
    poses = min(MAX_SWEEP_POSES, SWEEP_POSES_PER_TURN * math.ceil(max(speeds) / min(speeds)))
    q = assembled.q
    for t in np.linspace(0.0, period, poses + 1)[1:]:
        try:
            q = assemble(mechanism, q, float(t)).q
        except LinkageError as error:
            raise LinkageError(f"{mechanism.name}: the motors cannot drive it through a turn (it locks at t = "
                               f"{t:.3g} s of {period:.3g} s): {error}") from None
