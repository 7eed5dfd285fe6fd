"""A mechanism's run settings, in the app and on the command line, are the one physics Settings (issue 24, "one
Settings"): the panel's fields are Settings' own, its tolerance span is the one a mechanism's run allows, and every
value, the Baumgarte gains too, is refused by physics' run_options in its documented words."""

from __future__ import annotations

import math
import typing

import pytest
from pydantic import ValidationError

from app.mechanism_edits import TOLERANCE_RANGE, settings_knobs
from app.mechanism_runs import MechanismSettings, run_settings
from physics import LinkageError, Settings
from physics.mechanism.simulate import ALLOWED, run_options


def test_the_documented_words_of_a_mechanisms_run_are_kept():
    assert ALLOWED["t_end"] == "allowed range 0 < t_end <= 1e4 (the run's duration from t_start, s)"
    assert ALLOWED["samples"] == "allowed range 2 <= samples <= 1000000"
    assert ALLOWED["rtol"] == "allowed range 1e-14 <= rtol <= 1e-2"
    assert ALLOWED["atol"] == "allowed range 1e-16 <= atol <= 1e-2"


@pytest.mark.parametrize("field", ["step", "baumgarte_alpha", "baumgarte_beta"])
def test_the_panels_run_fields_are_the_one_settings_fields(field):
    assert MechanismSettings.model_fields[field].default == Settings.model_fields[field].default
    assert MechanismSettings.model_fields[field].metadata == Settings.model_fields[field].metadata
    top = next(item.le for item in Settings.model_fields[field].metadata if hasattr(item, "le"))
    assert getattr(MechanismSettings(**{field: top}), field) == top
    for bad in (top * 1.5, -1.0, math.nan):
        with pytest.raises(ValidationError):
            MechanismSettings(**{field: bad})


@pytest.mark.parametrize("field", ["integrator", "stabilization"])
def test_the_panels_names_are_the_one_settings_names(field):
    assert MechanismSettings.model_fields[field].annotation == Settings.model_fields[field].annotation
    for name in typing.get_args(Settings.model_fields[field].annotation):
        assert getattr(MechanismSettings(**{field: name}), field) == name
    with pytest.raises(ValidationError):
        MechanismSettings(**{field: "euler"})


def test_the_panels_tolerance_is_the_span_a_mechanisms_run_allows():
    assert TOLERANCE_RANGE == (1e-14, 1e-2)
    assert next(k for k in settings_knobs(MechanismSettings()) if k.name == "rtol").allowed == TOLERANCE_RANGE
    assert MechanismSettings(rtol=1e-2).rtol == run_options(t_end=1.0, samples=2, rtol=1e-2, atol=1e-2).rtol
    with pytest.raises(ValidationError):
        MechanismSettings(rtol=0.05)  # a chain's Settings takes it; a mechanism's run does not (documented)
    with pytest.raises(LinkageError, match=r"^rtol = 0.05: allowed range 1e-14 <= rtol <= 1e-2$"):
        run_options(t_end=1.0, samples=2, rtol=0.05)


def test_the_baumgarte_gains_of_a_chunk_are_checked_by_run_options():
    settings = run_settings(1.0, 3, "dae", "baumgarte", 1e-8, "DOP853", None, (5.0, 6.0))
    assert isinstance(settings, Settings) and (settings.baumgarte_alpha, settings.baumgarte_beta) == (5.0, 6.0)
    assert run_settings(1.0, 3, "dae", "projection", 1e-8, "DOP853", None, None).baumgarte_alpha == (
        Settings.model_fields["baumgarte_alpha"].default)
    for gains, words in [((1e5, 1.0), "baumgarte_alpha = 100000.0: allowed range 0 <= baumgarte_alpha <= 1e4"),
                         ((1.0, math.nan), "baumgarte_beta = nan: allowed range 0 <= baumgarte_beta <= 1e4")]:
        with pytest.raises(LinkageError) as error:
            run_settings(1.0, 3, "dae", "baumgarte", 1e-8, "DOP853", None, gains)
        assert str(error.value) == words
