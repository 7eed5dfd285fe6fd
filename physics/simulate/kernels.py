"""Compiled integration kernels, appended to every generated system module.

The code generator writes one module per ``(formulation, n, pinned)`` that defines ``accel``, ``N_LINKS`` and
``PINNED`` (see docs/architecture.md) and then appends the whole text of this file. The functions below use those
three names as module globals, which numba resolves when it compiles them; this file never defines them, so its
functions cannot run on their own. Everything is ``@njit(cache=True)``, plain arrays and scalars, with numba's
``error_model="numpy"`` (a division by zero gives inf or NaN, which the status reports, never an exception).

The ODE is ``y = [theta, omega]`` (shape ``(2n,)``), ``y' = [omega, theta_ddot]`` with ``theta_ddot`` from ``accel``.

Integrators (docs/integrators.md describes each):

* ``integrate_rk45``, ``integrate_dop853``: scipy's ``solve_ivp`` RK45 and DOP853 reproduced step for step;
* ``integrate_midpoint``: fixed-step implicit midpoint rule in ``(theta, omega)`` (symmetric, order 2);
* ``integrate_variational``: fixed-step variational integrator in ``(theta, p)`` (symplectic, order 2; it needs the
  Lagrange module's ``mass_and_force``);
* ``rk4_batch_step``: one classical RK4 step for a batch of states (ensembles);
* ``project_position``, ``project_velocity``: projection of a pinned chain onto its loop constraint.

The integrators return ``(status, n_steps, n_rhs, t_reached, n_filled)``:

* ``status``: one of the ``STATUS_*`` codes below (0 ok, < 0 failed);
* ``n_steps``: accepted steps;
* ``n_rhs``: right-hand-side evaluations made by the integrator (for RK45 and DOP853 without projection this is
  exactly scipy's ``nfev``); the one extra ``accel`` call per sample that fills ``cond_out`` is not counted;
* ``t_reached``: time of the last accepted (and, when projecting, projected) state; ``t_end`` on success;
* ``n_filled``: samples written, always ``count(t_eval <= t_reached)``; rows ``n_filled:`` of ``y_out`` and
  entries of ``cond_out`` stay NaN.

A failing run never raises. Only programming errors do (``ValueError``): arrays of the wrong shape, ``t_end < t0``
(the kernels integrate forward only) or a midpoint step ``h`` that is not positive.
"""

import math

import numpy as np
from numba import njit

# accel, N_LINKS and PINNED are globals of the generated module this text is appended to.

STATUS_OK = 0
STATUS_SINGULAR = -1  # accel reported a pivot ratio above SINGULAR_PIVOT_RATIO (or inf)
STATUS_NOT_FINITE = -2  # a state, an acceleration or an error estimate turned NaN or infinite
STATUS_STEP_TOO_SMALL = -3  # the adaptive step fell below 10 ulp of t, as in scipy
STATUS_MAX_STEPS = -4  # more than max_steps accepted steps were needed
STATUS_NO_CONVERGENCE = -5  # implicit midpoint: the Newton iteration did not converge (reduce h)

# Beyond this the linear solve in accel has lost about 12 of its 16 digits: the answer is noise.
SINGULAR_CONDITION = 1e12
# The pivot ratio returned by accel grows like 1/delta at a distance delta from a loop singularity, while
# the 2-norm condition number grows like 1/delta^2: a ratio of 1e6 means a condition near 1e12, about 12 of
# 16 digits lost. Past it the accelerations are not worth integrating. (Same value as physics.simulate.run.)
SINGULAR_PIVOT_RATIO = 1e6

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
EPSILON = 2.220446049250313e-16  # machine epsilon of float64
FD_RELATIVE_STEP = 1.4901161193847656e-08  # sqrt(machine epsilon): balances truncation and rounding

RK4_WORK_ROWS = 7  # rk4_batch_step needs work of shape (RK4_WORK_ROWS, n)

# Dormand-Prince 5(4) tableau, error weights and dense-output matrix, as in scipy.integrate._ivp.rk.RK45.
_RK45_N_STAGES = 6
_RK45_ERROR_ORDER = 4
_RK45_C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1], dtype=np.float64)
_RK45_A = np.array(
    [
        [0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ],
    dtype=np.float64,
)
_RK45_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84], dtype=np.float64)
_RK45_E = np.array(
    [-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40], dtype=np.float64
)
_RK45_P = np.array(
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ],
    dtype=np.float64,
)

