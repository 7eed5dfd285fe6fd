"""A chain hosted by the mechanism session (issue 24, "One app session"): the chain's knobs and names, its edits
through the chain's command layer, its share link, and its run against the chain engine's.

Each session is built in this process on a viser server of its own (``shared``: it draws for whoever connects,
no browser needed), its chunks computed in this interpreter (the worker pool set to none), so that a test can
see whether an edit loaded a new compiled system.
"""

from __future__ import annotations

import json
import math
import re
import urllib.parse

import numpy as np
import pytest
import viser

import physics
from app import commands, export, share
from app.chain_knobs import BAR_SLIDERS, chain_angles, hosted_start, reach_text
from app.commands import CONTROL, QUANTITIES
from app.panel_rows import CHAIN_PLOT_CHOICES, MECHANISM_PLOT_CHOICES
from app.parameters import METHOD_LABELS, SessionParameters
from app.player import SAMPLE_DT
from app.resources import STATIC
from app.session import MECHANISM_HELP, Session, chain_help
from conftest import wait_until
from physics import LinkageError, Settings
from physics.codegen import cache as codegen_cache
from physics.mechanism.parameters import structure_key
from physics.model import MAX_LINKS


@pytest.fixture
def host(in_process):
    """``host(preset)``: a chain preset hosted by a mechanism session on a viser server of its own."""
    opened: list[tuple[Session, viser.ViserServer]] = []

    def _host(preset: str, links: int | None = None, autoplay: bool = True) -> Session:
        params = SessionParameters.from_preset(preset, links=links)
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        session = Session.for_chain(server, params, shared=True, autoplay=autoplay)
        opened.append((session, server))
        assert session.player.wait_idle(120), "the first start was not shown"
        return session

    yield _host
    for session, server in opened:
        session.close(clean=True)
        server.stop()


def _played(session: Session, seconds: float) -> None:
    session.play()
    start = session.player.display_time
    assert wait_until(lambda: session.player.display_time > start + seconds, timeout=120), session.notices.text


def _paused_state(session: Session):
    session.pause()
    assert session.player.wait_idle(60)
    spec, t, q, qdot = session.player.current_start()
    return spec, t, q, qdot


def _edited(preset: str, edits: list[tuple[str, str]]) -> SessionParameters:
    """The chain session's parameters after the same edits (app/commands.py, as its panel applies them)."""
    params = SessionParameters.from_preset(preset)
    for name, text in edits:
        params = commands.apply(params, name, text, CONTROL).params
    return params


# ---------------------------------------------------------------------------------------------- the knobs
def test_every_chain_knob_is_there_by_the_chains_name_and_range(host):
    session = host("triple-a")
    params = session.chain
    names = [knob.name for knob in session.panel_knobs()]
    expected = {"g", "damping", *(f"{f}{k}" for f in "LdmI" for k in (1, 2, 3)),
                *(f"{f}{k}" for f in ("theta", "omega") for k in (1, 2, 3)), "rtol", "step"}
    assert expected <= set(names) and len(names) == len(set(names))
    assert not {"pin_x", "pin_y", "links"} & set(names)  # an open chain of a fixed size
    for knob in session.panel_knobs():
        assert knob.name in session._knob_handles and knob.name in session._typed_boxes, knob.name
        key, k = commands.split_name(knob.name)
        if key in BAR_SLIDERS:  # the chain panel's slider range, the model's typed range, the value in force
            spec = BAR_SLIDERS[key]
            lo, lo_open, hi, _ = QUANTITIES[key].bounds()
            assert knob.low == spec.range()[0] and knob.step == spec.step
            assert knob.allowed == (lo, params.L[k - 1] if key == "d" else hi) and knob.low_open == lo_open
            assert knob.value == getattr(params.chain.bars[k - 1], key)
            assert knob.label.endswith(f"{QUANTITIES[key].label} ({QUANTITIES[key].unit})")
    by_name = {knob.name: knob for knob in session.panel_knobs()}
    assert by_name["theta2"].value == pytest.approx(math.degrees(params.theta0[1]))
    assert by_name["theta1"].label == "theta1 (°)" and by_name["omega1"].label == "omega1 (°/s)"
    assert by_name["g"].value == params.g and by_name["g"].label == "gravity g (m/s²)"
    # the Method menu offers the chain's methods this session runs; others are refused naming the allowed ones
    assert list(session.method.options) == ["Newton-Euler", "Lagrange", "DAE"]
    with pytest.raises(LinkageError, match=r"method = 'reduced': allowed values newton_euler, lagrange, dae"):
        session.set_method("reduced")


def _moved(handle, value) -> None:
    """What viser does with a browser's update of ``handle``: the value stored, then every callback."""
    handle._impl.value = value
    for callback in list(handle._impl.update_cb):
        callback(None)


