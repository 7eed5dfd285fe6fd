"""How a run ended: one status enum for the kernels, ``Trajectory`` and the studies, each member with the
sentence that tells the user what happened and what to do.

The values are the kernels' integers (``physics.kernels.constants``: compiled code returns plain ints, and a
change there must change the kernels' cache digest), named here once.
"""

from __future__ import annotations

import enum

from .kernels.constants import (
    SINGULAR_PIVOT_RATIO,
    STATUS_INTEGRATOR_FAILED,
    STATUS_MAX_STEPS,
    STATUS_NOT_FINITE,
    STATUS_OK,
    STATUS_SINGULAR,
    STATUS_STEP_TOO_SMALL,
)


class Status(enum.IntEnum):
    """0 ok, < 0 failed midway (the run keeps what it computed up to then)."""

    OK = STATUS_OK
    SINGULAR = STATUS_SINGULAR
    NOT_FINITE = STATUS_NOT_FINITE
    STEP_TOO_SMALL = STATUS_STEP_TOO_SMALL
    MAX_STEPS = STATUS_MAX_STEPS
    INTEGRATOR_FAILED = STATUS_INTEGRATOR_FAILED

    @property
    def short(self) -> str:
        """A few words for a table cell."""
        return _SHORT[self]

    def message(self, t: float, detail: str = "") -> str:
        """The one-line explanation at time ``t``, naming the fix."""
        return _TEXT[self].format(t=t, limit=SINGULAR_PIVOT_RATIO, detail=detail)

    @classmethod
    def describe(cls, code: int, t: float, detail: str = "") -> str:
        """``message`` for a raw code; a code outside the table still gets a sentence."""
        try:
            return cls(code).message(t, detail)
        except ValueError:
            return f"failed at t = {t:.6g} s: {detail}"


_TEXT = {
    Status.OK: "ok",
    Status.SINGULAR: "the system became singular (pivot ratio above {limit:.0e}, condition number near its square) at "
    "t = {t:.6g} s: the linkage reached a singular position (links lined up) or its parameters give a bar no inertia",
    Status.NOT_FINITE: "the state became non-finite at t = {t:.6g} s",
    Status.STEP_TOO_SMALL: "the step size fell below the smallest allowed at t = {t:.6g} s (the problem is too "
    "stiff or singular for this integrator; try Radau or a looser tolerance)",
    Status.MAX_STEPS: "the integrator reached max_steps at t = {t:.6g} s; raise max_steps or loosen the tolerance",
    Status.INTEGRATOR_FAILED: "the integrator failed at t = {t:.6g} s: {detail}",
}

_SHORT = {
    Status.OK: "ok",
    Status.SINGULAR: "singular",
    Status.NOT_FINITE: "non-finite",
    Status.STEP_TOO_SMALL: "step < min",
    Status.MAX_STEPS: "max steps",
    Status.INTEGRATOR_FAILED: "failed",
}
