"""The general mechanism's panel has what the chain's has (issue 24, "one control generator"): the integrator
menu and its settings, the start's coordinates and speeds, a gear pair's ratio and offset, and one reader of
typed numbers for both panels."""

from __future__ import annotations

import math
import urllib.parse
from pathlib import Path

import numpy as np
import pytest

from app.commands import CONTROL, QUANTITIES, parse_number, read_number
from app.mechanism_edits import apply_edit, apply_setting, knobs, settings_knobs, start_knobs
from app.mechanism_runs import MechanismSettings, MechanismSpec, allowed_integrators, check_integrator, start_state
from app.mechanism_start import free_coordinates, pose_with, velocities_with
from app.server import LabServer
from app.session import Session
from conftest import lab_of, wait_until
from physics import INTEGRATOR_NAMES, LinkageError
from physics.mechanism import MECHANISM_PRESETS, Constraints, Mechanism
from physics.mechanism.files import load_mechanism
from physics.registry import REDUCED_INTEGRATOR, integrators_for

ROOT = Path(__file__).resolve().parents[2]
DOUBLE = ROOT / "docs" / "examples" / "double-pendulum.toml"

# A four-bar whose links cannot all turn (not Grashof): its output rocks, and some angles close no loop.
ROCKER = {
    "name": "double-rocker", "g": 9.81,
    "ground": {"A": [0.0, 0.0], "D": [3.0, 0.0]},
    "bodies": [
        {"name": "input", "points": {"A": [0.0, 0.0], "B": [0.0, 2.0]}, "mass": 1.0, "inertia": 0.1},
        {"name": "coupler", "points": {"B": [0.0, 2.0], "C": [2.5, 1.5]}, "mass": 1.0, "inertia": 0.1},
        {"name": "output", "points": {"C": [2.5, 1.5], "D": [3.0, 0.0]}, "mass": 1.0, "inertia": 0.1}],
    "joints": [{"kind": "revolute", "name": "A", "a": "ground.A", "b": "input.A"},
               {"kind": "revolute", "name": "B", "a": "input.B", "b": "coupler.B"},
               {"kind": "revolute", "name": "C", "a": "coupler.C", "b": "output.C"},
               {"kind": "revolute", "name": "D", "a": "output.D", "b": "ground.D"}],
}


@pytest.fixture(scope="module")
def double_lab():
    server = LabServer(port=0, warm=False, mechanism=load_mechanism(DOUBLE), mechanism_label="double-pendulum")
    yield server
    server.stop()


slider_lab = lab_of("slider-crank")


def _notice(session) -> str:
    return session.notices.text or ""


# ---------------------------------------------------------------------------------------------- the integrator
def test_every_integrator_of_the_registry_is_offered_where_it_applies():
    assert set(allowed_integrators("dae")) == set(INTEGRATOR_NAMES) - {"variational"}
    assert set(allowed_integrators("newton_euler")) == set(INTEGRATOR_NAMES) - {"variational"}
    assert set(allowed_integrators("lagrange")) == set(INTEGRATOR_NAMES)
    assert allowed_integrators("reduced") == (REDUCED_INTEGRATOR,)
    for method in ("dae", "lagrange", "newton_euler", "reduced"):  # the registry's own answer
        assert allowed_integrators(method) == integrators_for(method), method
    with pytest.raises(LinkageError) as refused:
        check_integrator("dae", "variational")
    message = str(refused.value)
    assert message.startswith("integrator = variational: does not apply to method dae") and "lagrange" in message
    assert message.endswith("allowed " + ", ".join(allowed_integrators("dae")))
    with pytest.raises(LinkageError, match=r"integrator = RK45: does not apply to method reduced .*allowed DOP853$"):
        check_integrator("reduced", "RK45")


def test_the_baumgarte_gains_reach_the_run():
    """Baumgarte terms with larger gains hold the loop closer over the same run (the gains are not ignored)."""
    mechanism = MECHANISM_PRESETS["slider-crank"]()
    q0, qdot0, _ = start_state(mechanism)
    spec = MechanismSpec("main", mechanism, MechanismSettings())
    residuals = []
    for gains in ((0.0, 0.0), (20.0, 100.0)):
        settings = MechanismSettings(stabilization="baumgarte", rtol=1e-6, baumgarte_alpha=gains[0],
                                     baumgarte_beta=gains[1], t_end=2.0, samples=21)
        run = spec.simulate(mechanism, q0, qdot0 + 0.0, settings).run
        residuals.append(float(np.max(np.abs(run.residual))))
    assert residuals[1] < residuals[0], residuals


