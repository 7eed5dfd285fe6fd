"""Status codes and the numerical constants every kernel shares (one table, one meaning each).

The status codes are named for Python code by ``physics.status.Status`` (with their messages)."""

STATUS_OK = 0
STATUS_SINGULAR = -1  # accel reported a pivot ratio above SINGULAR_PIVOT_RATIO (or inf)
STATUS_NOT_FINITE = -2  # a state, an acceleration or an error estimate turned NaN or infinite
STATUS_STEP_TOO_SMALL = -3  # the adaptive step fell below 10 ulp of t, as in scipy
STATUS_MAX_STEPS = -4  # more than max_steps accepted steps were needed
STATUS_INTEGRATOR_FAILED = -5  # the integrator gave up: for the fixed-step ones, Newton did not converge (reduce h)

# A 2-norm condition number beyond which a solve has lost about 12 of its 16 digits: the answer is noise
# (the projection leaves a state alone where J J^T is this badly conditioned).
SINGULAR_CONDITION_NUMBER = 1e12
# The pivot ratio returned by accel grows like 1/delta at a distance delta from a loop singularity, while
# the 2-norm condition number grows like 1/delta^2: a ratio of 1e6 means a condition near 1e12, about 12 of
# 16 digits lost. Past it the accelerations are not worth integrating. Every path (kernels, scipy back end,
# ensembles, single evaluations) uses this one name.
SINGULAR_PIVOT_RATIO = 1e6
# Above this pivot ratio the fast solve is redone with equilibration (well below the singular threshold).
RESCALE_ABOVE = 1e4
# Entries below this fraction of the largest are rounding noise (about 500 units in the last place).
RELATIVE_NOISE = 1e-13

# scipy.integrate._ivp.rk: step-size controller constants.
SAFETY = 0.9  # multiply steps computed from asymptotic behaviour of errors by this
MIN_FACTOR = 0.2  # minimum allowed decrease in a step size
MAX_FACTOR = 10.0  # maximum allowed increase in a step size

# Projection onto the loop constraint: Gauss-Newton converges quadratically, a few iterations suffice.
PROJECTION_TOLERANCE = 1e-13  # |tip - pin| at which the position projection stops
PROJECTION_MAX_ITERATIONS = 8

# Implicit midpoint: simplified Newton, stopped when every correction is below this relative size.
NEWTON_TOLERANCE = 1e-13
NEWTON_MAX_ITERATIONS = 50
# The implicit midpoint rule cuts a step on which Newton's iteration fails into up to 2^this equal pieces.
MIDPOINT_MAX_HALVINGS = 10
EPSILON = 2.220446049250313e-16  # machine epsilon of float64
FD_RELATIVE_STEP = 1.4901161193847656e-08  # sqrt(machine epsilon): balances truncation and rounding

RK4_WORK_ROWS = 7  # rk4_batch_step needs work of shape (RK4_WORK_ROWS, n)
