"""Both readings of the seed report's cases B and C are presets; the caption/code reading is the default."""

from __future__ import annotations

import math

import numpy as np
import pytest

from physics import get_preset, preset_names

# (preset, angles as the report writes them, where the report writes them)
READINGS = (
    ("triple-a", (math.pi / 2, math.pi, math.pi), "text, Figure 9 caption and code"),
    ("triple-b", (math.pi / 4, math.pi / 2, 3 * math.pi / 4), "Figure 10 caption and code"),
    ("triple-c", (math.pi, math.pi / 3, math.pi / 3), "Figure 11 caption and code"),
    ("triple-b-text", (math.pi / 4, math.pi / 4, 3 * math.pi / 4), "section 2.4 text, case 2"),
    ("triple-c-text", (math.pi / 4, math.pi / 3, math.pi / 3), "section 2.4 text, case 3"),
)


@pytest.mark.parametrize("name, theta, source", READINGS)
def test_each_reading_is_a_preset_with_the_reports_angles(name, theta, source):
    assert name in preset_names(), f"{name} ({source}) missing"
    preset = get_preset(name)
    np.testing.assert_array_equal(preset.theta0, np.array(theta))
    np.testing.assert_array_equal(preset.omega0, np.zeros(3))
    assert preset.chain.n == 3 and not preset.chain.pinned


@pytest.mark.parametrize("case", ("b", "c"))
def test_descriptions_state_the_ambiguity_both_ways(case):
    default, text = get_preset(f"triple-{case}"), get_preset(f"triple-{case}-text")
    assert not np.array_equal(default.theta0, text.theta0)
    assert f"triple-{case}-text" in default.description and "caption" in default.description
    assert f"triple-{case}" in text.description and "text" in text.description


def test_case_a_description_says_the_sources_agree():
    assert "agree" in get_preset("triple-a").description