@pytest.mark.parametrize("integrator", ["RK45", "midpoint", "Radau"])
def test_a_run_integrates_with_the_chosen_integrator(integrator):
    mechanism = load_mechanism(DOUBLE)
    q0, qdot0, _ = start_state(mechanism)
    spec = MechanismSpec("main", mechanism, MechanismSettings())
    settings = MechanismSettings(integrator=integrator, step=2e-3, rtol=1e-8, t_end=0.2, samples=11)
    chunk = spec.simulate(mechanism, q0 + np.array([0, 0, 0.3, 0, 0, 0.3]), qdot0, settings)
    assert chunk.status == 0 and chunk.run.integrator == integrator
    assert chunk.run.q.shape == (11, 6) and np.max(np.abs(chunk.run.residual)) < 1e-8


def test_the_run_settings_are_knobs_with_ranges():
    rtol, step, alpha, beta = settings_knobs(MechanismSettings())
    assert (alpha.name, beta.name) == ("baumgarte_alpha", "baumgarte_beta")
    assert apply_setting(MechanismSettings(), "baumgarte_beta", 12.5).baumgarte_beta == 12.5
    assert (rtol.name, rtol.log, rtol.value) == ("rtol", True, 1e-10)
    assert rtol.slider_value() == pytest.approx(-10.0) and rtol.from_slider(-8.0) == pytest.approx(1e-8)
    assert step.name == "step" and step.value == pytest.approx(1.0)  # ms
    assert apply_setting(MechanismSettings(), "step", 2.5).step == pytest.approx(2.5e-3)
    assert apply_setting(MechanismSettings(), "rtol", 1e-7).rtol == 1e-7
    with pytest.raises(LinkageError, match=r"^tolerance rtol = atol = 1: allowed range 1e-14 to 0.01$"):
        apply_setting(MechanismSettings(), "rtol", 1.0)


def test_the_integrator_menu_applies_or_refuses_naming_what_is_allowed(slider_lab, connect):
    _, session = connect(slider_lab)
    assert isinstance(session, Session)
    assert list(session.integrator.options) == list(INTEGRATOR_NAMES)
    session.guard(lambda: session.set_integrator("variational"))  # the DAE has no Lagrangian
    assert _notice(session).startswith("Not applied") and "allowed RK45, DOP853, ode45, Radau, LSODA, midpoint" in \
        _notice(session)
    assert session.settings.integrator == "DOP853" and session.integrator.value == "DOP853"
    session.set_method("lagrange")
    session.set_integrator("variational")
    assert session.settings.integrator == "variational"
    assert session._knob_handles["step"].visible and not session._knob_handles["rtol"].visible
    for action, words in ((lambda: session.set_method("dae"), "method = dae"),
                          (lambda: session.set_compare(True), "compare mode: integrator = variational")):
        session.notices.clear()
        session.guard(action)
        assert _notice(session).startswith("Not applied") and words in _notice(session), _notice(session)
    assert session.settings.method == "lagrange" and not session.compare
    session.set_typed("step", "2.5")  # ms, as the chain panel's
    assert session.settings.step == pytest.approx(2.5e-3)
    start = session.player.display_time
    session.play()
    assert wait_until(lambda: session.player.display_time > start + 0.3, timeout=60)
    assert session.player.runs[0].failed is None and "variational" in session.status.content
    session.set_stabilization("baumgarte")
    assert session._knob_handles["baumgarte_alpha"].visible
    session.set_typed("baumgarte_alpha", "20")
    assert session.spec.settings.baumgarte_alpha == 20.0
    session.set_integrator("RK45")
    session.set_typed("rtol", "1e-8")
    assert (session.settings.integrator, session.settings.rtol) == ("RK45", 1e-8)
    query = urllib.parse.parse_qs(session.link_query()[1:])
    assert query["integrator"] == ["RK45"] and query["rtol"] == ["1e-08"] and query["method"] == ["lagrange"]
    assert query["stabilization"] == ["baumgarte"] and query["baumgarte_alpha"] == ["20"]


