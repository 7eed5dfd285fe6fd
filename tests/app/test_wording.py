"""Notices speak the panel's language: method names as the menus show them, the field named once."""

from __future__ import annotations

import pytest

from app import commands
from app.parameters import SessionParameters, in_menu_words
from conftest import wait_until
from physics import LinkageError


def test_physics_method_names_read_as_the_menus_show_them():
    assert in_menu_words("method = lagrange (got dae)") == "method = Lagrange (got DAE)"
    assert in_menu_words("choose method 'reduced', which switches") == "choose method 'Reduced (1 dof)', which switches"
    assert in_menu_words("reduced_fixed and newton_euler") == "Reduced, theta1 fixed and Newton-Euler"
    assert in_menu_words("a daemon is not dae") == "a daemon is not DAE"  # whole words only


def test_a_refusal_names_its_field_once():
    params = SessionParameters.from_preset("triple-a", method="dae")
    with pytest.raises(LinkageError) as caught:
        commands.apply(params, "integrator", "variational")
    text = str(caught.value)
    assert text.count("integrator = variational") == 1 and ": :" not in text, text
    assert "needs method = lagrange" in text
    assert in_menu_words(text).endswith("needs method = Lagrange (got DAE)")


def test_reset_to_the_preset_values_undoes_edits(connect):
    _, session = connect()
    session.set_mechanism("double")
    default_L1, default_g = session.setup.L[0], session.setup.g
    session.set("L1", default_L1 + 0.5)
    session.set("g", default_g * 2)
    assert session.setup.L[0] == default_L1 + 0.5
    session.guard(session.reset_to_reference)  # what the "Reset to the preset's values" button does
    assert wait_until(lambda: session.setup.L[0] == default_L1 and session.setup.g == default_g, timeout=30)
    assert session.setup.preset == "double"