def test_the_panels_own_sliders_and_boxes_edit_the_chain(host):
    session = host("triple-a")
    _moved(session._knob_handles["m1"], 2.0)
    assert session.chain.m[0] == 2.0 and session.mechanism.bodies[0].mass == 2.0
    _moved(session._knob_handles["theta2"], 25.0)  # degrees, as the slider shows them
    assert session.chain.theta0[1] == pytest.approx(math.radians(25.0))
    for text, expected in (("2.5e1", 25.0), ("1,5", None)):
        commits = session.typed_commits
        _moved(session._typed_boxes["g"], text)
        assert wait_until(lambda: session.typed_commits > commits, timeout=30)
        if expected is not None:
            assert session.chain.g == expected and session.mechanism.g == expected and session.notices.text is None
        else:  # read as the chain panel reads it: refused in its words, the value in force kept
            with pytest.raises(LinkageError) as error:
                commands.apply(session.chain, "g", text, CONTROL)
            assert session.notices.text == f"Not applied: {error.value}" and session.chain.g == 25.0
            assert session._typed_boxes["g"].value == "25"


def test_a_four_bar_has_its_pin_its_driving_angle_and_its_reach(host):
    session = host("four-bar")
    names = {knob.name for knob in session.panel_knobs()}
    assert {"pin_x", "pin_y", "theta1", "omega1"} <= names
    # assembled by the loop closure: shown greyed, never set
    follows = {knob.name for knob in session.panel_knobs() if knob.follows}
    assert follows == {"theta2", "theta3", "omega2", "omega3"}
    assert all(session._knob_handles[name].disabled for name in follows)  # noqa: SLF001
    assert not follows & set(session._typed_boxes)  # noqa: SLF001 - nothing to type
    assert reach_text(session.chain) in session.facts.content
    assert "Reduced (1 dof)" in session.method.options
    # the start shown is the chain's own, the loop closed: every angle of q is the chain's theta0
    theta, _ = chain_angles(session.chain, session.q0, session.qdot0)
    assert np.allclose(theta, session.chain.theta0, atol=1e-12)


def test_the_number_of_bars_loads_that_chain_preset(host):
    session = host("chain")
    knob = next(k for k in session.panel_knobs() if k.name == "links")
    assert knob.allowed == (1.0, float(MAX_LINKS))
    session.set_method("dae")
    session.set("links", 5)
    assert session.chain.n == 5 and len(session.mechanism.bodies) == 5
    assert {"L5", "theta5"} <= {k.name for k in session.panel_knobs()}
    assert session.settings.method == "dae" and session.chain.method == "dae"  # the choice in force is kept
    assert session.link_query() == share.link_query(session.chain) and "links=5" in session.link_query()
    other = host("triple-a", autoplay=False)
    with pytest.raises(LinkageError, match="links: only the 'chain' mechanism has a variable number of bars"):
        other.set("links", 4)


# ---------------------------------------------------------------------------------------------- edits
def test_physical_edits_go_on_from_the_displayed_state_without_a_new_structure(host):
    session = host("triple-a")
    _played(session, 0.3)
    key = structure_key(session.mechanism)
    loaded = set(codegen_cache._loaded)
    for name, value in (("L1", 1.3), ("m2", 2.5), ("g", 4.0), ("damping", 0.2), ("d3", 0.4), ("I1", 0.05)):
        _, t, q, qdot = _paused_state(session)
        theta, omega = chain_angles(session.chain, q, qdot)
        session.set(name, value)
        assert session.player.wait_idle(60)
        spec, t_after, q_after, qdot_after = session.player.current_start()
        assert t_after == pytest.approx(t, abs=1e-12) and t_after > 0.0  # went on, not back to t = 0
        theta_after, omega_after = chain_angles(session.chain, q_after, qdot_after)
        assert np.allclose(theta_after, theta, atol=1e-12) and np.allclose(omega_after, omega, atol=1e-12), name
        assert structure_key(spec.chain) == key, name
        _played(session, 0.1)
    mechanism = session.mechanism
    assert math.dist(*mechanism.bodies[0].points.values()) == pytest.approx(1.3)
    assert mechanism.bodies[1].mass == 2.5 and mechanism.g == 4.0
    assert all(joint.damping == 0.2 for joint in mechanism.joints)
    assert session.player.runs[0].spec.chain == mechanism  # the run is of the new numbers
    assert set(codegen_cache._loaded) == loaded  # no system derived or compiled for any edit
    assert session.player.runs[0].failed is None


def test_a_four_bars_new_lengths_or_pin_go_on_from_the_displayed_state_on_the_new_loop(host):
    session = host("four-bar")
    _played(session, 0.3)
    key = structure_key(session.mechanism)
    for name, value in (("L3", 2.05), ("pin_x", session.chain.pin[0] + 0.01)):
        _, t, q, qdot = _paused_state(session)
        theta, _ = chain_angles(session.chain, q, qdot)
        session.set(name, value)
        assert session.player.wait_idle(60)
        spec, t_after, q_after, qdot_after = session.player.current_start()
        params = session.chain
        theta_after, omega_after = chain_angles(params, q_after, qdot_after)
        assert t_after == pytest.approx(t, abs=1e-12) and t_after > 0.0, name
        assert theta_after[0] == pytest.approx(theta[0], abs=1e-12), name  # the driving angle kept
        gap = physics.loop_closure.loop_residual(params.L, theta_after, params.pin)
        assert float(np.hypot(*gap)) < 1e-9, name  # the others close the new loop
        assert structure_key(spec.chain) == key, name
        _played(session, 0.1)
    assert session.player.runs[0].failed is None