# DOP853 coefficients, copied from scipy.integrate._ivp.dop853_coefficients (same literals, same doubles).
_DOP853_N_STAGES = 12
_DOP853_N_STAGES_EXTENDED = 16
_DOP853_INTERPOLATOR_POWER = 7
_DOP853_ERROR_ORDER = 7
_DOP853_C = np.array(
    [
        0.0,
        0.526001519587677318785587544488e-01,
        0.789002279381515978178381316732e-01,
        0.118350341907227396726757197510,
        0.281649658092772603273242802490,
        0.333333333333333333333333333333,
        0.25,
        0.307692307692307692307692307692,
        0.651282051282051282051282051282,
        0.6,
        0.857142857142857142857142857142,
        1.0,
        1.0,
        0.1,
        0.2,
        0.777777777777777777777777777778,
    ]
)
_DOP853_A = np.zeros((_DOP853_N_STAGES_EXTENDED, _DOP853_N_STAGES_EXTENDED))
_DOP853_A[1, 0] = 5.26001519587677318785587544488e-2
_DOP853_A[2, 0] = 1.97250569845378994544595329183e-2
_DOP853_A[2, 1] = 5.91751709536136983633785987549e-2
_DOP853_A[3, 0] = 2.95875854768068491816892993775e-2
_DOP853_A[3, 2] = 8.87627564304205475450678981324e-2
_DOP853_A[4, 0] = 2.41365134159266685502369798665e-1
_DOP853_A[4, 2] = -8.84549479328286085344864962717e-1
_DOP853_A[4, 3] = 9.24834003261792003115737966543e-1
_DOP853_A[5, 0] = 3.7037037037037037037037037037e-2
_DOP853_A[5, 3] = 1.70828608729473871279604482173e-1
_DOP853_A[5, 4] = 1.25467687566822425016691814123e-1
_DOP853_A[6, 0] = 3.7109375e-2
_DOP853_A[6, 3] = 1.70252211019544039314978060272e-1
_DOP853_A[6, 4] = 6.02165389804559606850219397283e-2
_DOP853_A[6, 5] = -1.7578125e-2
_DOP853_A[7, 0] = 3.70920001185047927108779319836e-2
_DOP853_A[7, 3] = 1.70383925712239993810214054705e-1
_DOP853_A[7, 4] = 1.07262030446373284651809199168e-1
_DOP853_A[7, 5] = -1.53194377486244017527936158236e-2
_DOP853_A[7, 6] = 8.27378916381402288758473766002e-3
_DOP853_A[8, 0] = 6.24110958716075717114429577812e-1
_DOP853_A[8, 3] = -3.36089262944694129406857109825
_DOP853_A[8, 4] = -8.68219346841726006818189891453e-1
_DOP853_A[8, 5] = 2.75920996994467083049415600797e1
_DOP853_A[8, 6] = 2.01540675504778934086186788979e1
_DOP853_A[8, 7] = -4.34898841810699588477366255144e1
_DOP853_A[9, 0] = 4.77662536438264365890433908527e-1
_DOP853_A[9, 3] = -2.48811461997166764192642586468
_DOP853_A[9, 4] = -5.90290826836842996371446475743e-1
_DOP853_A[9, 5] = 2.12300514481811942347288949897e1
_DOP853_A[9, 6] = 1.52792336328824235832596922938e1
_DOP853_A[9, 7] = -3.32882109689848629194453265587e1
_DOP853_A[9, 8] = -2.03312017085086261358222928593e-2
_DOP853_A[10, 0] = -9.3714243008598732571704021658e-1
_DOP853_A[10, 3] = 5.18637242884406370830023853209
_DOP853_A[10, 4] = 1.09143734899672957818500254654
_DOP853_A[10, 5] = -8.14978701074692612513997267357
_DOP853_A[10, 6] = -1.85200656599969598641566180701e1
_DOP853_A[10, 7] = 2.27394870993505042818970056734e1
_DOP853_A[10, 8] = 2.49360555267965238987089396762
_DOP853_A[10, 9] = -3.0467644718982195003823669022
_DOP853_A[11, 0] = 2.27331014751653820792359768449
_DOP853_A[11, 3] = -1.05344954667372501984066689879e1
_DOP853_A[11, 4] = -2.00087205822486249909675718444
_DOP853_A[11, 5] = -1.79589318631187989172765950534e1
_DOP853_A[11, 6] = 2.79488845294199600508499808837e1
_DOP853_A[11, 7] = -2.85899827713502369474065508674
_DOP853_A[11, 8] = -8.87285693353062954433549289258
_DOP853_A[11, 9] = 1.23605671757943030647266201528e1
_DOP853_A[11, 10] = 6.43392746015763530355970484046e-1
_DOP853_A[12, 0] = 5.42937341165687622380535766363e-2
_DOP853_A[12, 5] = 4.45031289275240888144113950566
_DOP853_A[12, 6] = 1.89151789931450038304281599044
_DOP853_A[12, 7] = -5.8012039600105847814672114227
_DOP853_A[12, 8] = 3.1116436695781989440891606237e-1
_DOP853_A[12, 9] = -1.52160949662516078556178806805e-1
_DOP853_A[12, 10] = 2.01365400804030348374776537501e-1
_DOP853_A[12, 11] = 4.47106157277725905176885569043e-2
_DOP853_A[13, 0] = 5.61675022830479523392909219681e-2
_DOP853_A[13, 6] = 2.53500210216624811088794765333e-1
_DOP853_A[13, 7] = -2.46239037470802489917441475441e-1
_DOP853_A[13, 8] = -1.24191423263816360469010140626e-1
_DOP853_A[13, 9] = 1.5329179827876569731206322685e-1
_DOP853_A[13, 10] = 8.20105229563468988491666602057e-3
_DOP853_A[13, 11] = 7.56789766054569976138603589584e-3
_DOP853_A[13, 12] = -8.298e-3
_DOP853_A[14, 0] = 3.18346481635021405060768473261e-2
_DOP853_A[14, 5] = 2.83009096723667755288322961402e-2
_DOP853_A[14, 6] = 5.35419883074385676223797384372e-2
_DOP853_A[14, 7] = -5.49237485713909884646569340306e-2
_DOP853_A[14, 10] = -1.08347328697249322858509316994e-4
_DOP853_A[14, 11] = 3.82571090835658412954920192323e-4
_DOP853_A[14, 12] = -3.40465008687404560802977114492e-4
_DOP853_A[14, 13] = 1.41312443674632500278074618366e-1
_DOP853_A[15, 0] = -4.28896301583791923408573538692e-1
_DOP853_A[15, 5] = -4.69762141536116384314449447206
_DOP853_A[15, 6] = 7.68342119606259904184240953878
_DOP853_A[15, 7] = 4.06898981839711007970213554331
_DOP853_A[15, 8] = 3.56727187455281109270669543021e-1
_DOP853_A[15, 12] = -1.39902416515901462129418009734e-3
_DOP853_A[15, 13] = 2.9475147891527723389556272149
_DOP853_A[15, 14] = -9.15095847217987001081870187138
_DOP853_B = _DOP853_A[_DOP853_N_STAGES, :_DOP853_N_STAGES].copy()
_DOP853_E3 = np.zeros(_DOP853_N_STAGES + 1)
_DOP853_E3[:-1] = _DOP853_B.copy()
_DOP853_E3[0] -= 0.244094488188976377952755905512
_DOP853_E3[8] -= 0.733846688281611857341361741547
_DOP853_E3[11] -= 0.220588235294117647058823529412e-1
_DOP853_E5 = np.zeros(_DOP853_N_STAGES + 1)
_DOP853_E5[0] = 0.1312004499419488073250102996e-1
_DOP853_E5[5] = -0.1225156446376204440720569753e1
_DOP853_E5[6] = -0.4957589496572501915214079952
_DOP853_E5[7] = 0.1664377182454986536961530415e1
_DOP853_E5[8] = -0.3503288487499736816886487290
_DOP853_E5[9] = 0.3341791187130174790297318841
_DOP853_E5[10] = 0.8192320648511571246570742613e-1
_DOP853_E5[11] = -0.2235530786388629525884427845e-1
_DOP853_D = np.zeros((_DOP853_INTERPOLATOR_POWER - 3, _DOP853_N_STAGES_EXTENDED))
_DOP853_D[0, 0] = -0.84289382761090128651353491142e1
_DOP853_D[0, 5] = 0.56671495351937776962531783590
_DOP853_D[0, 6] = -0.30689499459498916912797304727e1
_DOP853_D[0, 7] = 0.23846676565120698287728149680e1
_DOP853_D[0, 8] = 0.21170345824450282767155149946e1
_DOP853_D[0, 9] = -0.87139158377797299206789907490
_DOP853_D[0, 10] = 0.22404374302607882758541771650e1
_DOP853_D[0, 11] = 0.63157877876946881815570249290
_DOP853_D[0, 12] = -0.88990336451333310820698117400e-1
_DOP853_D[0, 13] = 0.18148505520854727256656404962e2
_DOP853_D[0, 14] = -0.91946323924783554000451984436e1
_DOP853_D[0, 15] = -0.44360363875948939664310572000e1
_DOP853_D[1, 0] = 0.10427508642579134603413151009e2
_DOP853_D[1, 5] = 0.24228349177525818288430175319e3
_DOP853_D[1, 6] = 0.16520045171727028198505394887e3
_DOP853_D[1, 7] = -0.37454675472269020279518312152e3
_DOP853_D[1, 8] = -0.22113666853125306036270938578e2
_DOP853_D[1, 9] = 0.77334326684722638389603898808e1
_DOP853_D[1, 10] = -0.30674084731089398182061213626e2
_DOP853_D[1, 11] = -0.93321305264302278729567221706e1
_DOP853_D[1, 12] = 0.15697238121770843886131091075e2
_DOP853_D[1, 13] = -0.31139403219565177677282850411e2
_DOP853_D[1, 14] = -0.93529243588444783865713862664e1
_DOP853_D[1, 15] = 0.35816841486394083752465898540e2
_DOP853_D[2, 0] = 0.19985053242002433820987653617e2
_DOP853_D[2, 5] = -0.38703730874935176555105901742e3
_DOP853_D[2, 6] = -0.18917813819516756882830838328e3
_DOP853_D[2, 7] = 0.52780815920542364900561016686e3
_DOP853_D[2, 8] = -0.11573902539959630126141871134e2
_DOP853_D[2, 9] = 0.68812326946963000169666922661e1
_DOP853_D[2, 10] = -0.10006050966910838403183860980e1
_DOP853_D[2, 11] = 0.77771377980534432092869265740
_DOP853_D[2, 12] = -0.27782057523535084065932004339e1
_DOP853_D[2, 13] = -0.60196695231264120758267380846e2
_DOP853_D[2, 14] = 0.84320405506677161018159903784e2
_DOP853_D[2, 15] = 0.11992291136182789328035130030e2
_DOP853_D[3, 0] = -0.25693933462703749003312586129e2
_DOP853_D[3, 5] = -0.15418974869023643374053993627e3
_DOP853_D[3, 6] = -0.23152937917604549567536039109e3
_DOP853_D[3, 7] = 0.35763911791061412378285349910e3
_DOP853_D[3, 8] = 0.93405324183624310003907691704e2
_DOP853_D[3, 9] = -0.37458323136451633156875139351e2
_DOP853_D[3, 10] = 0.10409964950896230045147246184e3
_DOP853_D[3, 11] = 0.29840293426660503123344363579e2
_DOP853_D[3, 12] = -0.43533456590011143754432175058e2
_DOP853_D[3, 13] = 0.96324553959188282948394950600e2
_DOP853_D[3, 14] = -0.39177261675615439165231486172e2
_DOP853_D[3, 15] = -0.14972683625798562581422125276e3


