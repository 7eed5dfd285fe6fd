"""A warm mechanism run's Python (issue 24: a chain run as a mechanism no slower than the chain engine).

* run_options remembers the Settings of the arguments it accepted (physics/mechanism/run_settings.py): the same
  arguments give the same object, arguments that differ in type or in the sign of a zero are checked on their
  own, and a refusal is never remembered.
* A remembered start comes back as ``dataclasses.replace`` gave it: every field equal, its own writable pose.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from physics.errors import LinkageError
from physics.mechanism import MECHANISM_PRESETS, run_settings
from physics.mechanism.assembly import assembled_with_jacobian
from physics.mechanism.prepared import prepared
from physics.mechanism.run_settings import checked_run_options, run_options
from physics.model import Settings


def test_the_same_arguments_give_the_checked_settings_once():
    run_settings._checked.clear()
    first = run_options(t_end=2.0, samples=50, method="lagrange", rtol=1e-7, atol=1e-7)
    assert run_options(t_end=2.0, samples=50, method="lagrange", rtol=1e-7, atol=1e-7) is first
    assert first == checked_run_options(t_end=2.0, samples=50, method="lagrange", rtol=1e-7, atol=1e-7)
    other = run_options(t_end=2.0, samples=50, method="newton_euler", rtol=1e-7, atol=1e-7)
    assert other.method == "newton_euler" and other is not first
    chain = Settings(method="dae", integrator="RK45", rtol=1e-6, atol=1e-6)
    assert run_options(t_end=1.0, samples=5, settings=chain) is run_options(t_end=1.0, samples=5, settings=chain)


def test_a_refusal_is_refused_every_time_and_types_are_not_mixed():
    run_settings._checked.clear()
    assert run_options(t_end=1.0, samples=5).samples == 5
    for _ in range(2):
        with pytest.raises(LinkageError, match="samples = 5.0"):
            run_options(t_end=1.0, samples=5.0)
        with pytest.raises(LinkageError, match="samples = True"):
            run_options(t_end=1.0, samples=True)
    negative = run_options(t_end=1.0, samples=5, baumgarte_alpha=-0.0)
    positive = run_options(t_end=1.0, samples=5, baumgarte_alpha=0.0)
    assert str(negative.baumgarte_alpha) == "-0.0" and str(positive.baumgarte_alpha) == "0.0"
    with pytest.raises(LinkageError):
        run_options(t_end=1.0, samples=5, rtol=[1e-6])  # not a key: checked and refused as before
    assert len(run_settings._checked) <= run_settings.MAX_CHECKED


def test_a_remembered_start_is_the_replaced_one_with_its_own_pose():
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    pieces = prepared(mechanism)
    first, jacobian = assembled_with_jacobian(mechanism, pieces)
    second, again = assembled_with_jacobian(mechanism, pieces)  # remembered
    assert again is jacobian
    expected = dataclasses.replace(first, q=first.q.copy())
    for field in dataclasses.fields(expected):
        value = getattr(second, field.name)
        if isinstance(value, np.ndarray):
            assert np.array_equal(value, getattr(expected, field.name))
        else:
            assert value == getattr(expected, field.name), field.name
    assert second.q is not first.q and second.q.flags.writeable
    second.q[0] += 1.0  # the caller's own: the remembered pose is untouched
    assert assembled_with_jacobian(mechanism, pieces)[0].q[0] == first.q[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        second.residual = 0.0  # type: ignore[misc]