def test_a_start_angle_starts_again_at_zero_from_the_typed_degrees(host):
    session = host("triple-a")
    _played(session, 0.3)
    session.set_link_value("theta1", "40")
    session.set_link_value("omega2", "-90")
    assert session.player.wait_idle(60)
    ring = session.player.runs[0].ring
    assert ring.t_first == 0.0
    q0, qdot0 = ring.get("q", 0), ring.get("qdot", 0)
    assert q0[2] == pytest.approx(math.radians(40.0), abs=1e-12)
    assert qdot0[5] == pytest.approx(math.radians(-90.0), abs=1e-12)
    assert session.chain.theta0[0] == pytest.approx(math.radians(40.0))

    four = host("four-bar")
    theta1 = math.degrees(four.chain.theta0[0]) - 10.0
    four.set_link_value("theta1", f"{theta1}")
    assert four.player.wait_idle(60)
    q0 = four.player.runs[0].ring.get("q", 0)
    assert math.degrees(q0[2]) == pytest.approx(theta1, abs=1e-9)
    assert np.allclose(q0[2::3], four.chain.theta0, atol=1e-12)  # the others assembled by the loop closure
    gap = physics.loop_closure.loop_residual(four.chain.L, four.chain.theta0, four.chain.pin)
    assert float(np.hypot(*gap)) < 1e-9


@pytest.mark.parametrize("preset, name, text", [
    ("triple-a", "L1", "-1"),
    ("triple-a", "theta1", "nan"),
    ("triple-a", "m2", "1,5"),
    ("four-bar", "pin_x", "50"),
    ("four-bar", "theta1", "30"),
])
def test_a_refused_value_is_one_notice_in_the_chain_panels_words(host, preset, name, text):
    session = host(preset)
    with pytest.raises(LinkageError) as expected:
        commands.apply(session.chain, name, text, CONTROL)
    before = session.link_query()
    session.guard(lambda: session.set_typed(name, text))
    assert session.notices.text == f"Not applied: {expected.value}"
    assert name in str(expected.value)
    assert session.link_query() == before  # nothing changed
    _played(session, 0.2)  # and the session goes on


def test_a_hosted_chains_link_is_the_chain_sessions(host):
    edits = [("L1", "1.25"), ("m2", "2"), ("g", "5.5"), ("damping", "0.05"), ("theta1", "35"), ("omega3", "20"),
             ("rtol", "1e-10")]
    session = host("triple-a")
    for name, text in edits:
        session.set_link_value(name, text)
    session.set_method("dae")
    session.set_stabilization("baumgarte")
    expected = _edited("triple-a", [*edits, ("method", "dae"), ("stabilization", "baumgarte")])
    assert session.link_query() == share.link_query(expected)
    assert session.setup_pairs() == urllib.parse.parse_qsl(session.link_query()[1:])
    # the same setup loaded into another hosted session gives the same link
    other = host("triple-a", autoplay=False)
    other.load_setup(session.setup_pairs())
    assert other.notices.text is None and other.link_query() == session.link_query()
    # snapshot --set speaks SI, as python -m physics --set
    other.set_value("theta1", f"{math.radians(10.0)!r}")
    assert other.chain.theta0[0] == pytest.approx(math.radians(10.0))

    four = host("four-bar")
    four.set_link_value("pin_x", f"{four.chain.pin[0] + 0.05}")
    four.set_link_value("L2", "1.05")
    expected = _edited("four-bar", [("pin_x", f"{SessionParameters.from_preset('four-bar').pin[0] + 0.05}"),
                                    ("L2", "1.05")])
    assert four.link_query() == share.link_query(expected)
    # a setup naming another chain preset loads that preset here, then its values (the integration choices in
    # force kept unless it names them, as the chain session's load_setup)
    third = host("triple-a", autoplay=False)
    third.load_setup(four.setup_pairs())
    assert third.chain.preset == "four-bar" and third.link_query() == four.link_query()
    assert {"pin_x", "theta1"} <= {knob.name for knob in third.panel_knobs()}
    other.load_setup(four.setup_pairs())
    assert other.chain.preset == "four-bar" and other.settings.method == "dae" and other.chain.damping == 0.05
    # the saved file is the chain's pairs, no mechanism description (it reopens as the chain preset)
    saved = share.setup_from_state(four.setup_document(), "the test's setup")
    assert saved.mechanism is None and saved.preset == "four-bar" and saved.pairs == four.setup_pairs()


def test_a_centre_of_mass_slider_ends_at_its_bars_length(host):
    session = host("triple-a", autoplay=False)
    session.set("L2", 0.6)
    assert session.chain.d[1] <= 0.6  # pulled in by the chain's command layer
    handle = session._knob_handles["d2"]
    assert handle.max == pytest.approx(0.6) and session._typed_boxes["d2"].value == f"{session.chain.d[1]:.6g}"