# ----------------------------------------------------------------------------------------------------------------
# Right-hand side and small helpers
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _ode_rhs(y, params, alpha, beta, theta, omega, theta_ddot, dydt):
    """Fill ``dydt = [omega, theta_ddot]`` at state ``y``; return ``(status, condition)``.

    ``theta, omega, theta_ddot`` are scratch arrays of shape ``(n,)``: accel always sees contiguous 1-D arrays.
    """
    n = theta.shape[0]
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    condition = accel(theta, omega, params, alpha, beta, theta_ddot)  # noqa: F821 (generated-module global)
    finite = condition == condition
    for i in range(n):
        dydt[i] = omega[i]
        dydt[n + i] = theta_ddot[i]
        if not np.isfinite(theta_ddot[i]):
            finite = False
    if condition > SINGULAR_PIVOT_RATIO:
        return STATUS_SINGULAR, condition
    if not finite:
        return STATUS_NOT_FINITE, condition
    return STATUS_OK, condition


@njit(cache=True, error_model="numpy")
def _sample_condition(y, params, alpha, beta, theta, omega, theta_ddot):
    """Condition estimate of accel at state ``y`` (the value stored in ``cond_out``)."""
    n = theta.shape[0]
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    return accel(theta, omega, params, alpha, beta, theta_ddot)  # noqa: F821 (generated-module global)


@njit(cache=True, error_model="numpy")
def _all_finite(x):
    for i in range(x.shape[0]):
        if not np.isfinite(x[i]):
            return False
    return True


@njit(cache=True, error_model="numpy")
def _rms_norm(x):
    """Root-mean-square norm, scipy's ``common.norm``."""
    total = 0.0
    for i in range(x.shape[0]):
        total += x[i] * x[i]
    return math.sqrt(total) / math.sqrt(x.shape[0])


@njit(cache=True, error_model="numpy")
def _check_arguments(y0, t0, t_end, t_eval, params, y_out, cond_out):
    """Programming errors only (the caller validates user input): wrong shapes or a backward interval."""
    if not (t_end >= t0):
        raise ValueError("t_end must be >= t0 (the kernels integrate forward only)")
    if y0.shape[0] != 2 * N_LINKS:  # noqa: F821 (generated-module global)
        raise ValueError("y0 must have shape (2 * N_LINKS,)")
    if params.shape[0] < 4 * N_LINKS + 3:  # noqa: F821
        raise ValueError("params must have at least 4 * N_LINKS + 3 entries")
    if y_out.shape[0] != t_eval.shape[0] or y_out.shape[1] != y0.shape[0]:
        raise ValueError("y_out must have shape (len(t_eval), 2 * N_LINKS)")
    if cond_out.shape[0] != t_eval.shape[0] and cond_out.shape[0] != 0:
        raise ValueError("cond_out must have shape (len(t_eval),), or (0,) to skip the per-sample condition")


# ----------------------------------------------------------------------------------------------------------------
# Projection onto the loop constraint tip(theta) = pin
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _constraint_gram(theta, params):
    """Entries ``(a, b, c)`` of ``J J^T = [[a, b], [b, c]]`` with ``J[0, i] = L_i cos, J[1, i] = L_i sin``."""
    a = 0.0
    b = 0.0
    c = 0.0
    for i in range(theta.shape[0]):
        jx = params[i] * math.cos(theta[i])
        jy = params[i] * math.sin(theta[i])
        a += jx * jx
        b += jx * jy
        c += jy * jy
    return a, b, c


@njit(cache=True, error_model="numpy")
def project_position(theta, params):
    """Move ``theta`` (n,) in place onto ``tip(theta) = pin`` by the least change (Gauss-Newton).

    Each iteration applies ``dtheta = -J^T (J J^T)^-1 Phi``, ``Phi = tip - pin``; it stops when ``|Phi|`` is below
    PROJECTION_TOLERANCE or after PROJECTION_MAX_ITERATIONS. Near a singular configuration (all bars parallel,
    ``J J^T`` with condition above SINGULAR_CONDITION) the correction would be noise, so ``theta`` is left as it is.
    Returns the final ``|Phi|``.
    """
    n = theta.shape[0]
    pin_x = params[4 * n + 1]
    pin_y = params[4 * n + 2]
    residual = 0.0
    for iteration in range(PROJECTION_MAX_ITERATIONS + 1):
        phi_x = -pin_x
        phi_y = -pin_y
        for i in range(n):
            phi_x += params[i] * math.sin(theta[i])
            phi_y -= params[i] * math.cos(theta[i])
        residual = math.sqrt(phi_x * phi_x + phi_y * phi_y)
        if residual < PROJECTION_TOLERANCE or iteration == PROJECTION_MAX_ITERATIONS:
            break
        a, b, c = _constraint_gram(theta, params)
        det = a * c - b * b
        if not det > (a + c) * (a + c) / SINGULAR_CONDITION:
            break
        lambda_x = (c * phi_x - b * phi_y) / det
        lambda_y = (a * phi_y - b * phi_x) / det
        for i in range(n):
            theta[i] -= params[i] * (math.cos(theta[i]) * lambda_x + math.sin(theta[i]) * lambda_y)
    return residual


