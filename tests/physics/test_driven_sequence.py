"""A driven mechanism's position analysis in one native call (physics.codegen.native_states.driven_sequence,
physics.mechanism.engine.ONE_CALL) gives the very bits of the row-by-row loop it replaced (a project_states call
per sample): every Trajectory field of every fully driven preset, of a run where Newton does not close some
samples (assembled again in Python) and of a run that ends where no pose closes the loops; and it refuses a
wrong array before any pointer is handed over."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from physics.codegen import native_states
from physics.codegen.projection_ir import driven_ir, states_ir
from physics.kernels.constants import PROJECTION_TOLERANCE
from physics.mechanism import MECHANISM_PRESETS, Mechanism, engine
from physics.mechanism.assembly import assemble
from physics.mechanism.prepared import prepared
from physics.mechanism.simulate import simulate_mechanism
from physics.status import Status


def _fully_driven() -> list[str]:
    return [name for name, make in MECHANISM_PRESETS.items() if assemble(make()).mobility == 0]


def _long_crank() -> Mechanism:
    """The crank-rocker with a crank too long to turn (tests/physics/test_cold_mechanism.py): its motor drives
    it where the loop cannot close, part of the way round."""
    document = MECHANISM_PRESETS["crank-rocker"]().model_dump(mode="json")
    for body in document["bodies"]:
        if body["name"] in ("crank", "coupler"):
            body["points"]["A"] = [0.0, 0.25]
    return Mechanism.model_validate(document)


def _both(monkeypatch, mechanism: Mechanism, t_end: float, samples: int, method: str = "dae"):
    """``(row_by_row, one_call, fallbacks)``: the run both ways, and the samples each assembled in Python."""
    assembled = {False: 0, True: 0}
    original = engine._assembled_state
    runs = {}
    for one_call in (False, True):
        def counted(*arguments, _one_call=one_call):
            assembled[_one_call] += 1
            return original(*arguments)

        monkeypatch.setattr(engine, "ONE_CALL", one_call)
        monkeypatch.setattr(engine, "_assembled_state", counted)
        if one_call:  # the sequence, not a project_states call per sample
            monkeypatch.setattr(native_states, "project_states", _not_called)
        runs[one_call] = simulate_mechanism(mechanism, t_end, samples, method=method)
    assert assembled[False] == assembled[True]
    return runs[False], runs[True], assembled[True]


def _not_called(*_arguments):
    raise AssertionError("the one-call path called project_states")


def _assert_same_bits(before, after) -> None:
    assert not before.integrated and not after.integrated
    for field in dataclasses.fields(before):
        old, new = getattr(before, field.name), getattr(after, field.name)
        if isinstance(old, np.ndarray):
            assert old.dtype == new.dtype and np.array_equal(old, new), field.name
        elif field.name == "body_points":
            assert old.names == new.names
        else:
            assert old == new, field.name
    for name in before.point_names:
        assert np.array_equal(before.point(name), after.point(name)), name


@pytest.mark.parametrize("span, samples", [(2.0, 121), (10.0, 601)])
@pytest.mark.parametrize("name", _fully_driven())
def test_every_fully_driven_preset_gives_the_row_by_row_bits(monkeypatch, name, span, samples):
    before, after, _ = _both(monkeypatch, MECHANISM_PRESETS[name](), span, samples)
    assert after.status == Status.OK and after.t.size == samples
    _assert_same_bits(before, after)


def test_a_tree_formulation_gives_the_row_by_row_bits(monkeypatch):
    before, after, _ = _both(monkeypatch, MECHANISM_PRESETS["crank-rocker"](), 2.0, 121, method="lagrange")
    assert after.coordinates == "tree"
    _assert_same_bits(before, after)


def test_samples_newton_does_not_close_are_assembled_and_the_sequence_goes_on(monkeypatch):
    # 0.5 s between samples: the predicted pose is too far off for Newton's iterations on several of them
    before, after, fallbacks = _both(monkeypatch, MECHANISM_PRESETS["crank-rocker"](), 10.0, 21)
    assert fallbacks >= 2 and after.status == Status.OK and after.t.size == 21
    _assert_same_bits(before, after)


def test_a_run_ends_where_no_pose_closes_the_loops_as_before(monkeypatch):
    before, after, fallbacks = _both(monkeypatch, _long_crank(), 10.0, 601)
    assert fallbacks >= 1 and after.status == Status.SINGULAR and "cannot be assembled" in after.message
    assert 1 < after.t.size < 601 and after.message == before.message
    _assert_same_bits(before, after)


def _rows(name: str = "jansen-leg", samples: int = 31):
    """``(layout, params, t, xs, vs)`` of a driven run's position analysis: row 0 its assembled start."""
    mechanism = MECHANISM_PRESETS[name]()
    run = simulate_mechanism(mechanism, 1.0, samples)
    compiled = engine.compiled_system(mechanism, "dae")
    params, layout = engine.run_parameters(mechanism, compiled, 0.0, prepared(mechanism).projection_weights,
                                           integrating=False)
    xs, vs = np.zeros_like(run.q), np.zeros_like(run.qdot)
    xs[0], vs[0] = run.q[0], run.qdot[0]
    return layout, params, np.ascontiguousarray(run.t), xs, vs