# ---------------------------------------------------------------------------------------------- the physics
@pytest.mark.parametrize("damping", ["0", "0.3"])
@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
def test_the_hosted_run_is_the_chain_engines(host, preset, damping):
    """theta from the hosted run's q against physics.simulate's Trajectory.theta, same settings (the joints'
    damping too), over 2 s."""
    session = host(preset, autoplay=False)
    session.set_link_value("rtol", "1e-10")
    session.set_link_value("damping", damping)
    assert session.goto_time(2.0, timeout=300), session.notices.text
    ring = session.player.runs[0].ring
    count = int(round(2.0 / ring.dt)) + 1
    window = ring.window(0, count - 1, ["t", "q", "qdot"])
    theta, omega = chain_angles(session.chain, window["q"], window["qdot"])
    params = session.chain
    settings = Settings(method=params.method, integrator="DOP853", rtol=1e-10, atol=1e-10, damping=float(damping),
                        t_end=float(window["t"][-1]), samples=len(window["t"]), trace=params.trace)
    reference = physics.simulate(params.chain, params.theta0, params.omega0, settings)
    assert np.allclose(window["t"], reference.t, atol=1e-12)
    error = float(np.max(np.abs(theta - reference.theta)))
    assert error < 1e-7, f"{preset}: largest theta difference {error:.2e} rad"
    q0, _ = hosted_start(params)
    assert np.allclose(window["q"][0], q0, atol=1e-12)


def test_a_hosted_chain_gives_way_to_a_mechanism_preset_and_back(host):
    """The menu: another chain preset is hosted here; a mechanism preset gets its own knobs and keeps its traced
    point (the trace menu's new options no longer reset it to none); its link is the mechanism's."""
    session = host("triple-a")
    session.choose("four-bar")
    assert session.chain is not None and session.chain.preset == "four-bar" and session.label == "four-bar"
    assert "pin_x" in {knob.name for knob in session.panel_knobs()}
    session.choose("triple-b")
    assert session.settings.trace == "bar3.D" and session.trace_menu.value == "tip H"  # the chain's tip
    session.choose("slider-crank")
    assert session.chain is None and session.label == "slider-crank"
    _played(session, 0.3)  # the menus' callbacks (viser's, when a value left its options) have run meanwhile
    mechanism = session.mechanism
    assert session.settings.trace == mechanism.trace and session.trace_menu.value == mechanism.trace
    assert session.link_query() == "?preset=slider-crank"
    assert {f"mass:{body.name}" for body in mechanism.bodies} <= {knob.name for knob in session.panel_knobs()}


# ---------------------------------------------------------------------------------------------- what it hands out
# the chain session's snapshot keys, in its order (docs/app.md, "snapshot()"; app/readout.py snapshot_document)
CHAIN_SNAPSHOT_KEYS = ["session", "shared", "parameters", "method", "compare", "playing", "speed", "time", "theta",
                       "omega", "joints", "energy", "runs", "reference", "notice", "frames_sent", "scene"]
RUN_KEYS = ["label", "method", "t", "theta", "omega", "joints", "trace_xy", "samples_stored", "simulated_until",
            "failed"]


@pytest.mark.parametrize("preset", ["triple-a", "four-bar"])
def test_a_hosted_chains_snapshot_is_the_chain_sessions(host, preset):
    session = host(preset, autoplay=False)
    session.set_link_value("m2", "1.5")
    assert session.goto_time(0.5, timeout=120), session.notices.text
    shot = session.snapshot()
    assert list(shot) == CHAIN_SNAPSHOT_KEYS
    params = session.chain
    assert shot["parameters"] == params.as_dict() and shot["method"] == params.method
    assert shot["session"] == session.id and shot["compare"] is False and shot["reference"] is None
    assert [list(run) for run in shot["runs"]] == [RUN_KEYS] and shot["runs"][0]["label"] == "main"
    # the chain's angles at the time shown, from the run's own q
    ring = session.player.runs[0].ring
    i = ring.index_at(session.player.display_time)
    theta, omega = chain_angles(params, ring.get("q", i), ring.get("qdot", i))
    assert shot["time"] == pytest.approx(0.5, abs=1e-9)
    assert np.allclose(shot["theta"], theta, atol=1e-12) and np.allclose(shot["omega"], omega, atol=1e-12)
    joints = physics.kinematics.joint_positions(params.L, theta[None, :])[0]
    assert np.allclose(shot["joints"], joints, atol=1e-12)
    expected_energy = {"kinetic", "potential", "total", "reference", "relative_drift"} | (
        {"constraint_error"} if params.pinned else set())
    assert set(shot["energy"]) == expected_energy
    assert shot["energy"]["total"] == pytest.approx(float(ring.get("energy", i)))
    assert list(shot["scene"]) == ["root", "nodes", "names"] and shot["scene"]["names"] == sorted(shot["scene"]["nodes"])
    assert shot["scene"]["root"] == "/linkage" and shot["scene"]["nodes"]
    assert shot["energy"]["reference"] == pytest.approx(float(ring.get("energy", 0)))
    # after an edit that goes on, the drift is measured from the energy at the edit, as the chain view's
    _, t_edit, _, _ = _paused_state(session)
    session.set("m1", 1.25)
    _played(session, 0.2)
    session.pause()
    ring = session.player.runs[0].ring
    assert session.snapshot()["energy"]["reference"] == pytest.approx(float(ring.get("energy", ring.index_at(t_edit))))
    assert t_edit > 0.0 and ring.t_first < t_edit