@njit(cache=True, error_model="numpy")
def project_velocity(theta, omega, params):
    """Remove from ``omega`` (n,) in place its component that moves the tip: ``omega -= J^T (J J^T)^-1 J omega``.

    Returns ``|J omega|`` before the projection (the tip's speed it removed). Left unchanged near a singular
    configuration, as in project_position.
    """
    n = theta.shape[0]
    v_x = 0.0
    v_y = 0.0
    for i in range(n):
        v_x += params[i] * math.cos(theta[i]) * omega[i]
        v_y += params[i] * math.sin(theta[i]) * omega[i]
    a, b, c = _constraint_gram(theta, params)
    det = a * c - b * b
    if det > (a + c) * (a + c) / SINGULAR_CONDITION:
        lambda_x = (c * v_x - b * v_y) / det
        lambda_y = (a * v_y - b * v_x) / det
        for i in range(n):
            omega[i] -= params[i] * (math.cos(theta[i]) * lambda_x + math.sin(theta[i]) * lambda_y)
    return math.sqrt(v_x * v_x + v_y * v_y)


@njit(cache=True, error_model="numpy")
def _project_state(y, params, theta, omega):
    """Project ``y = [theta, omega]`` in place (positions, then velocities); False if the result is not finite."""
    n = theta.shape[0]
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    project_position(theta, params)
    project_velocity(theta, omega, params)
    for i in range(n):
        y[i] = theta[i]
        y[n + i] = omega[i]
    return _all_finite(y)


# ----------------------------------------------------------------------------------------------------------------
# Explicit Runge-Kutta pairs (scipy's RK45 and DOP853)
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _rk_stages(t, y, h, A, n_stages, K, y_stage, params, alpha, beta, theta, omega, theta_ddot):
    """Stages 1 .. n_stages-1 into rows of ``K`` (row 0 holds f(y)); scipy's ``rk_step`` loop.

    Returns ``(status, rhs_evaluations)``.
    """
    n_state = y.shape[0]
    for s in range(1, n_stages):
        for j in range(n_state):
            dy = 0.0
            for r in range(s):
                dy += K[r, j] * A[s, r]
            y_stage[j] = y[j] + dy * h
        status, _ = _ode_rhs(y_stage, params, alpha, beta, theta, omega, theta_ddot, K[s])
        if status != STATUS_OK:
            return status, s
    return STATUS_OK, n_stages - 1


@njit(cache=True, error_model="numpy")
def _rk45_sample(x, h, y_old, K, y_sample):
    """scipy's RkDenseOutput: ``y_old + h * (K^T P) [x, x^2, x^3, x^4]``."""
    n_state = y_old.shape[0]
    p0 = x
    p1 = p0 * x
    p2 = p1 * x
    p3 = p2 * x
    for j in range(n_state):
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        q3 = 0.0
        for r in range(_RK45_N_STAGES + 1):
            q0 += K[r, j] * _RK45_P[r, 0]
            q1 += K[r, j] * _RK45_P[r, 1]
            q2 += K[r, j] * _RK45_P[r, 2]
            q3 += K[r, j] * _RK45_P[r, 3]
        y_sample[j] = h * (q0 * p0 + q1 * p1 + q2 * p2 + q3 * p3) + y_old[j]


@njit(cache=True, error_model="numpy")
def _dop853_dense_coefficients(t_old, h, y_old, y_new, K, F, y_stage, params, alpha, beta, theta, omega, theta_ddot):
    """scipy's DOP853 ``_dense_output_impl``: three extra stages into K[13:16], then the 7 rows of ``F``.

    ``K[12]`` must hold f(y_new) of the step. Returns ``(status, rhs_evaluations)``.
    """
    n_state = y_old.shape[0]
    evaluations = 0
    for s in range(_DOP853_N_STAGES + 1, _DOP853_N_STAGES_EXTENDED):
        for j in range(n_state):
            dy = 0.0
            for r in range(s):
                dy += K[r, j] * _DOP853_A[s, r]
            y_stage[j] = y_old[j] + dy * h
        status, _ = _ode_rhs(y_stage, params, alpha, beta, theta, omega, theta_ddot, K[s])
        evaluations += 1
        if status != STATUS_OK:
            return status, evaluations
    for j in range(n_state):
        delta_y = y_new[j] - y_old[j]
        f_old = K[0, j]
        f_new = K[_DOP853_N_STAGES, j]
        F[0, j] = delta_y
        F[1, j] = h * f_old - delta_y
        F[2, j] = 2 * delta_y - h * (f_new + f_old)
        for row in range(_DOP853_INTERPOLATOR_POWER - 3):
            total = 0.0
            for r in range(_DOP853_N_STAGES_EXTENDED):
                total += _DOP853_D[row, r] * K[r, j]
            F[3 + row, j] = h * total
    return STATUS_OK, evaluations


@njit(cache=True, error_model="numpy")
def _dop853_sample(x, y_old, F, y_sample):
    """scipy's Dop853DenseOutput: Horner-like product alternating factors ``x`` and ``1 - x``."""
    n_state = y_old.shape[0]
    for j in range(n_state):
        value = 0.0
        for i in range(_DOP853_INTERPOLATOR_POWER):
            value += F[_DOP853_INTERPOLATOR_POWER - 1 - i, j]
            if i % 2 == 0:
                value *= x
            else:
                value *= 1 - x
        y_sample[j] = value + y_old[j]