# ---------------------------------------------------------------------------------------------- the start
def test_the_free_coordinates_are_the_bodies_a_person_turns():
    double = load_mechanism(DOUBLE)
    q, _, mobility = start_state(double)
    assert [(c.body, c.axis) for c in free_coordinates(double, q, mobility)] == [("upper", "angle"),
                                                                                  ("lower", "angle")]
    crank = MECHANISM_PRESETS["slider-crank"]()
    q, _, mobility = start_state(crank)
    assert [(c.body, c.axis) for c in free_coordinates(crank, q, mobility)] == [("crank", "angle")]
    jansen = MECHANISM_PRESETS["jansen-leg"]()
    q, _, mobility = start_state(jansen)
    assert free_coordinates(jansen, q, mobility) == ()  # its motor fixes every body


@pytest.mark.parametrize("preset, turn", [("slider-crank", 2.5), ("watt-six-bar", -1.0), ("stephenson-six-bar", 3.0)])
def test_a_start_angle_closes_every_loop_and_its_speed_every_velocity(preset, turn):
    mechanism = MECHANISM_PRESETS[preset]()
    q, _, mobility = start_state(mechanism)
    free = free_coordinates(mechanism, q, mobility)
    held = np.array([q[c.index] for c in free]) + turn
    posed = pose_with(mechanism, q, free, held)
    constraints = Constraints(mechanism)
    assert np.max(np.abs(constraints.residual(posed, 0.0))) < 1e-10
    assert np.allclose(posed[[c.index for c in free]], held, atol=1e-12)
    qdot = velocities_with(mechanism, posed, free, np.full(len(free), 2.0))
    assert np.max(np.abs(constraints.jacobian(posed) @ qdot - constraints.velocity_rhs())) < 1e-10
    assert np.allclose(qdot[[c.index for c in free]], 2.0)


def test_a_start_no_loop_reaches_is_refused_naming_the_joint():
    rocker = Mechanism.model_validate(ROCKER)
    q, _, mobility = start_state(rocker)
    free = free_coordinates(rocker, q, mobility)
    with pytest.raises(LinkageError, match=r"^joint 'B' cannot close there"):
        pose_with(rocker, q, free, np.array([math.radians(-120.0)]))


def test_start_controls_set_the_start_restart_and_travel_in_links(double_lab, connect):
    _, session = connect(double_lab)
    names = [knob.name for knob in session._start_knobs()]
    assert names == ["angle0:upper", "angle0:lower", "omega0:upper", "omega0:lower"]
    assert all(name in session._typed_boxes and name in session._knob_handles for name in names)
    session.typed_box("angle0:upper").value = "60"  # as a person types it: applied when typing pauses
    assert wait_until(lambda: not session.typing(), timeout=10)
    session.set_typed("omega0:lower", "-90")
    assert session.q0[2] == pytest.approx(math.radians(60), abs=1e-12) and abs(session.q0[5]) < 1e-12
    assert session.qdot0[5] == pytest.approx(math.radians(-90)) and session.qdot0[2] == 0.0
    assert session.player.wait_idle(60)
    first = session.player.runs[0].ring
    assert first.t_first == 0.0 and np.allclose(first.get("q", 0), session.q0, atol=1e-9)
    assert np.allclose(first.get("qdot", 0), session.qdot0, atol=1e-9)
    assert session.typed_box("angle0:upper").value == "60"
    assert session._knob_handles["angle0:upper"].value == pytest.approx(60.0)
    session.reset()  # Reset starts again from the start in force, as the chain's
    assert session.q0[2] == pytest.approx(math.radians(60)) and session.qdot0[5] == pytest.approx(math.radians(-90))
    assert session.snapshot()["start"] == pytest.approx(
        {"angle0:upper": 60.0, "angle0:lower": 0.0, "omega0:upper": 0.0, "omega0:lower": -90.0}, abs=1e-9)


def test_a_start_travels_in_a_share_link(slider_lab, connect):
    _, session = connect(slider_lab)
    session.set_typed("angle0:crank", "120")
    session.set_typed("omega0:crank", "180")
    pairs = urllib.parse.parse_qsl(session.link_query()[1:])
    assert pairs[-2:] == [("angle0:crank", "120"), ("omega0:crank", "180")]
    # the link opens a new session with this start (its values go through the share link's path)
    _, other = connect(slider_lab)
    other.load_setup([pair for pair in pairs if pair[0] != "preset"])
    assert other.notices.text is None, other.notices.text
    assert np.allclose(other.q0, session.q0, atol=1e-9) and np.allclose(other.qdot0, session.qdot0, atol=1e-9)
    other.reset_to_reference()
    assert abs(other.q0[2]) < 1e-12 and not np.any(other.qdot0)
    assert "angle0:crank" not in other.link_query()


