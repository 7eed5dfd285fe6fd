"""A general mechanism's saved setup checked as a whole, without a session: ``python -m app --state FILE``.

Why: a setup file given on the command line must be right as a whole (one line naming the first value refused,
exit 2) before the server listens, as a chain's is (:func:`app.share.check_setup`). A browser's session applies
a setup value by value through its panel (:meth:`app.session.Session.set_link_value`); this
module replays the same values, in the same order and through the same models (:mod:`app.mechanism_edits`,
:mod:`app.mechanism_start`, :mod:`app.mechanism_runs`), on plain data. Plain numpy and pydantic; no viser.
"""

from __future__ import annotations

from typing import get_args

import numpy as np

from physics import LinkageError
from physics.mechanism import Mechanism
from physics.model import INTEGRATOR_NAMES

from . import share
from .commands import read_number
from .mechanism_edits import START_NAMES, apply_edit, apply_setting, knobs, settings_knobs, start_knobs, start_value
from .mechanism_runs import (
    MechanismSettings,
    allowed_integrators,
    check_integrator,
    check_method,
    drawing,
    is_reduced,
    start_state,
)
from .mechanism_start import free_coordinates, pose_with, velocities_with
from .player import SAMPLE_DT

METHOD_NAMES = get_args(MechanismSettings.model_fields["method"].annotation)
STABILIZATION_NAMES = get_args(MechanismSettings.model_fields["stabilization"].annotation)
START_KINDS = {names[k] for names in START_NAMES.values() for k in (0, 2)}


def _choice(field: str, value: str, allowed: list[str]) -> None:
    if value not in allowed:
        raise LinkageError(f"{field} = {value!r}: allowed values {', '.join(allowed)}")


class SetupReplay:
    """A mechanism, its run settings and its start, edited by a setup's values as a session's panel edits them."""

    def __init__(self, mechanism: Mechanism) -> None:
        self.reference = self.mechanism = mechanism
        self.settings = MechanismSettings(trace=mechanism.trace)
        self._assembled(mechanism)

    def _assembled(self, mechanism: Mechanism) -> None:
        """A new geometry: the start is its assembled sketch at rest (as a session's after a size change)."""
        self.q0, self.qdot0, self.mobility = start_state(mechanism)
        self.sketch_q = self.q0
        self.free = free_coordinates(mechanism, self.q0, self.mobility)
        self.mechanism = mechanism
        if is_reduced(self.settings.method) and self.mobility != 1:
            self.settings = self.settings.model_copy(update={"method": "dae"})

    def start_knobs(self):
        return start_knobs(self.mechanism, self.free, self.sketch_q, self.q0, self.qdot0)

    def apply(self, name: str, text: str) -> None:
        """One value of the setup, in the panel's units; LinkageError naming the field otherwise."""
        if name == "method":
            _choice("method", text, list(METHOD_NAMES))
            check_method(text, self.mobility)
            update: dict[str, object] = {"method": text}
            if is_reduced(text):
                update.update(stabilization="projection", integrator=allowed_integrators(text)[0])
            elif self.settings.integrator not in allowed_integrators(text):
                raise LinkageError(f"method = {text}: the integrator {self.settings.integrator} does not apply "
                                   f"to it; choose one of {', '.join(allowed_integrators(text))} first")
            self.settings = self.settings.model_copy(update=update)
        elif name == "integrator":
            _choice("integrator", text, list(INTEGRATOR_NAMES))
            check_integrator(self.settings.method, text)
            self.settings = self.settings.model_copy(update={"integrator": text})
        elif name == "stabilization":
            _choice("stabilization", text, list(STABILIZATION_NAMES))
            if is_reduced(self.settings.method) and text != "projection":
                raise LinkageError("stabilisation: the reduced model closes its loops by position analysis; "
                                   "choose another method first")
            self.settings = self.settings.model_copy(update={"stabilization": text})
        elif name == "trace":
            _choice("traced point", text, ["(none)", *drawing(self.mechanism).labels])
            self.settings = self.settings.model_copy(update={"trace": None if text == "(none)" else text})
        else:
            self._number(name, text)

    def _number(self, name: str, text: str) -> None:
        every = [*knobs(self.mechanism, self.reference), *settings_knobs(self.settings), *self.start_knobs()]
        knob = next((k for k in every if k.name == name), None)
        value: object = text if knob is None else read_number(knob.label, knob.unit, text)
        if name in {k.name for k in settings_knobs(self.settings)}:
            self.settings = apply_setting(self.settings, name, value)
        elif name.partition(":")[0] in START_KINDS:
            number = start_value(self.start_knobs(), name, value)
            position, is_value = next((k, name == f"{START_NAMES[c.axis][0]}:{c.body}")
                                      for k, c in enumerate(self.free)
                                      if name in (f"{START_NAMES[c.axis][0]}:{c.body}",
                                                  f"{START_NAMES[c.axis][2]}:{c.body}"))
            indices = [c.index for c in self.free]
            values, rates = self.q0[indices].copy(), self.qdot0[indices].copy()
            if is_value:
                values[position] = number
                try:
                    self.q0 = pose_with(self.mechanism, self.q0, self.free, values)
                except LinkageError as error:
                    label = next(k.label for k in self.start_knobs() if k.name == name)
                    raise LinkageError(f"{label} = {text}: {error}") from None
            else:
                rates[position] = number
            self.qdot0 = velocities_with(self.mechanism, self.q0, self.free, np.asarray(rates))
        else:
            edited = apply_edit(self.mechanism, name, value, self.reference, SAMPLE_DT)
            if name.startswith(("size:", "ratio:", "offset:")):
                self._assembled(edited)
            else:
                self.mechanism = edited


def check_mechanism_setup(pairs: list[tuple[str, str]], mechanism: Mechanism) -> SetupReplay:
    """``mechanism`` set up by ``pairs`` (the preset's name and a chain's ``links`` aside); LinkageError naming
    the first value refused (the whole file must be right on the command line)."""
    replay = SetupReplay(mechanism)
    for name, text in pairs:
        if name == "links":
            raise LinkageError("links: only the 'chain' mechanism has a variable number of bars")
        if name not in share.FIRST:
            replay.apply(name, text)
    return replay