@njit(cache=True, error_model="numpy")
def _integrate_explicit_rk(
    A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
):
    """Shared driver of integrate_rk45 and integrate_dop853: scipy's ``solve_ivp`` loop with ``t_eval``.

    The method is told by its tableau ``A`` (an argument, not a constant flag, so that numba compiles this
    function once for both methods).
    """
    _check_arguments(y0, t0, t_end, t_eval, params, y_out, cond_out)
    use_dop853 = A.shape[0] == _DOP853_N_STAGES_EXTENDED
    projecting = PINNED and project  # noqa: F821 (generated-module global)
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    n_samples = t_eval.shape[0]
    if use_dop853:
        B = _DOP853_B
        n_stages = _DOP853_N_STAGES
        n_rows = _DOP853_N_STAGES_EXTENDED
        error_exponent = -1.0 / (_DOP853_ERROR_ORDER + 1)
        initial_step_exponent = 1.0 / (_DOP853_ERROR_ORDER + 1)
    else:
        B = _RK45_B
        n_stages = _RK45_N_STAGES
        n_rows = _RK45_N_STAGES + 1
        error_exponent = -1.0 / (_RK45_ERROR_ORDER + 1)
        initial_step_exponent = 1.0 / (_RK45_ERROR_ORDER + 1)

    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    K = np.empty((n_rows, n_state))
    F = np.empty((_DOP853_INTERPOLATOR_POWER, n_state))
    y = y0.copy()
    y_new = np.empty(n_state)
    y_next = np.empty(n_state)
    y_stage = np.empty(n_state)
    f = np.empty(n_state)
    f_next = np.empty(n_state)
    scale = np.empty(n_state)
    work = np.empty(n_state)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if projecting and not _project_state(y, params, theta, omega):
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    status, condition = _ode_rhs(y, params, alpha, beta, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    # Samples at t0 are y0 itself: scipy's dense output of the first step returns y_old exactly there.
    i_sample = _initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    interval_length = abs(t_end - t0)
    if interval_length == 0.0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample

    # scipy's select_initial_step (Hairer, Norsett & Wanner, Sec. II.4), direction +1, max_step inf.
    for j in range(n_state):
        scale[j] = atol + abs(y[j]) * rtol
    for j in range(n_state):
        work[j] = y[j] / scale[j]
    d0 = _rms_norm(work)
    for j in range(n_state):
        work[j] = f[j] / scale[j]
    d1 = _rms_norm(work)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval_length)
    for j in range(n_state):
        y_stage[j] = y[j] + h0 * f[j]
    status, _ = _ode_rhs(y_stage, params, alpha, beta, theta, omega, theta_ddot, f_next)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, i_sample
    for j in range(n_state):
        work[j] = (f_next[j] - f[j]) / scale[j]
    d2 = _rms_norm(work) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** initial_step_exponent
    h_abs = min(100 * h0, h1, interval_length)

    while t < t_end:
        if n_steps >= max_steps:
            status = STATUS_MAX_STEPS
            break
        # scipy's RungeKutta._step_impl
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        step_rejected = False
        t_new = t
        h = 0.0
        while True:
            if h_abs < min_step:
                status = STATUS_STEP_TOO_SMALL
                break
            t_new = t + h_abs
            if t_new - t_end > 0:
                t_new = t_end
            h = t_new - t
            h_abs = abs(h)
            for j in range(n_state):
                K[0, j] = f[j]
            status, evaluations = _rk_stages(
                t, y, h, A, n_stages, K, y_stage, params, alpha, beta, theta, omega, theta_ddot
            )
            n_rhs += evaluations
            if status != STATUS_OK:
                break
            for j in range(n_state):
                total = 0.0
                for r in range(n_stages):
                    total += K[r, j] * B[r]
                y_new[j] = y[j] + h * total
            status, _ = _ode_rhs(y_new, params, alpha, beta, theta, omega, theta_ddot, K[n_stages])
            n_rhs += 1
            if status != STATUS_OK:
                break
            for j in range(n_state):
                scale[j] = atol + max(abs(y[j]), abs(y_new[j])) * rtol
            if use_dop853:
                err5_norm_2 = 0.0
                err3_norm_2 = 0.0
                for j in range(n_state):
                    err5 = 0.0
                    err3 = 0.0
                    for r in range(n_stages + 1):
                        err5 += K[r, j] * _DOP853_E5[r]
                        err3 += K[r, j] * _DOP853_E3[r]
                    err5 /= scale[j]
                    err3 /= scale[j]
                    err5_norm_2 += err5 * err5
                    err3_norm_2 += err3 * err3
                if err5_norm_2 == 0 and err3_norm_2 == 0:
                    error_norm = 0.0
                else:
                    denominator = err5_norm_2 + 0.01 * err3_norm_2
                    error_norm = abs(h) * err5_norm_2 / math.sqrt(denominator * n_state)
            else:
                for j in range(n_state):
                    total = 0.0
                    for r in range(n_stages + 1):
                        total += K[r, j] * _RK45_E[r]
                    work[j] = total * h / scale[j]
                error_norm = _rms_norm(work)
            if not np.isfinite(error_norm):
                status = STATUS_NOT_FINITE
                break
            if error_norm < 1:
                if error_norm == 0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * error_norm**error_exponent)
                if step_rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            h_abs *= max(MIN_FACTOR, SAFETY * error_norm**error_exponent)
            step_rejected = True
        if status != STATUS_OK:
            break

        # The next state: y_new itself (FSAL), or its projection with a fresh derivative.
        for j in range(n_state):
            y_next[j] = y_new[j]
            f_next[j] = K[n_stages, j]
        if projecting:
            if not _project_state(y_next, params, theta, omega):
                status = STATUS_NOT_FINITE
                break
            status, _ = _ode_rhs(y_next, params, alpha, beta, theta, omega, theta_ddot, f_next)
            n_rhs += 1
            if status != STATUS_OK:
                break

        # Samples in (t, t_new] from the step's dense output, as solve_ivp does with t_eval.
        if i_sample < n_samples and t_eval[i_sample] <= t_new:
            if use_dop853:
                status, evaluations = _dop853_dense_coefficients(
                    t, h, y, y_new, K, F, y_stage, params, alpha, beta, theta, omega, theta_ddot
                )
                n_rhs += evaluations
                if status != STATUS_OK:
                    break
            while i_sample < n_samples and t_eval[i_sample] <= t_new:
                x = (t_eval[i_sample] - t) / h
                if use_dop853:
                    _dop853_sample(x, y, F, y_stage)
                else:
                    _rk45_sample(x, h, y, K, y_stage)
                if projecting:
                    _project_state(y_stage, params, theta, omega)
                y_out[i_sample, :] = y_stage
                if cond_out.shape[0]:  # (0,) = the caller computes it with the reactions, once
                    cond_out[i_sample] = _sample_condition(y_stage, params, alpha, beta, theta, omega, theta_ddot)
                i_sample += 1

        for j in range(n_state):
            y[j] = y_next[j]
            f[j] = f_next[j]
        t = t_new
        n_steps += 1

    # Samples are written only with the state they follow, so n_filled == count(t_eval <= t_reached).
    return status, n_steps, n_rhs, t, i_sample


@njit(cache=True, error_model="numpy")
def integrate_rk45(y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out):
    """Dormand-Prince 5(4) exactly as scipy's ``solve_ivp(method="RK45")``, samples at ``t_eval``.

    y0 (2n,) initial ``[theta, omega]``; t_eval (T,) sorted within [t0, t_end]; y_out (T, 2n) and cond_out (T,) are
    filled with the sampled states and accel's condition estimate there. alpha, beta are passed to accel (Baumgarte
    gains); project (pinned chains only) projects every accepted step and every sample onto the loop constraint.
    Returns ``(status, n_steps, n_rhs, t_reached, n_filled)`` (see the module docstring).
    """
    return _integrate_explicit_rk(
        _RK45_A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
    )


@njit(cache=True, error_model="numpy")
def integrate_dop853(y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out):
    """Dormand-Prince 8(5,3) exactly as scipy's ``solve_ivp(method="DOP853")``; arguments as integrate_rk45."""
    return _integrate_explicit_rk(
        _DOP853_A, y0, t0, t_end, t_eval, params, rtol, atol, alpha, beta, project, max_steps, y_out, cond_out
    )


# ----------------------------------------------------------------------------------------------------------------
# Implicit midpoint rule
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _lu_factor(M, pivots):
    """In-place LU factorisation with partial pivoting; False if a pivot is exactly zero."""
    size = M.shape[0]
    for k in range(size):
        best = k
        for i in range(k + 1, size):
            if abs(M[i, k]) > abs(M[best, k]):
                best = i
        pivots[k] = best
        if M[best, k] == 0.0:
            return False
        if best != k:
            for j in range(size):
                swap = M[k, j]
                M[k, j] = M[best, j]
                M[best, j] = swap
        for i in range(k + 1, size):
            M[i, k] /= M[k, k]
            factor = M[i, k]
            if factor != 0.0:
                for j in range(k + 1, size):
                    M[i, j] -= factor * M[k, j]
    return True


@njit(cache=True, error_model="numpy")
def _lu_solve(M, pivots, rhs):
    """Solve with the factors of _lu_factor, overwriting ``rhs`` with the solution."""
    size = M.shape[0]
    for k in range(size):
        p = pivots[k]
        if p != k:
            swap = rhs[k]
            rhs[k] = rhs[p]
            rhs[p] = swap
    for i in range(size):
        total = rhs[i]
        for j in range(i):
            total -= M[i, j] * rhs[j]
        rhs[i] = total
    for i in range(size - 1, -1, -1):
        total = rhs[i]
        for j in range(i + 1, size):
            total -= M[i, j] * rhs[j]
        rhs[i] = total / M[i, i]


