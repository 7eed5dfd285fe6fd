"""A mechanism preset's generated DAE and the states of a short run of its own: what the tests of the generated
elimination (tests/physics/test_structured_solve.py) and of the fused ``rhs`` (tests/physics/test_kernels_fused_rhs.py)
evaluate it at, so both check the code on the states the integrators really visit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from physics.kernels.abi import LAYOUT_SOLVE
from physics.mechanism import engine
from physics.mechanism.presets import MECHANISM_PRESETS
from physics.mechanism.simulate import simulate_mechanism

# The integrated presets whose DAE is sparse enough for a generated elimination (and so a fused rhs).
STRUCTURED_PRESETS = ["slider-crank", "watt-six-bar", "stephenson-six-bar", "jansen-leg"]


@dataclass
class PresetDae:
    """The compiled DAE of a preset, its parameter vector and layout, and a run's states (C-contiguous)."""

    compiled: object
    params: np.ndarray
    layout: np.ndarray
    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray


def preset_dae(name: str, t_end: float, samples: int) -> PresetDae:
    """Preset ``name``'s DAE along its own run of ``t_end`` seconds (``samples`` states)."""
    mechanism = MECHANISM_PRESETS[name]()
    run = simulate_mechanism(mechanism, t_end, samples, method="dae")
    compiled = engine.compiled_system(mechanism, "dae")
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, None)
    assert layout[LAYOUT_SOLVE] != 0, "the DAE of a mechanism has a generated sparse elimination"
    return PresetDae(compiled, params, layout, np.asarray(run.t), np.ascontiguousarray(run.q),
                     np.ascontiguousarray(run.qdot))