def test_the_sequence_stops_at_the_first_row_it_cannot_keep():
    layout, params, t, xs, vs = _rows()
    tolerance = 100.0 * PROJECTION_TOLERANCE * max(1.0, float(np.max(np.abs(xs[0]))))
    assert native_states.driven_sequence(layout, t, xs, vs, params, 1, tolerance) == t.size
    assert np.all(np.isfinite(xs)) and np.all(np.isfinite(vs)) and not np.array_equal(xs[1], xs[0])
    kept = xs.copy()
    assert native_states.driven_sequence(layout, t, xs, vs, params, 5, -1.0) == 5  # no residual is below -1
    assert np.array_equal(xs[:5], kept[:5]) and np.array_equal(xs[6:], kept[6:])
    xs[9, 0] = np.inf  # row 10 is predicted from it: not finite
    assert native_states.driven_sequence(layout, t, xs, vs, params, 10, np.inf) == 10
    assert native_states.driven_sequence(layout, t, xs, vs, params, t.size, tolerance) == t.size  # nothing left
    assert np.array_equal(params, _rows()[1])  # the caller's params untouched (a copy takes each time)


def test_a_wrong_array_is_refused_before_any_pointer_is_handed_over():
    layout, params, t, xs, vs = _rows(samples=5)
    call = native_states.driven_sequence
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout, t, np.asfortranarray(xs), vs, params, 1, 1e-9)
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout, t[:-1], xs, vs, params, 1, 1e-9)
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout, t, xs, vs[:, :-1].copy(), params, 1, 1e-9)
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout, t, xs, vs.astype(np.float32), params, 1, 1e-9)
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout.astype(np.int32), t, xs, vs, params, 1, 1e-9)
    with pytest.raises(ValueError, match="C-contiguous"):
        call(layout, t, xs[0], vs, params, 1, 1e-9)
    with pytest.raises(ValueError, match="start must be at least 1"):
        call(layout, t, xs, vs, params, 0, 1e-9)


def test_the_sequence_ir_is_deterministic_and_free_of_fast_math():
    """Its module goes through LLVM's O2 pipeline: the bits stay the row-by-row loop's only because no
    instruction allows reassociation or contraction (and the machine code is cached under the sources' digest,
    which needs the same text from the same sources)."""
    text = driven_ir()
    assert text == driven_ir() and 'define i64 @"driven_sequence"' in text
    for flag in ("fast", "reassoc", "contract", "afn", "arcp", "nnan", "ninf", "nsz"):
        assert f" {flag} " not in text, flag
    assert "driven_sequence" not in states_ir()  # its own module: the states' keeps its short compilation