@njit(cache=True, error_model="numpy")
def _hermite_sample(s, h, y_old, f_old, y_new, f_new, y_sample):
    """Cubic Hermite interpolant at fraction ``s`` of a step of length ``h``."""
    s2 = s * s
    s3 = s2 * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    for j in range(y_old.shape[0]):
        y_sample[j] = h00 * y_old[j] + h10 * h * f_old[j] + h01 * y_new[j] + h11 * h * f_new[j]


@njit(cache=True, error_model="numpy")
def _initial_samples(y, t0, t_eval, condition, y_out, cond_out):
    """Write the start state into every sample at or before ``t0``; returns the next sample's index."""
    i_sample = 0
    while i_sample < t_eval.shape[0] and t_eval[i_sample] <= t0:
        y_out[i_sample, :] = y
        if cond_out.shape[0]:
            cond_out[i_sample] = condition
        i_sample += 1
    return i_sample


@njit(cache=True, error_model="numpy")
def _fixed_steps(t0, t_end, h):
    """``N = ceil((t_end - t0) / h)`` equal steps (so the step is at most ``h``): ``(N, step)``."""
    n_total = max(1, int(math.ceil((t_end - t0) / h * (1.0 - 1e-12))))
    return n_total, (t_end - t0) / n_total


@njit(cache=True, error_model="numpy")
def _hermite_samples(i_sample, t, t_new, y, f, y_next, f_next, t_eval, params, alpha, beta, project,
                     y_sample, theta, omega, theta_ddot, y_out, cond_out):
    """Fill the samples in ``(t, t_new]`` from the cubic Hermite interpolant of a fixed step (projected onto the
    loop when ``project``); returns the next sample's index."""
    while i_sample < t_eval.shape[0] and t_eval[i_sample] <= t_new:
        s = (t_eval[i_sample] - t) / (t_new - t)
        _hermite_sample(s, t_new - t, y, f, y_next, f_next, y_sample)
        if project:
            _project_state(y_sample, params, theta, omega)
        y_out[i_sample, :] = y_sample
        if cond_out.shape[0]:
            cond_out[i_sample] = _sample_condition(y_sample, params, alpha, beta, theta, omega, theta_ddot)
        i_sample += 1
    return i_sample


