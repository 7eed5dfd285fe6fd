"""The one check of a mechanism's run options: every option turned into the project's one run-settings model,
:class:`physics.model.Settings`, or refused in one line naming the field and its allowed range.

Its own module so that both :func:`physics.mechanism.simulate.simulate_mechanism` and the reduced model's own
entry (:func:`physics.mechanism.reduced.simulate_reduced`, which ``simulate_mechanism`` runs) check with it.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import ValidationError

from ..errors import LinkageError
from ..model import (
    MECHANISM_MAX_SAMPLES,
    MECHANISM_MAX_T_END,
    MECHANISM_MAX_TOLERANCE,
    MIN_ATOL,
    MIN_RTOL,
    Settings,
)
from ..registry import (
    BACKENDS,
    DEFAULT_BACKEND,
    INTEGRATOR_NAMES,
    MECHANISM_METHODS,
    METHODS,
    REDUCED_INTEGRATOR,
    STABILIZATIONS,
    integrators_for,
)

__all__ = ["ALLOWED", "run_options"]


def _ten(power_of_ten: float) -> str:
    """``1e4``, ``1e-2``: a limit as the refusals have always written it."""
    return f"1e{round(math.log10(power_of_ten))}"


# What each option of a mechanism's run allows, in the one line that refuses it. The names come from the
# registry; the spans of t_end, samples and the tolerances are a mechanism run's own (physics.model's
# MECHANISM_MAX_*, tighter than a chain's: a general mechanism's samples are heavier), checked before the one
# Settings checks its own.
ALLOWED = {
    "t_end": f"allowed range 0 < t_end <= {_ten(MECHANISM_MAX_T_END)} (the run's duration from t_start, s)",
    "samples": f"allowed range 2 <= samples <= {MECHANISM_MAX_SAMPLES}",
    "t_start": "allowed range -1e6 <= t_start <= 1e6 (s)",
    "method": f"allowed values {', '.join(MECHANISM_METHODS)}",
    "stabilization": f"allowed values {', '.join(STABILIZATIONS)}",
    "rtol": f"allowed range {MIN_RTOL:g} <= rtol <= {_ten(MECHANISM_MAX_TOLERANCE)}",
    "atol": f"allowed range {MIN_ATOL:g} <= atol <= {_ten(MECHANISM_MAX_TOLERANCE)}",
    "integrator": f"allowed values {', '.join(INTEGRATOR_NAMES)}",
    "backend": f"allowed values {', '.join(BACKENDS)}",
    "step": "allowed range 0 < step <= 1 (s, the fixed step of midpoint and variational)",
    "max_steps": "allowed range 1 <= max_steps <= 1e9 (integration steps before a run is stopped)",
    "baumgarte_alpha": "allowed range 0 <= baumgarte_alpha <= 1e4",
    "baumgarte_beta": "allowed range 0 <= baumgarte_beta <= 1e4",
}
_SPANS = {"t_end": (0.0, MECHANISM_MAX_T_END, True), "t_start": (-1e6, 1e6, False),
          "rtol": (MIN_RTOL, MECHANISM_MAX_TOLERANCE, False), "atol": (MIN_ATOL, MECHANISM_MAX_TOLERANCE, False)}
_NAMES = {"method": MECHANISM_METHODS, "stabilization": STABILIZATIONS, "integrator": INTEGRATOR_NAMES,
          "backend": BACKENDS}


def _refuse(field: str, value) -> LinkageError:
    return LinkageError(f"{field} = {value!r}: {ALLOWED[field]}")


def _number(field: str, value) -> float:
    """A real number inside the mechanism's span for ``field``, or the one line naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise _refuse(field, value)
    number = float(value)
    low, high, open_low = _SPANS[field]
    if not (math.isfinite(number) and (low < number if open_low else low <= number) and number <= high):
        raise LinkageError(f"{field} = {value}: {ALLOWED[field]}")
    return number


_checked: dict[tuple, Settings] = {}
MAX_CHECKED = 64  # argument sets remembered at once (the app's chunks, a study's runs: a few each)