@pytest.mark.parametrize("preset", ["double", "four-bar"])
def test_a_hosted_chains_downloads_are_the_chain_sessions(host, preset):
    session = host(preset, autoplay=False)
    session.set_method("dae")
    assert session.goto_time(0.5, timeout=120), session.notices.text
    params = session.chain
    stem = f"linkage-{preset}-dae"
    name, csv = session.download_file("csv")
    assert name == f"{stem}.csv"
    history = session.history()
    header = csv.decode().splitlines()[0].split(",")
    assert header == list(export.columns(history, "dae", params.pinned))
    assert header[:1 + 2 * params.n] == ["t", *(f"theta{k}" for k in range(1, params.n + 1)),
                                         *(f"omega{k}" for k in range(1, params.n + 1))]
    rows = csv.decode().splitlines()[1:]
    assert len(rows) == len(history["t"]) and len(rows) == int(round(0.5 / SAMPLE_DT)) + 1
    name, content = session.download_file("json")
    assert name == f"{stem}.json" and json.loads(content)["description"] == session.run_label()
    name, page = session.download_file("html")
    assert name == f"{stem}-replay.html" and page.startswith(b"<!")
    name, setup = session.download_file("setup")
    assert name == f"linkage-{preset}-setup.json" and setup == share.state_document(params)
    with pytest.raises(LinkageError, match="download = 'pdf': allowed csv, json, html, setup, tex"):
        session.download_file("pdf")


def test_the_chain_sessions_history_and_exports_on_a_hosted_chain(host):
    session = host("four-bar", autoplay=False)
    assert session.goto_time(0.4, timeout=120), session.notices.text
    history = session.history()
    ring = session.player.runs[0].ring
    theta, omega = chain_angles(session.chain, ring.window(0, len(history["t"]) - 1)["q"],
                                ring.window(0, len(history["t"]) - 1)["qdot"])
    assert np.allclose(history["theta"], theta, atol=1e-12) and np.allclose(history["omega"], omega, atol=1e-12)
    assert {"tip_reaction", "constraint_xy", "reactions", "joints"} <= set(history)
    params = session.chain
    assert session.run_label() == f"four-bar (3 bars), {METHOD_LABELS[params.method]}, {params.integrator}"
    assert session.export_csv() == session.download_file("csv")[1]
    assert session.export_json() == session.download_file("json")[1]
    assert session.export_html() == session.download_file("html")[1].decode("utf-8")
    assert session.export_html.label == "Save HTML replay"  # and it is still the panel's button
    mechanism = host("triple-a", autoplay=False)
    mechanism.choose("slider-crank")
    for call in (mechanism.history, mechanism.run_label, mechanism.export_csv, mechanism.export_json,
                 mechanism.export_html):
        with pytest.raises(LinkageError, match="applies to a chain preset only; 'slider-crank' is a mechanism"):
            call()


# ---------------------------------------------------------------------------------------------- the traced point
def _trace_of(params: SessionParameters, q: np.ndarray) -> np.ndarray:
    """The chain's traced point of hosted states ``q``, by the chain's own kinematics."""
    theta, _ = chain_angles(params, q, np.zeros_like(q))
    point = params.trace
    return physics.kinematics.point_on_bar(params.L, theta, point.bar, point.along, point.across)


def test_the_four_bar_traces_its_coupler_curve(host):
    session = host("four-bar", autoplay=False)
    params = session.chain
    assert params.trace == params.default_trace and params.trace.across != 0.0  # off the bar: no named point
    assert list(session.trace_menu.options) == list(params.trace_choices())
    assert session.trace_menu.value == "coupler point"
    assert session.goto_time(1.5, timeout=120), session.notices.text
    ring = session.player.runs[0].ring
    stored = ring.window(0, len(ring) - 1, ["q", "trace_xy", "joints"])
    assert np.allclose(stored["trace_xy"], _trace_of(params, stored["q"]), atol=1e-12)
    # a curve of its own: away from every drawn point's path (joints, centres), and it moves
    gaps = np.hypot(*(stored["joints"] - stored["trace_xy"][:, None, :]).transpose(2, 0, 1))
    assert float(gaps.min()) > 0.1
    assert float(np.ptp(stored["trace_xy"], axis=0).max()) > 0.05
    # the line drawn is that path over the trace length
    shown = ring.index_at(session.player.display_time)
    window = session._trace_window(ring, session.player.display_time, shown)
    assert len(window) > 2 and np.allclose(window, stored["trace_xy"][: shown + 1][-len(window):], atol=1e-12)
    assert session.snapshot()["runs"][0]["trace_xy"] == pytest.approx(list(stored["trace_xy"][shown]), abs=1e-12)


