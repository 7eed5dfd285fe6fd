"""Integration kernels compiled once per installation, for every mechanism (numba loads with the first kernel
module a run imports: each imports :mod:`.disk_cache` first; the package itself imports nothing).

Each kernel takes the address of the mechanism's generated ``assemble`` (and, for the variational integrator,
its ``mass_and_force``) as an integer, plus the mechanism's ``layout`` array (:mod:`physics.kernels.abi`), so
numba compiles RK45, DOP853, the implicit midpoint rule, the variational
integrator, projection and the batch RK4 step once and caches them; a new mechanism compiles only its own
straight-line code. Everything is plain arrays and scalars with numba's ``error_model="numpy"`` (a division by
zero gives inf or NaN, which the status reports, never an exception).

Modules: ``abi`` (the contract with generated code), ``linear`` (dense solves with a singularity estimate),
``system`` (``A x = b`` through ``assemble``; batched entry points), ``projection``, ``explicit_rk``
(RK45, DOP853), ``midpoint``, ``variational``, ``batch`` (RK4 for ensembles), ``reduced`` (one evaluation of
a mechanism's reduced model in one joint coordinate, on its generated DAE code), ``constants`` (status codes
and shared constants), ``tables`` (Butcher tableaux). docs/integrators.md describes each integrator.

The integrators return ``(status, n_steps, n_rhs, t_reached, n_filled)``:

* ``status``: one of the ``STATUS_*`` codes of :mod:`physics.kernels.constants` (0 ok, < 0 failed);
* ``n_steps``: accepted steps;
* ``n_rhs``: right-hand-side evaluations (for RK45 and DOP853 without projection exactly scipy's ``nfev``);
  the one extra evaluation per sample that fills ``cond_out`` is not counted;
* ``t_reached``: time of the last accepted (and, when projecting, projected) state; ``t_end`` on success;
* ``n_filled``: samples written, always ``count(t_eval <= t_reached)``; rows ``n_filled:`` of ``y_out`` and
  entries of ``cond_out`` stay NaN.

A failing run never raises. Only programming errors do (``ValueError``): arrays of the wrong shape,
``t_end < t0`` (the kernels integrate forward only) or a fixed step ``h`` that is not positive.
"""

