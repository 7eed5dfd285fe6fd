"""Hand-written systems handed to the compiled kernels exactly as a generated mechanism is (the ``assemble`` and
``constraints`` contract of physics/kernels/abi.py): equations written out here, independent of the project's
derivations. Shared by tests/physics/test_kernels.py and tests/physics/test_kernels_geometric_test.py."""

import math

import numpy as np
from numba import cfunc

from physics.kernels import batch, explicit_rk, midpoint, projection, system
from physics.kernels.abi import ASSEMBLE_SIGNATURE, make_layout
from physics.kernels.constants import RK4_WORK_ROWS

DOUBLE_PARAMS = np.array([1.0, 1.0, 0.5, 0.5, 1.0, 1.0, 0.2, 0.3, 1.0, 0.0, 0.0])
DOUBLE_Y0 = np.array([1.2, -0.4, 0.0, 0.3])


# Double pendulum of rigid bars, from Lagrange's equations written out by hand:
#   M11 = I1 + m1 d1^2 + m2 L1^2, M12 = m2 L1 d2 cos(t1 - t2), M22 = I2 + m2 d2^2,
#   r1 = -m2 L1 d2 sin(t1 - t2) w2^2 - (m1 d1 + m2 L1) g sin t1,
#   r2 =  m2 L1 d2 sin(t1 - t2) w1^2 - m2 d2 g sin t2.
def double_assemble(theta, omega, params, A, b):
    L1 = params[0]
    d1 = params[2]
    d2 = params[3]
    m1 = params[4]
    m2 = params[5]
    I1 = params[6]
    I2 = params[7]
    g = params[8]
    s12 = math.sin(theta[0] - theta[1])
    c12 = math.cos(theta[0] - theta[1])
    A[0] = I1 + m1 * d1 * d1 + m2 * L1 * L1
    A[1] = m2 * L1 * d2 * c12
    A[2] = m2 * L1 * d2 * c12
    A[3] = I2 + m2 * d2 * d2
    b[0] = -m2 * L1 * d2 * s12 * omega[1] ** 2 - (m1 * d1 + m2 * L1) * g * math.sin(theta[0])
    b[1] = m2 * L1 * d2 * s12 * omega[0] ** 2 - m2 * d2 * g * math.sin(theta[1])


class Toy:
    """A hand-written system: ``assemble`` (``n`` coordinates, ``k`` unknowns, ``4 n + 3`` parameters, as a
    chain's) and, optionally, ``constraints`` with its constraint ``rows`` among the unknowns."""

    def __init__(self, assemble, n, k, constraints=None, rows=()):
        self.N_LINKS = n
        self.RK4_WORK_ROWS = RK4_WORK_ROWS
        self._compiled = cfunc(ASSEMBLE_SIGNATURE, error_model="numpy")(assemble)  # keeps the code alive
        self.assemble = self._compiled.address
        self._constraints = None if constraints is None else cfunc(ASSEMBLE_SIGNATURE, error_model="numpy")(constraints)
        address = 0 if self._constraints is None else self._constraints.address
        self.layout = make_layout(n, k, range(n), n_parameters=4 * n + 3, constraint_rows=rows,
                                  constraint_address=address)
        self.system = system.make_system(self.assemble, self.layout)

    def accel(self, theta, omega, params):
        theta_ddot = np.empty((1, self.N_LINKS))
        cond = np.empty(1)
        system.accel_states(self.assemble, self.layout, np.ascontiguousarray([theta]), np.ascontiguousarray([omega]),
                            params, 0.0, 0.0, theta_ddot, cond)
        return theta_ddot[0]

    def integrate_rk45(self, *args):
        return explicit_rk.integrate_rk45(self.assemble, self.layout, *args)

    def integrate_dop853(self, *args):
        return explicit_rk.integrate_dop853(self.assemble, self.layout, *args)

    def integrate_midpoint(self, *args):
        return midpoint.integrate_midpoint(self.assemble, self.layout, *args)

    def rk4_batch_step(self, *args):
        return batch.rk4_batch_step(self.assemble, self.layout, *args)

    def project_position(self, theta, params):
        return projection.project_position(self.system, theta, np.zeros_like(theta), params)

    def project_velocity(self, theta, omega, params):
        return projection.project_velocity(self.system, theta, omega, params)