def test_choosing_the_traced_point_goes_on_without_a_new_structure(host):
    session = host("triple-a")
    _played(session, 0.3)
    key = structure_key(session.mechanism)
    loaded = set(codegen_cache._loaded)
    _, t, _, _ = _paused_state(session)
    session.trace_menu.value = "centre of mass 2"  # the menu's own callback, as a browser's choice
    assert session.notices.text is None and session.trace_menu.value == "centre of mass 2"
    assert session.player.wait_idle(60)
    spec, t_after, _, _ = session.player.current_start()
    assert t_after == pytest.approx(t, abs=1e-12) and structure_key(spec.chain) == key
    _played(session, 0.2)
    params = session.chain
    assert params.trace == params.trace_choices()["centre of mass 2"]
    ring = session.player.runs[0].ring
    first = ring.index_at(t_after + 0.05)
    stored = ring.window(first, len(ring) - 1, ["q", "trace_xy"])
    assert np.allclose(stored["trace_xy"], _trace_of(params, stored["q"]), atol=1e-12)
    assert set(codegen_cache._loaded) == loaded  # nothing derived or compiled
    # the link is the chain session's (which leaves the traced point out), and a link's trace= is read as its
    assert session.link_query() == share.link_query(_edited("triple-a", [("trace", "centre of mass 2")]))
    other = host("triple-a", autoplay=False)
    other.load_setup([("preset", "triple-a"), ("trace", "centre of mass 2")])
    assert other.notices.text is None and other.chain.trace == params.trace
    assert other.trace_menu.value == "centre of mass 2"
    with pytest.raises(LinkageError, match="traced point = 'bar9.D': allowed tip H, joint 1"):
        session.set_trace("bar9.D")


# ---------------------------------------------------------------------------------------------- labels and help
def test_a_hosted_chains_plots_and_help_are_the_chain_panels(host):
    session = host("triple-a")
    assert session.help.content == (STATIC / "help.md").read_text(encoding="utf-8") == chain_help()
    assert tuple(session.plot_choice.options) == CHAIN_PLOT_CHOICES
    session.plot_choice.value = "Angles θ(t)"  # the menu's own callback, as a browser's choice
    assert session.plot_kind == "angles" and session.notices.text is None
    plot = session.coordinate_plot
    assert plot is not None and plot.labels == ["θ1", "θ2", "θ3"] and plot.handle.title == "Angles"
    _played(session, 0.5)
    assert wait_until(lambda: plot.points_shown > 2, timeout=30)
    t, *angles = plot.handle.data
    ring = session.player.runs[0].ring
    i = ring.index_at(float(t[-1]))
    theta, _ = chain_angles(session.chain, ring.get("q", i), ring.get("qdot", i))
    assert float(ring.get("t", i)) == pytest.approx(float(t[-1]), abs=1e-9)
    assert np.allclose([a[-1] for a in angles], np.degrees(theta), atol=1e-9)  # degrees, every bar
    words = f"{METHOD_LABELS[session.params.method]} · {session.params.integrator}"  # the chain view's status
    assert wait_until(lambda: words in session.status.content, timeout=30), session.status.content
    starts = {knob.name: knob.label for knob in session._start_knobs()}
    assert starts == {**{f"theta{k}": f"theta{k} (°)" for k in (1, 2, 3)},
                      **{f"omega{k}": f"omega{k} (°/s)" for k in (1, 2, 3)}}
    session.choose("slider-crank")  # a mechanism: its own help, plot menu and coordinates
    assert session.help.content == MECHANISM_HELP
    assert tuple(session.plot_choice.options) == MECHANISM_PLOT_CHOICES
    assert session.plot_choice.value == "Coordinates over time" and session.plot_kind == "angles"
    assert session.coordinate_plot is not None and session.coordinate_plot.handle.title == "Coordinates"
    session.set_mechanism("four-bar")  # a chain preset is hosted here again
    assert session.help.content == chain_help() and session.plot_choice.value == "Angles θ(t)"


# ---------------------------------------------------------------------------------------------- the chain session's API
def test_params_setup_notice_and_set_in_si_or_control_units(host):
    session = host("triple-a", autoplay=False)
    assert session.params is session.chain and session.setup is session.chain
    session.set("theta1", math.radians(30.0))  # SI by default, as python -m physics --set
    assert session.params.theta0[0] == pytest.approx(math.radians(30.0))
    session.set("theta1", "45", units=CONTROL)  # the panel's degrees
    assert session.params.theta0[0] == pytest.approx(math.radians(45.0))
    session.set("step", 2.0, units=CONTROL)  # milliseconds in the panel, seconds in SI
    assert session.params.step == pytest.approx(2e-3)
    session.set("step", 1e-3)
    assert session.params.step == pytest.approx(1e-3)
    session.set("speed", 2.0)  # a display setting
    assert session.display.speed == 2.0
    with pytest.raises(LinkageError) as expected:
        commands.apply(session.params, "L1", -1.0, commands.SI)
    with pytest.raises(LinkageError, match=re.escape(str(expected.value))):
        session.set("L1", -1.0)
    assert session.notice is None
    session.guard(lambda: session.set("L1", -1.0))
    assert session.notice == session.notices.text == f"Not applied: {expected.value}"
    session.choose("slider-crank")
    for name in ("params", "setup"):
        with pytest.raises(LinkageError, match=f"{name}: applies to a chain preset only"):
            getattr(session, name)


