"""Every validation rule names the field and the allowed range; the CLI prints one line and exits non-zero."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from physics import LinkageError, Settings, get_preset, make_chain
from physics.model import apply_overrides, validated

SEED = dict(L=[1.0, 1.0, 1.0], d=[0.5, 0.5, 0.5], m=[1.0, 1.0, 1.0], I=[0.2, 0.3, 0.4])


def _chain_with(field, index, value, g=1.0):
    values = {k: list(v) for k, v in SEED.items()}
    values[field][index] = value
    return make_chain(values["L"], values["d"], values["m"], values["I"], g=g)


@pytest.mark.parametrize(
    "field, index, value, must_say",
    [
        ("L", 1, -1.0, ["L2", "0 <= L <= 1000 m"]),
        ("L", 0, 1e308, ["L1", "0 <= L <= 1000 m"]),
        ("m", 0, 1e7, ["m1", "0 <= m <= 1e+06 kg"]),
        ("I", 1, 1e300, ["I2", "0 <= I <= 1e+12 kg m^2"]),
        ("d", 0, -0.1, ["d1", "0 <= d <= L"]),
        ("d", 2, 1.5, ["d3", "0 <= d <= L"]),
        ("m", 2, -2.0, ["m3", "0 <= m"]),
        ("I", 0, -0.5, ["I1", "0 <= I"]),
        ("L", 0, math.nan, ["L1", "finite"]),
        ("m", 1, math.inf, ["m2", "finite"]),
        ("I", 2, math.nan, ["I3", "finite"]),
    ],
)
def test_bar_rules_name_the_field(field, index, value, must_say):
    with pytest.raises(LinkageError) as info:
        _chain_with(field, index, value)
    text = str(info.value)
    for part in must_say:
        assert part in text, text
    assert "\n" not in text


@pytest.mark.parametrize(
    "g, must_say",
    [(-1.0, ["g", "0 <= g <= 1000 m/s^2"]), (1e300, ["g = 1e+300", "0 <= g <= 1000 m/s^2"]), (math.nan, ["g", "finite"])],
)
def test_gravity_rules(g, must_say):
    with pytest.raises(LinkageError) as info:
        _chain_with("L", 0, 1.0, g=g)
    for part in must_say:
        assert part in str(info.value)


@pytest.mark.parametrize(
    "name, value, must_say",
    [
        ("theta2", 1e5, "theta2 = 100000: allowed range -10000 <= theta <= 10000 rad"),
        ("omega1", -1e300, "omega1 = -1e+300: allowed range -10000 <= omega <= 10000 rad/s"),
    ],
)
def test_start_state_beyond_its_bound_is_refused_on_the_command_line(name, value, must_say):
    result = subprocess.run(
        [sys.executable, "-m", "physics", "simulate", "--preset", "triple-a", "--set", f"{name}={value}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2
    assert result.stderr.strip() == f"error: {must_say}"
    assert result.stdout == ""


def test_singular_mass_matrix_names_the_bar_and_the_fix():
    with pytest.raises(LinkageError) as info:
        make_chain([1, 1, 1], [0.5, 0.5, 0.0], [1, 1, 1], [0.2, 0.3, 0.0])
    text = str(info.value)
    assert "bar 3" in text and "singular" in text and "I3" in text


@pytest.mark.parametrize("d1, I1", [(1.8e-313, 1.17549435082e-38), (0.0, 9.9e-10), (3e-5, 0.0)])
def test_next_to_no_inertia_about_a_joint_is_refused_with_the_range(d1, I1):
    """Numerically no inertia: the motion's time scale collapses (a damped single bar of 1.2e-38 kg m^2 took more
    steps for one sample than a run may take in the app's long control run)."""
    with pytest.raises(LinkageError) as info:
        make_chain([1.0], [d1], [1.0], [I1])
    text = str(info.value)
    assert "bar 1" in text and ">= 1e-09 kg·m²" in text and "I1" in text
    make_chain([1.0], [0.0], [1.0], [1e-9])  # the floor itself is allowed


def test_link_count_range():
    with pytest.raises(LinkageError, match="links = 13"):
        make_chain([1.0] * 13, [0.5] * 13, [1.0] * 13, [0.1] * 13)
    with pytest.raises(LinkageError, match="links"):
        get_preset("chain", links=0)


def test_unknown_override_lists_allowed_names():
    preset = get_preset("triple-a")
    with pytest.raises(LinkageError, match="unknown parameter 'L4'"):
        apply_overrides(preset.chain, preset.theta0, preset.omega0, {"L4": 1})
    with pytest.raises(LinkageError, match="theta1"):
        apply_overrides(preset.chain, preset.theta0, preset.omega0, {"theta1": "nan"})


@pytest.mark.parametrize(
    "fields, must_say",
    [
        (dict(rtol=0.0), "rtol"),
        (dict(atol=-1.0), "atol"),
        (dict(t_end=-5.0), "t_end"),
        (dict(samples=1), "samples"),
        (dict(method="euler"), "method"),
        (dict(integrator="Euler"), "integrator"),
        (dict(integrator="midpoint", backend="scipy"), "midpoint"),
        (dict(integrator="variational", backend="scipy"), "variational"),
        (dict(integrator="variational", method="dae"), "method = lagrange"),
    ],
)
def test_settings_rules(fields, must_say):
    with pytest.raises(LinkageError) as info:
        validated(Settings, **fields)
    assert must_say in str(info.value)


@pytest.mark.parametrize(
    "argv, must_say",
    [
        (["simulate", "--preset", "triple-a", "--set", "L2=-1"], "L2"),
        (["simulate", "--preset", "triple-a", "--set", "m3=nan"], "m3"),
        (["simulate", "--preset", "triple-a", "--rtol", "0"], "rtol"),
        (["simulate", "--preset", "nonsense"], "--preset"),
        (["simulate", "--preset", "chain", "--links", "40"], "links"),
        (["accelerations", "--preset", "triple-a", "--state", "1,2"], "--state"),
        (["accelerations", "--preset", "four-bar", "--pin", "9,9"], "theta1"),
        (["simulate", "--preset", "triple-a", "--set", "d1=3"], "d"),
        (["simulate", "--preset", "triple-a", "--method", "newton_euler", "--integrator", "variational"], "lagrange"),
    ],
)
def test_cli_bad_input_is_one_line_and_nonzero(argv, must_say):
    result = subprocess.run([sys.executable, "-m", "physics", *argv], capture_output=True, text=True, timeout=120)
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert must_say in lines[0]