def test_a_start_angle_that_cannot_close_is_one_notice_naming_the_joint(double_lab, connect):
    _, session = connect(double_lab)
    session.load_file(None, "rocker.json", Mechanism.model_validate(ROCKER).model_dump_json().encode())
    name = next(knob.name for knob in session._start_knobs() if knob.name.startswith("angle0:"))
    before = session.q0.copy()
    session.notices.clear()
    session.guard(lambda: session.set_typed(name, "-120"))
    notice = _notice(session)
    assert notice.startswith("Not applied") and "joint 'B' cannot close there" in notice and "= -120" in notice
    assert np.array_equal(session.q0, before)
    assert session.typed_box(name).value == f"{math.degrees(before[8]):.6g}"


def test_a_mechanism_its_motors_fix_has_no_start_controls():
    mechanism = MECHANISM_PRESETS["crank-rocker"]()
    q, qdot, mobility = start_state(mechanism)
    assert start_knobs(mechanism, free_coordinates(mechanism, q, mobility), q, q, qdot) == []


# ---------------------------------------------------------------------------------------------- gear pairs
def test_a_gear_pair_has_its_ratio_and_offset_knobs_and_the_run_keeps_the_ratio():
    mechanism = MECHANISM_PRESETS["geared-five-bar"]()
    names = {knob.name: knob for knob in knobs(mechanism)}
    assert names["ratio:gears"].value == -1.0 and names["offset:gears"].value == 0.0
    assert names["ratio:gears"].geometry and names["offset:gears"].unit == "°"
    edited = apply_edit(mechanism, "ratio:gears", -2.0)
    gear = next(joint for joint in edited.joints if joint.kind == "gear")
    assert gear.ratio == -2.0
    q0, qdot0, _ = start_state(edited)
    spec = MechanismSpec("main", edited, MechanismSettings())
    run = spec.simulate(edited, q0, qdot0, MechanismSettings(t_end=0.1, samples=6)).run
    bodies = [body.name for body in edited.bodies]
    first, second = (3 * bodies.index(name) + 2 for name in ("crank1", "crank2"))
    assert np.allclose(run.qdot[:, second], -2.0 * run.qdot[:, first], rtol=1e-8, atol=1e-9)
    with pytest.raises(LinkageError, match=r"^gear gears: ratio = 0: "):
        apply_edit(mechanism, "ratio:gears", 0.0)
    offset = apply_edit(mechanism, "offset:gears", 30.0)
    assert next(j for j in offset.joints if j.kind == "gear").offset == pytest.approx(math.radians(30.0))


# ---------------------------------------------------------------------------------------------- typed numbers
@pytest.mark.parametrize("text", ["2.5e1", "1e-3", "-0", "1_000", "1,5", "", "nan", " \u221215 ", "x" * 70])
def test_both_panels_read_a_typed_number_with_one_reader(text, double_lab, connect):
    """The chain's parse_number and the mechanism's boxes give the same number or the same refusal, bar the
    field's name."""
    chain = mechanism = None
    try:
        chain = parse_number("g", QUANTITIES["g"], text, CONTROL)
    except LinkageError as error:
        chain = str(error).replace("g: ", "FIELD: ", 1).replace("g = ", "FIELD = ", 1)
    try:
        mechanism = read_number("g (m/s²)", "m/s²", text)
    except LinkageError as error:
        mechanism = str(error).replace("g (m/s²)", "FIELD", 1)
    assert chain == mechanism
    if text == "2.5e1":
        assert chain == 25.0
    if text == "1,5":
        assert "not a number" in str(chain)
    _, session = connect(double_lab)
    session.notices.clear()
    session.guard(lambda: session.set_typed("g", text))
    if isinstance(mechanism, str):
        assert _notice(session) == f"Not applied: {mechanism.replace('FIELD', 'g (m/s²)')}"
    elif 0 <= mechanism <= 1e3:  # the model's bounds, as the chain's box (not the slider's 0 to 30)
        assert session.mechanism.g == mechanism
    else:
        assert "allowed range 0 to 1000" in _notice(session)