@njit(cache=True, error_model="numpy")
def integrate_midpoint(y0, t0, t_end, h, t_eval, params, alpha, beta, project, y_out, cond_out):
    """Fixed-step implicit midpoint rule ``y1 = y0 + h f((y0 + y1) / 2)``: symmetric, order 2.

    Applied to ``y = (theta, omega)`` it is symplectic only where ``omega`` is a constant multiple of the
    momentum (a single bar); for a chain use integrate_variational, which steps ``(theta, p)``.

    The interval is cut into ``N = ceil((t_end - t0) / h)`` equal steps (so the step is at most ``h``). Each step
    is solved by simplified Newton with a forward-difference Jacobian of the right-hand side refreshed at the start
    of the step, until every correction is below NEWTON_TOLERANCE relative. Samples come from the cubic Hermite
    interpolant between steps. Arguments and return value as integrate_rk45 (STATUS_NO_CONVERGENCE if Newton
    fails; n_rhs includes the Jacobian's evaluations).
    """
    _check_arguments(y0, t0, t_end, t_eval, params, y_out, cond_out)
    if not (h > 0.0 and h < np.inf):
        raise ValueError("h must be positive and finite")
    projecting = PINNED and project  # noqa: F821 (generated-module global)
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    y = y0.copy()
    f = np.empty(n_state)
    y_next = np.empty(n_state)
    f_next = np.empty(n_state)
    y_mid = np.empty(n_state)
    f_mid = np.empty(n_state)
    y_probe = np.empty(n_state)
    f_probe = np.empty(n_state)
    correction = np.empty(n_state)
    newton_matrix = np.empty((n_state, n_state))
    pivots = np.empty(n_state, dtype=np.int64)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if projecting and not _project_state(y, params, theta, omega):
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    status, condition = _ode_rhs(y, params, alpha, beta, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    i_sample = _initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    if t_end == t0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample
    n_total, step = _fixed_steps(t0, t_end, h)

    for k in range(n_total):
        t_new = t_end if k == n_total - 1 else t0 + (k + 1) * step
        # Newton matrix I - (step/2) df/dy; df/dy = [[0, I], [d theta_ddot / d theta, d theta_ddot / d omega]].
        for i in range(n_state):
            for j in range(n_state):
                newton_matrix[i, j] = 0.0
            newton_matrix[i, i] = 1.0
        for i in range(n):
            newton_matrix[i, n + i] = -0.5 * step
        for j in range(n_state):
            for i in range(n_state):
                y_probe[i] = y[i]
            y_probe[j] = y[j] + FD_RELATIVE_STEP * max(1.0, abs(y[j]))
            delta = y_probe[j] - y[j]
            status, _ = _ode_rhs(y_probe, params, alpha, beta, theta, omega, theta_ddot, f_probe)
            n_rhs += 1
            if status != STATUS_OK:
                break
            for i in range(n):
                newton_matrix[n + i, j] -= 0.5 * step * (f_probe[n + i] - f[n + i]) / delta
        if status != STATUS_OK:
            break
        if not _lu_factor(newton_matrix, pivots):
            status = STATUS_NO_CONVERGENCE
            break
        # Explicit Euler predictor, then y1 <- y1 - M^-1 (y1 - y0 - step f((y0 + y1)/2)).
        for i in range(n_state):
            y_next[i] = y[i] + step * f[i]
        converged = False
        for iteration in range(NEWTON_MAX_ITERATIONS):
            for i in range(n_state):
                y_mid[i] = 0.5 * (y[i] + y_next[i])
            status, _ = _ode_rhs(y_mid, params, alpha, beta, theta, omega, theta_ddot, f_mid)
            n_rhs += 1
            if status != STATUS_OK:
                break
            for i in range(n_state):
                correction[i] = -(y_next[i] - y[i] - step * f_mid[i])
            _lu_solve(newton_matrix, pivots, correction)
            largest = 0.0
            for i in range(n_state):
                y_next[i] += correction[i]
                relative = abs(correction[i]) / (1.0 + abs(y_next[i]))
                if not relative <= largest:
                    largest = relative
            if not np.isfinite(largest):
                status = STATUS_NOT_FINITE
                break
            if largest <= NEWTON_TOLERANCE:
                converged = True
                break
        if status != STATUS_OK:
            break
        if not converged:
            status = STATUS_NO_CONVERGENCE
            break
        if projecting and not _project_state(y_next, params, theta, omega):
            status = STATUS_NOT_FINITE
            break
        status, _ = _ode_rhs(y_next, params, alpha, beta, theta, omega, theta_ddot, f_next)
        n_rhs += 1
        if status != STATUS_OK:
            break
        n_steps += 1

        i_sample = _hermite_samples(i_sample, t, t_new, y, f, y_next, f_next, t_eval, params, alpha, beta,
                                    projecting, y_probe, theta, omega, theta_ddot, y_out, cond_out)
        for i in range(n_state):
            y[i] = y_next[i]
            f[i] = f_next[i]
        t = t_new

    return status, n_steps, n_rhs, t, i_sample


# ----------------------------------------------------------------------------------------------------------------
# Variational integrator (midpoint discrete Lagrangian; RATTLE for a pinned tip)
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _del_residual(theta0, momentum0, unknowns, step, params, theta_mid, velocity, M, force, residual):
    """Residual of the discrete Euler-Lagrange equation for the step's increment ``q1 - q0 = unknowns[:n]``.

    With ``L_d(q0, q1) = h L((q0 + q1) / 2, (q1 - q0) / h)`` and damping as a midpoint force, the step from
    ``(q0, p0)`` solves ``p0 = -D1 L_d(q0, q1) - (h/2) Q = M v - (h/2) f`` (``f = dL/dq + Q`` at the midpoint).
    A pinned chain adds the loop force ``G(q0)^T lambda`` and the rows ``tip(q1) = pin``: the position half of
    RATTLE. The momentum rows are multiplied by ``h`` (and the unknown multiplier is ``h lambda =
    unknowns[n:]``) so that every row and column of the Newton matrix is of order one (``M``, ``G``): unscaled,
    its condition grows like ``1/h`` and rounding keeps Newton from reaching its tolerance. The unknown is the
    increment, not ``q1``, so that ``v = (q1 - q0) / h`` carries the increment's relative precision instead of
    ``|q| * eps / h`` (which at h = 3e-5 s costs more than the method's own error).
    """
    n = theta0.shape[0]
    for i in range(n):
        theta_mid[i] = theta0[i] + 0.5 * unknowns[i]
        velocity[i] = unknowns[i] / step
    mass_and_force(theta_mid, velocity, params, M, force)  # noqa: F821 (generated-module global)
    for i in range(n):
        total = -step * momentum0[i] - 0.5 * step * step * force[i]
        for j in range(n):
            total += M[i, j] * unknowns[j]
        residual[i] = total
    if PINNED:  # noqa: F821 (generated-module global)
        tip_x = -params[4 * n + 1]
        tip_y = -params[4 * n + 2]
        for i in range(n):
            c = math.cos(theta0[i])
            s = math.sin(theta0[i])
            residual[i] -= params[i] * (c * unknowns[n] + s * unknowns[n + 1])
            tip_x += params[i] * math.sin(theta0[i] + unknowns[i])
            tip_y -= params[i] * math.cos(theta0[i] + unknowns[i])
        residual[n] = tip_x
        residual[n + 1] = tip_y


@njit(cache=True, error_model="numpy")
def _velocity_from_momentum(theta, momentum, params, M, force, pivots, loop_work, omega):
    """``omega = M(theta)^-1 p``; for a pinned chain then the velocity half of RATTLE, which removes the part of
    ``p`` along ``G^T`` so that the tip stays still (``G omega = 0``). ``momentum`` is updated to match;
    ``loop_work`` (2, n) is scratch. Returns False when the mass matrix is singular."""
    n = theta.shape[0]
    for i in range(n):
        omega[i] = 0.0
    mass_and_force(theta, omega, params, M, force)  # noqa: F821 (generated-module global)
    if not _lu_factor(M, pivots):
        return False
    for i in range(n):
        omega[i] = momentum[i]
    _lu_solve(M, pivots, omega)
    if PINNED:  # noqa: F821 (generated-module global)
        # W = M^-1 G^T (two columns), S = G W (2 x 2); mu = S^-1 G omega; omega -= W mu; p -= G^T mu.
        w_x = loop_work[0]
        w_y = loop_work[1]
        for i in range(n):
            w_x[i] = params[i] * math.cos(theta[i])
            w_y[i] = params[i] * math.sin(theta[i])
        _lu_solve(M, pivots, w_x)
        _lu_solve(M, pivots, w_y)
        s_xx = 0.0
        s_xy = 0.0
        s_yx = 0.0
        s_yy = 0.0
        g_x = 0.0
        g_y = 0.0
        for i in range(n):
            c = params[i] * math.cos(theta[i])
            s = params[i] * math.sin(theta[i])
            s_xx += c * w_x[i]
            s_xy += c * w_y[i]
            s_yx += s * w_x[i]
            s_yy += s * w_y[i]
            g_x += c * omega[i]
            g_y += s * omega[i]
        det = s_xx * s_yy - s_xy * s_yx
        if not abs(det) > 0.0:
            return False
        mu_x = (s_yy * g_x - s_xy * g_y) / det
        mu_y = (s_xx * g_y - s_yx * g_x) / det
        for i in range(n):
            omega[i] -= w_x[i] * mu_x + w_y[i] * mu_y
            momentum[i] -= params[i] * (math.cos(theta[i]) * mu_x + math.sin(theta[i]) * mu_y)
    return _all_finite(omega)


@njit(cache=True, error_model="numpy")
def integrate_variational(y0, t0, t_end, h, t_eval, params, y_out, cond_out):
    """Fixed-step variational integrator: symplectic and momentum-consistent, order 2 (docs/integrators.md).

    It discretises the Lagrangian itself (``mass_and_force``, generated from T - V by the Lagrange derivation
    only), so it needs a module that has one (``HAS_LAGRANGIAN``). It advances ``(theta, p)`` with
    ``p = M(theta) omega`` by the midpoint discrete Lagrangian; a pinned chain keeps its tip on the pin exactly
    (to the Newton tolerance) through a discrete multiplier and a velocity projection (RATTLE), so no
    stabilisation gains apply. Because the map is symplectic the energy error stays bounded over long runs
    instead of drifting, even on chaotic motion. Each step is solved by simplified Newton on the unknown angles
    (and multiplier), with a forward-difference Jacobian refreshed per step. Samples come from the cubic Hermite
    interpolant of ``(theta, omega)`` between steps, with ``theta_ddot`` from ``accel``; for a pinned chain they
    are projected onto the loop. Arguments and return value as integrate_midpoint without the stabilisation
    gains; ``n_rhs`` counts evaluations of ``mass_and_force`` and ``accel``.
    """
    _check_arguments(y0, t0, t_end, t_eval, params, y_out, cond_out)
    if not (h > 0.0 and h < np.inf):
        raise ValueError("h must be positive and finite")
    if not HAS_LAGRANGIAN:  # noqa: F821 (generated-module global)
        raise ValueError("the variational integrator needs the Lagrange formulation's module")
    n = y0.shape[0] // 2
    n_state = y0.shape[0]
    size = n + (2 if PINNED else 0)  # noqa: F821
    theta = np.empty(n)
    omega = np.empty(n)
    theta_ddot = np.empty(n)
    theta_mid = np.empty(n)
    velocity = np.empty(n)
    force = np.empty(n)
    M = np.empty((n, n))
    mass_pivots = np.empty(n, dtype=np.int64)
    loop_work = np.empty((2, n))
    momentum = np.empty(n)
    momentum_next = np.empty(n)
    unknowns = np.zeros(size)
    probe = np.empty(size)
    residual = np.empty(size)
    residual_probe = np.empty(size)
    newton_matrix = np.empty((size, size))
    pivots = np.empty(size, dtype=np.int64)
    y = y0.copy()
    f = np.empty(n_state)
    y_next = np.empty(n_state)
    f_next = np.empty(n_state)
    y_sample = np.empty(n_state)
    y_out[:, :] = np.nan
    cond_out[:] = np.nan

    t = t0
    n_steps = 0
    n_rhs = 0
    if PINNED and not _project_state(y, params, theta, omega):  # noqa: F821
        return STATUS_NOT_FINITE, n_steps, n_rhs, t, 0
    for i in range(n):
        theta[i] = y[i]
        omega[i] = y[n + i]
    mass_and_force(theta, omega, params, M, force)  # noqa: F821
    n_rhs += 1
    for i in range(n):
        total = 0.0
        for j in range(n):
            total += M[i, j] * omega[j]
        momentum[i] = total
    status, condition = _ode_rhs(y, params, 0.0, 0.0, theta, omega, theta_ddot, f)
    n_rhs += 1
    if status != STATUS_OK:
        return status, n_steps, n_rhs, t, 0
    i_sample = _initial_samples(y, t0, t_eval, condition, y_out, cond_out)
    if t_end == t0:
        return STATUS_OK, n_steps, n_rhs, t, i_sample
    n_total, step = _fixed_steps(t0, t_end, h)

    for k in range(n_total):
        t_new = t_end if k == n_total - 1 else t0 + (k + 1) * step
        # Predictor: a Taylor step for the angles; the multiplier keeps its last value (it varies slowly).
        for i in range(n):
            unknowns[i] = step * f[i] + 0.5 * step * step * f[n + i]
        _del_residual(y[:n], momentum, unknowns, step, params, theta_mid, velocity, M, force, residual)
        n_rhs += 1
        for j in range(size):
            for i in range(size):
                probe[i] = unknowns[i]
            delta = FD_RELATIVE_STEP * max(1.0, abs(y[j]) if j < n else 0.0)
            probe[j] = unknowns[j] + delta
            delta = probe[j] - unknowns[j]
            _del_residual(y[:n], momentum, probe, step, params, theta_mid, velocity, M, force, residual_probe)
            n_rhs += 1
            for i in range(size):
                newton_matrix[i, j] = (residual_probe[i] - residual[i]) / delta
        if not _lu_factor(newton_matrix, pivots):
            status = STATUS_NO_CONVERGENCE
            break
        # Stop when the correction is below NEWTON_TOLERANCE of the unknowns' size (norm-wise) plus the rounding
        # of the angles themselves (q1 = q0 + increment is stored to eps |q0|; the loop rows' residual is only
        # known to eps L), or when it has stopped shrinking within a thousand times that.
        floor = 0.0
        for i in range(n):
            floor = max(floor, abs(y[i]))
        floor = 4.0 * EPSILON * max(floor, 1.0)
        converged = False
        previous = np.inf
        for iteration in range(NEWTON_MAX_ITERATIONS):
            for i in range(size):
                probe[i] = -residual[i]
            _lu_solve(newton_matrix, pivots, probe)
            largest = 0.0
            scale = 0.0
            for i in range(size):
                unknowns[i] += probe[i]
                largest = max(largest, abs(probe[i]))
                scale = max(scale, abs(unknowns[i]))
            _del_residual(y[:n], momentum, unknowns, step, params, theta_mid, velocity, M, force, residual)
            n_rhs += 1
            if not (np.isfinite(largest) and np.isfinite(scale)):
                status = STATUS_NOT_FINITE
                break
            if largest <= NEWTON_TOLERANCE * scale + floor or (
                    largest >= 0.5 * previous and largest <= 1e3 * (NEWTON_TOLERANCE * scale + floor)):
                converged = True
                break
            previous = largest
        if status != STATUS_OK:
            break
        if not converged:
            status = STATUS_NO_CONVERGENCE
            break
        # p1 = D2 L_d(q0, q1) + (h/2) Q = M v + (h/2) f at the converged midpoint (the last residual's M, force).
        for i in range(n):
            total = 0.5 * step * force[i]
            for j in range(n):
                total += M[i, j] * velocity[j]
            momentum_next[i] = total
            theta[i] = y[i] + unknowns[i]
        if not _velocity_from_momentum(theta, momentum_next, params, M, force, mass_pivots, loop_work, omega):
            status = STATUS_NOT_FINITE
            break
        n_rhs += 1
        for i in range(n):
            y_next[i] = theta[i]
            y_next[n + i] = omega[i]
        status, _ = _ode_rhs(y_next, params, 0.0, 0.0, theta, omega, theta_ddot, f_next)
        n_rhs += 1
        if status != STATUS_OK:
            break
        n_steps += 1

        i_sample = _hermite_samples(i_sample, t, t_new, y, f, y_next, f_next, t_eval, params, 0.0, 0.0,
                                    PINNED, y_sample, theta, omega, theta_ddot, y_out, cond_out)  # noqa: F821
        for i in range(n_state):
            y[i] = y_next[i]
            f[i] = f_next[i]
        for i in range(n):
            momentum[i] = momentum_next[i]
        t = t_new

    return status, n_steps, n_rhs, t, i_sample


# ----------------------------------------------------------------------------------------------------------------
# Ensembles
# ----------------------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def rk4_batch_step(theta, omega, params, h, alpha, beta, work, cond_out):
    """Advance K states by one classical RK4 step of size ``h``, in place.

    theta, omega (K, n): the states; work (RK4_WORK_ROWS, n): scratch; cond_out (K,) receives, per state, the
    largest condition estimate accel returned over the four stages (NaN if any was NaN). One state after another
    in a plain loop: the caller decides about threads. Returns the largest entry of cond_out (NaN wins).
    """
    n_batch = theta.shape[0]
    n = theta.shape[1]
    theta_stage = work[0]
    omega_stage = work[1]
    theta_ddot = work[2]
    k_theta = work[3]
    k_omega = work[4]
    sum_theta = work[5]
    sum_omega = work[6]
    worst_overall = 0.0
    for b in range(n_batch):
        worst = 0.0
        for stage in range(4):
            if stage == 0:
                for i in range(n):
                    theta_stage[i] = theta[b, i]
                    omega_stage[i] = omega[b, i]
            else:
                fraction = h if stage == 3 else 0.5 * h
                for i in range(n):
                    theta_stage[i] = theta[b, i] + fraction * k_theta[i]
                    omega_stage[i] = omega[b, i] + fraction * k_omega[i]
            condition = accel(theta_stage, omega_stage, params, alpha, beta, theta_ddot)  # noqa: F821
            if condition > worst or condition != condition:
                if worst == worst:
                    worst = condition
            weight = 1.0 if stage == 0 or stage == 3 else 2.0
            for i in range(n):
                k_theta[i] = omega_stage[i]
                k_omega[i] = theta_ddot[i]
                if stage == 0:
                    sum_theta[i] = k_theta[i]
                    sum_omega[i] = k_omega[i]
                else:
                    sum_theta[i] += weight * k_theta[i]
                    sum_omega[i] += weight * k_omega[i]
        for i in range(n):
            theta[b, i] += h / 6.0 * sum_theta[i]
            omega[b, i] += h / 6.0 * sum_omega[i]
        cond_out[b] = worst
        if worst > worst_overall or worst != worst:
            if worst_overall == worst_overall:
                worst_overall = worst
    return worst_overall