def test_set_start_displayed_state_and_state_at_in_the_chains_terms(host):
    session = host("double", autoplay=False)
    theta0, omega0 = np.array([0.4, -0.2]), np.array([0.1, 0.3])
    session.set_start(theta0, omega0)
    assert np.array_equal(session.params.theta0, theta0) and np.array_equal(session.params.omega0, omega0)
    assert session.player.wait_idle(60) and not session.player.playing  # paused unless play
    t, theta, omega = session.displayed_state()
    assert t == 0.0 and np.allclose(theta, theta0, atol=1e-12) and np.allclose(omega, omega0, atol=1e-12)
    assert session.goto_time(0.5, timeout=120)
    t, theta, omega = session.displayed_state()
    ring = session.player.runs[0].ring
    i = ring.index_at(t)
    expected = chain_angles(session.params, ring.get("q", i), ring.get("qdot", i))
    assert t == pytest.approx(0.5, abs=1e-9)
    assert np.allclose(theta, expected[0], atol=1e-12) and np.allclose(omega, expected[1], atol=1e-12)
    exact = session.state_at(float(ring.get("t", i)), exact=True)
    assert exact is not None and np.allclose(exact[0], expected[0], atol=1e-12)
    between = session.state_at(float(ring.get("t", i)) - 0.5 * SAMPLE_DT)
    assert between is not None and len(between[0]) == 2 and session.state_at(0.1234, exact=True) is None
    with pytest.raises(LinkageError):
        session.set_start([0.1], [0.0])  # one angle for two bars: refused by the chain's models
    assert np.array_equal(session.params.theta0, theta0)
    session.set_start(theta0, omega0, play=True)
    assert wait_until(lambda: session.player.playing and session.player.display_time > 0.1, timeout=60)
    session.choose("slider-crank")
    with pytest.raises(LinkageError, match="set_start: applies to a chain preset only"):
        session.set_start(theta0, omega0)


def test_set_mechanism_and_set_links(host):
    session = host("triple-a", autoplay=False)
    session.set_method("dae")
    session.set_mechanism("chain", links=4)
    assert session.params.preset == "chain" and session.params.n == 4 and session.params.method == "dae"
    session.set_links(6)
    assert session.params.n == 6 and len(session.mechanism.bodies) == 6
    session.set_mechanism("jansen-leg")
    assert session.chain is None and session.label == "jansen-leg"
    with pytest.raises(LinkageError, match="links: only the 'chain' mechanism has a variable number of bars"):
        session.set_links(3)
    session.set_mechanism("four-bar")
    assert session.params.preset == "four-bar" and session.label == "four-bar" and session.menu.value == "four-bar"
    with pytest.raises(LinkageError, match="mechanism = 'nope': allowed .*triple-a.*jansen-leg"):
        session.set_mechanism("nope")


# ---------------------------------------------------------------------------------------------- compare mode
def test_compare_mode_of_a_hosted_chain_runs_three_formulations_and_measures_the_chains_traced_point(host):
    session = host("four-bar", autoplay=False)
    session.set_compare(True)
    _played(session, 1.0)
    between = session.compare_view.between
    assert between is not None and wait_until(lambda: between.points_shown > 2, timeout=60)
    assert between.handle.title.startswith("Traced point coupler point: divergence")
    session.pause()
    assert session.player.wait_idle(60)
    shot = session.snapshot()
    assert list(shot) == CHAIN_SNAPSHOT_KEYS and shot["compare"] is True
    assert [run["label"] for run in shot["runs"]] == ["newton_euler", "lagrange", "dae"]
    assert [run["method"] for run in shot["runs"]] == ["newton_euler", "lagrange", "dae"]
    assert all(list(run) == RUN_KEYS and run["failed"] is None for run in shot["runs"])
    assert shot["reference"] is not None and shot["reference"]["label"] == "reference"
    params = session.chain
    for run in [*shot["runs"], shot["reference"]]:
        point = _trace_of(params, np.array([[0.0, 0.0, v] for v in run["theta"]]).reshape(1, -1))[0]
        assert np.allclose(run["trace_xy"], point, atol=1e-12), run["label"]
        # the formulations agree with the converged reference at the default tolerance
        assert np.allclose(run["theta"], shot["reference"]["theta"], atol=1e-4), run["label"]
    for run in session.player.runs:  # every ring traces the chain's point (the divergence is measured there)
        stored = run.ring.window(0, len(run.ring) - 1, ["q", "trace_xy"])
        assert np.allclose(stored["trace_xy"], _trace_of(params, stored["q"]), atol=1e-12), run.spec.label
    # the reference run's divergence read-out names every formulation (none parts visibly in a second)
    assert session.compare_view.passing_times() == {"newton_euler": None, "lagrange": None, "dae": None}


