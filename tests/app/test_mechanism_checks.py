"""A mechanism that cannot run is refused wherever it enters, before anything shown changes
(physics/mechanism/validation.py through app.mechanism_runs.start_state): ``python -m app --mechanism FILE``
exits 2 with one line, a file chosen in the browser is one notice and the mechanism shown stays, an edit that
would make it unrunnable is refused with its range; and a state is never drawn or continued with a mechanism
it does not belong to."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.mechanism_edits import apply_edit
from app.player import SAMPLE_DT
from app.server import LabServer
from app.session import Session
from conftest import wait_until
from physics import LinkageError
from physics.mechanism import MECHANISM_PRESETS, Mechanism
from physics.mechanism.validation import check_runnable

ROOT = Path(__file__).resolve().parents[2]


def _rocker_with(change) -> dict:
    data = MECHANISM_PRESETS["crank-rocker"]().model_dump()
    change(data)
    return data


def _first_point(body: dict, xy) -> None:
    body["points"][next(iter(body["points"]))] = xy


# name, the description, words of the one line that refuses it
CANNOT_RUN = [
    ("unassemblable", _rocker_with(lambda d: _first_point(d["bodies"][1], [5.0, 5.0])),
     "cannot be assembled"),
    ("massless", _rocker_with(lambda d: [b.update(mass=0.0, inertia=0.0) for b in d["bodies"]]),
     "body 'crank': mass = 0 kg: allowed range 1e-06 <= mass <= 1e+06 kg"),
    ("tiny-mass", _rocker_with(lambda d: d["bodies"][1].update(mass=5e-324)),
     "body 'coupler': mass = 4.94066e-324 kg: allowed range 1e-06"),
    ("tiny-inertia", _rocker_with(lambda d: d["bodies"][2].update(inertia=5e-324)),
     "body 'rocker': inertia = 4.94066e-324 kg m^2: allowed range 1e-09"),
    ("fast-motor", _rocker_with(lambda d: d["drivers"][0].update(speed=1000.0)),
     "motor 'O2': speed = 1000 rad/s: allowed range -30 <= speed <= 30 rad/s"),
    ("far-point", _rocker_with(lambda d: d["bodies"][1]["points"].update(far=[1e300, 0.0])),
     "body 'coupler': point 'far' = [1e+300, 0] m: allowed coordinates"),
]
IDS = [row[0] for row in CANNOT_RUN]


@pytest.mark.parametrize("name, data, words", CANNOT_RUN, ids=IDS)
def test_the_check_refuses_each_kind_in_one_line(name, data, words):
    mechanism = Mechanism.model_validate(data)
    with pytest.raises(LinkageError) as refusal:
        check_runnable(mechanism, SAMPLE_DT)
    assert words in str(refusal.value) and "\n" not in str(refusal.value), str(refusal.value)


def test_every_preset_passes_the_check():
    for name, make in MECHANISM_PRESETS.items():
        check_runnable(make(), SAMPLE_DT)  # raises for a preset that could not run


@pytest.mark.parametrize("name, data, words", CANNOT_RUN[:3] + CANNOT_RUN[4:5], ids=IDS[:3] + IDS[4:5])
def test_python_m_app_refuses_a_file_that_cannot_run_before_serving(tmp_path, name, data, words):
    path = tmp_path / f"{name}.json"
    path.write_text(Mechanism.model_validate(data).model_dump_json())
    done = subprocess.run([sys.executable, "-m", "app", "--port", "0", "--processes", "1", "--mechanism", str(path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in done.stderr, done.stderr
    assert "serving" not in done.stdout


@pytest.fixture(scope="module")
def rocker_lab():
    server = LabServer(port=0, warm=False, preset="crank-rocker")
    yield server
    server.stop()


def _moving(session, seconds: float = 0.3) -> bool:
    first = session.player.display_time
    return wait_until(lambda: session.player.display_time > first + seconds, timeout=60)


def test_an_uploaded_file_that_cannot_run_leaves_the_mechanism_shown(rocker_lab, connect):
    _, session = connect(rocker_lab)
    assert isinstance(session, Session)
    shown, label = session.mechanism, session.label
    for name, data, words in CANNOT_RUN:
        content = Mechanism.model_validate(data).model_dump_json().encode()
        session.guard(lambda name=name, content=content: session.load_file(None, f"{name}.json", content))
        assert words in (session.notices.text or ""), (name, session.notices.text)
        assert session.mechanism is shown and session.label == label, name  # nothing replaced
    assert _moving(session) and session.player.error is None


def test_a_mass_or_inertia_too_small_to_compute_with_is_refused_and_the_session_goes_on(rocker_lab, connect):
    _, session = connect(rocker_lab)
    shown = session.mechanism
    for name, words in (("mass:coupler", "allowed range 1e-06 to"), ("inertia:rocker", "allowed range 1e-09 to")):
        session.guard(lambda name=name: session.set(name, 5e-324))
        assert words in (session.notices.text or ""), session.notices.text
    assert session.mechanism == shown
    assert _moving(session) and session.player.error is None
    # the bounds themselves are runnable values
    edited = apply_edit(shown, "mass:coupler", 1e-6, sample_interval=SAMPLE_DT)
    assert edited.body("coupler").mass == 1e-6


def test_a_state_of_another_mechanism_is_never_continued(rocker_lab, connect):
    """The race of a menu choice and a method within 0.3 s: the player's displayed state may still be the
    previous mechanism's when the method's edit asks for it. Simulated by handing the edit a Jansen leg's
    state (7 bodies) while the session holds a crank-rocker (3 bodies): the run starts again from the
    crank-rocker's own start instead of failing in points_at_poses."""
    _, session = connect(rocker_lab)
    jansen = MECHANISM_PRESETS["jansen-leg"]()
    from app.mechanism_runs import MechanismSettings, MechanismSpec, start_state  # noqa: PLC0415

    q, qdot, _ = start_state(jansen)
    foreign = MechanismSpec("main", jansen, MechanismSettings())
    player = session.player
    player.current_start = lambda: (foreign, 1.0, q, qdot)  # type: ignore[method-assign]
    player.current_state = lambda: (1.0, q, qdot)  # type: ignore[method-assign]  # the same, without its run
    try:
        session.guard(lambda: session.set_method("lagrange"))
    finally:
        del player.current_start, player.current_state  # the class's own again
    assert session.settings.method == "lagrange"
    assert session.player.wait_idle(60)
    assert _moving(session) and session.player.error is None, session.player.error
    assert "Simulation stopped" not in (session.notices.text or ""), session.notices.text
    start = session.player.current_start()
    assert start is not None and np.shape(start[2]) == (3 * len(session.mechanism.bodies),)


def test_a_menu_choice_and_a_method_together_keep_the_run_going(rocker_lab, connect):
    """The same race through the session's own entry points, on threads as viser's callbacks run."""
    import threading  # noqa: PLC0415

    _, session = connect(rocker_lab)
    for name, method in (("jansen-leg", "lagrange"), ("slider-crank", "newton_euler"), ("crank-rocker", "dae"),
                         ("watt-six-bar", "lagrange"), ("chebyshev-lambda", "dae")):
        chooser = threading.Thread(target=lambda name=name: session.guard(lambda: session.choose(name)))
        chooser.start()
        session.guard(lambda method=method: session.set_method(method))
        chooser.join(60)
        assert session.player.wait_idle(60)
        assert session.player.error is None and "Simulation stopped" not in (session.notices.text or ""), (
            name, method, session.notices.text)
    assert _moving(session)