def run_options(*, t_end, samples, t_start=0.0, method="dae", stabilization="projection", rtol=1e-10, atol=1e-10,
                integrator="DOP853", step=None, max_steps=None, backend=DEFAULT_BACKEND,
                settings: Settings | None = None, baumgarte_alpha=None, baumgarte_beta=None) -> Settings:
    """:func:`checked_run_options`, remembered: the same arguments (each of the same type: ``200`` and ``200.0``
    are different arguments, one of them refused) give the same frozen :class:`Settings` without checking and
    validating them again (a tenth of a warm short run's Python). Only accepted arguments are kept."""
    arguments = (t_end, samples, t_start, method, stabilization, rtol, atol, integrator, step, max_steps, backend,
                 settings, baumgarte_alpha, baumgarte_beta)
    try:
        # a float by its bits (-0.0 is not 0.0 here), anything else by its value
        key = tuple((type(value), value.hex() if isinstance(value, float) else value) for value in arguments)
        found = _checked.get(key)
    except TypeError:  # an argument that cannot be a key (a list): checked, and refused, below
        key, found = None, None
    if found is not None:
        return found
    checked = checked_run_options(t_end=t_end, samples=samples, t_start=t_start, method=method,
                                  stabilization=stabilization, rtol=rtol, atol=atol, integrator=integrator, step=step,
                                  max_steps=max_steps, backend=backend, settings=settings,
                                  baumgarte_alpha=baumgarte_alpha, baumgarte_beta=baumgarte_beta)
    if key is not None:
        if len(_checked) >= MAX_CHECKED:
            _checked.clear()
        _checked[key] = checked
    return checked


def checked_run_options(*, t_end, samples, t_start=0.0, method="dae", stabilization="projection", rtol=1e-10,
                        atol=1e-10, integrator="DOP853", step=None, max_steps=None, backend=DEFAULT_BACKEND,
                        settings: Settings | None = None, baumgarte_alpha=None, baumgarte_beta=None) -> Settings:
    """The :class:`physics.model.Settings` of a mechanism's run, every option checked: LinkageError
    ``"field = value: allowed ..."`` (one line) for the first bad one, or the registry's sentence for a
    combination that cannot run (``integrator = variational: needs method = lagrange (got dae)``). With
    ``settings`` its method, integrator, back end, tolerances, step, budget, stabilisation and gains are the run's
    (the keywords are then not read); ``t_end`` and ``samples`` are always the arguments'. The Baumgarte gains
    (``baumgarte_alpha``, ``baumgarte_beta``: None keeps Settings' defaults) are checked by Settings too."""
    if settings is not None:
        method, stabilization, integrator, backend = (settings.method, settings.stabilization, settings.integrator,
                                                      settings.backend)
        rtol, atol, step, max_steps = settings.rtol, settings.atol, settings.step, settings.max_steps
        if settings.damping != 0.0:
            raise LinkageError(f"damping = {settings.damping:g}: does not apply to a mechanism (a chain's joint "
                               "damping); give each joint its damping in the description, or --set JOINT.damping=C")
        if settings.trace is not None:
            raise LinkageError("trace: a chain's bar point does not apply to a mechanism (it traces the point its "
                               "description names, trace = \"body.point\")")
    values = {"t_end": _number("t_end", t_end), "t_start": _number("t_start", t_start),
              "rtol": _number("rtol", rtol), "atol": _number("atol", atol)}
    if (isinstance(samples, bool) or not isinstance(samples, (int, np.integer))
            or not 2 <= samples <= MECHANISM_MAX_SAMPLES):
        raise _refuse("samples", samples)
    for field, value in (("method", method), ("stabilization", stabilization), ("integrator", integrator),
                         ("backend", backend)):
        if not isinstance(value, str) or value not in _NAMES[field]:
            raise _refuse(field, value)
    if METHODS[method].reduced and integrator not in integrators_for(method):
        raise LinkageError(f"integrator = {integrator}: method {method!r} integrates with {REDUCED_INTEGRATOR} only "
                           "(scipy's, on its own switching right-hand side); leave integrator out")
    fields = dict(method=method, integrator=integrator, backend=backend, rtol=values["rtol"], atol=values["atol"],
                  t_end=values["t_end"], samples=int(samples), stabilization=stabilization)
    if settings is not None:
        baumgarte_alpha, baumgarte_beta = settings.baumgarte_alpha, settings.baumgarte_beta
    for field, gain in (("baumgarte_alpha", baumgarte_alpha), ("baumgarte_beta", baumgarte_beta)):
        if gain is not None:
            fields[field] = gain
    if step is not None:
        fields["step"] = step
    if max_steps is not None:
        fields["max_steps"] = max_steps
    try:
        return Settings(**fields)
    except ValidationError as error:
        first = error.errors()[0]
        field = str(first["loc"][0]) if first["loc"] else ""
        if field in ALLOWED:
            raise _refuse(field, fields[field]) from None
        raise LinkageError(str(first["msg"]).removeprefix("Value error, ")) from None