def test_any_preset_chosen_in_the_menu_is_shown_in_the_same_session(host):
    session = host("triple-a", autoplay=False)
    session.choose("slider-crank")
    assert session.chain is None
    session.choose("four-bar")  # the menu
    assert session.chain is not None and session.params.preset == "four-bar" and session.help.content == chain_help()
    session.choose("jansen-leg")
    edited = _edited("double", [("m2", "2.5"), ("theta1", "20")])
    session.open_setup(share.setup_from_state(share.state_document(edited), "the test's setup"))
    assert session.params.preset == "double" and session.link_query() == share.link_query(edited)
    assert session.notices.text is None


def test_the_fixed_coordinate_model_stops_at_the_four_bars_dead_centre_in_the_chains_words(host):
    """The menu's "Reduced, theta1 fixed" (the chain's key ``reduced_fixed``) on a hosted four-bar: the run stops
    where theta1 stops being a coordinate, and the notice says so as the chain panel did; Reset recovers."""
    session = host("four-bar")
    assert METHOD_LABELS["reduced_fixed"] in session.method.options
    session.method.value = METHOD_LABELS["reduced_fixed"]
    assert wait_until(lambda: session.params.method == "reduced_fixed", timeout=30)
    assert session.settings.method == "reduced_fixed" and session.settings.integrator == "DOP853"
    assert session.goto_time(10.0)
    assert wait_until(lambda: session.notice is not None and "collinear" in session.notice, timeout=120)
    notice = session.notice
    assert "theta1 stopped being a valid coordinate" in notice and "joint 'O'" not in notice
    assert "Reduced (1 dof)" in notice  # the fix, named as the menu names it
    snap = session.snapshot()
    assert 0.0 < snap["time"] < 10.0 and snap["runs"][0]["failed"] and not snap["playing"]
    session.reset()
    assert session.player.wait_idle(120)
    assert session.snapshot()["time"] == 0.0


def test_a_mechanisms_fixed_coordinate_model_is_named_for_what_it_keeps(host):
    """A general mechanism of mobility 1 offers the fixed-coordinate model too, labelled by what it keeps."""
    session = host("four-bar")
    session.choose("stephenson-six-bar")
    assert wait_until(lambda: session.chain is None, timeout=60)
    label = session.method.options[-1]
    assert label != METHOD_LABELS["reduced_fixed"] and "fixed" in label
    session.method.value = label
    assert wait_until(lambda: session.settings.method == "reduced_fixed", timeout=30)
    session.choose("four-bar")
    assert wait_until(lambda: session.chain is not None, timeout=60)
    assert METHOD_LABELS["reduced_fixed"] in session.method.options


def test_the_report_tab_replays_the_seed_reports_figures_for_chains_and_mechanisms(host):
    from app import report_view  # noqa: PLC0415

    session = host("triple-a")
    panel = session.seed_report
    assert panel.choice.value == report_view.FIGURES[0].label
    panel.choice.value = report_view.FIGURES[5].label
    picture = report_view.figure_html(report_view.FIGURES[5], report_view.SEED_REPORT_FOLDER, panel.document)
    assert wait_until(lambda: panel.figure.content == picture, timeout=10)
    session.choose("slider-crank")  # the course's figures stay: the report is the course's, whatever is shown
    assert wait_until(lambda: session.chain is None, timeout=60)
    assert session.seed_report.figure.content == picture


def test_the_next_value_applied_takes_down_a_refusal_and_leaves_other_notices(host):
    """Issue 26: a refusal's notice stayed on after the next valid value. A value applied after it takes it down;
    a notice of another kind (here a study's "Done") stays, and so does a refusal raised by the action itself."""
    session = host("triple-a")
    session.guard(lambda: session.set_typed("L1", "-1"))
    assert session.notices.text.startswith("Not applied: ") and "L1" in session.notices.text
    assert session.notices.showing == "Not applied"  # the notification in the browser
    in_force = repr(session.chain.chain.bars[0].L)
    session.guard(lambda: session.set_typed("L1", in_force))  # a control's echo of the value put back
    assert session.notices.showing == "Not applied", "an echo that applies nothing took the refusal down"
    session.guard(lambda: session.set_typed("L1", "1.2"))
    assert session.chain.chain.bars[0].L == pytest.approx(1.2)
    assert session.notices.text is None and session.notices.showing is None  # the status line and the browser
    session.guard(lambda: session.set_typed("m2", "1,5"))  # refused again: the new refusal is shown
    assert session.notices.text.startswith("Not applied: ") and "m2" in session.notices.text
    session.show_notice("Done", "work-precision chart of triple-a", color="green")
    session.guard(session.pause)  # an action applied that says nothing: only a refusal is taken down
    assert session.notices.text == "Done: work-precision chart of triple-a"
    _played(session, 0.2)
