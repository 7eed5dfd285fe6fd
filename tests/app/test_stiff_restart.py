"""A stiff start keeps the session answering: each integrator call is bounded, a restart is shown after about
one sample's worth of steps, and the run is not stopped for needing many steps.

Found by the 10,000-example control run (tests/app/test_every_control.py): random edits left a chain whose middle
bar has almost no inertia between heavy ones (I2 = 1.4e-7 kg·m², m2 = 6e-305 kg) moving at 12 rad/s with DOP853
at rtol 6e-12. One 0.25 s chunk then takes about 620,000 steps (40 s on a busy machine); the player, inside that
one call, applied no edit until it returned, and the test's next edit was not shown within 60 s.
"""

from __future__ import annotations

import numpy as np

import physics
from app.mechanism_runs import MechanismSpec

# The edits that made the stiff chain (SI units), in the order the control run made them.
STIFF = (
    ("L1", 2.402150296151124), ("L2", 2.762497101341757), ("L3", 1.0333333333333334),
    ("d1", 0.3162498183721603), ("d2", 1.6964532315260934), ("d3", 0.0),
    ("m1", 4.284740094480353), ("m2", 5.92462039343366e-305), ("m3", 0.0),
    ("I1", 0.17025221101954405), ("I2", 1.365131476751062e-07), ("I3", 0.9566712349507294),
    ("g", 2.9646696947888267), ("method", "lagrange"), ("integrator", "DOP853"),
    ("rtol", 5.994809562009449e-12), ("damping", 1.0766081671315602),
)
THETA0 = np.array([-1.99755354, 1.04719755, -3.14159265])
OMEGA0 = np.array([0.0, -12.58382391, -12.56637061])
STEPS_PER_CHUNK = 616_773  # what DOP853 needs for the first 0.25 s from this start (measured; about 41,000 per sample)


def test_a_stiff_start_is_shown_and_the_next_edit_too_with_bounded_integrator_calls(connect, monkeypatch):
    _, session = connect()
    calls: list[tuple[int | None, int, int]] = []  # (max_steps given, steps taken, status) of each call
    simulate = MechanismSpec.simulate  # each run's integrator call (the one session's runs carry their own)

    def counting(spec, mechanism, q0, qdot0, settings, **kw):
        traj = simulate(spec, mechanism, q0, qdot0, settings, **kw)
        calls.append((getattr(settings, "max_steps", None), traj.n_steps, traj.status))
        return traj

    monkeypatch.setattr(MechanismSpec, "simulate", counting)
    session.pause()
    for name, value in STIFF:
        session.set(name, value)
    assert session.player.wait_idle(120)
    notes: list[str] = []
    show = session.show_notice
    session.show_notice = lambda title, body, **kw: (notes.append(f"{title}: {body}"), show(title, body, **kw))
    del calls[:]
    session.set_start(THETA0, OMEGA0)  # the stiff start, at t = 0
    assert session.player.wait_idle(300), "the stiff start was never shown"
    run = session.player.runs[0]
    assert len(run.ring) > 1 and run.failed is None, (run.failed, notes)
    # each call was bounded: far fewer steps than the one 0.25 s chunk the player used to ask for
    assert calls and max(steps for _, steps, _ in calls) < STEPS_PER_CHUNK // 4, calls
    assert all(given is not None and given < physics.Settings().max_steps for given, _, _ in calls), calls

    session.set("I2", 0.3)  # an edit while the stiff run computes ahead: shown once the current call returns
    assert session.player.wait_idle(300), "the edit after the stiff start was never shown"
    assert session.params.chain.bars[1].I == 0.3
    assert session.player.runs[0].failed is None
    assert not [n for n in notes if n.startswith("Simulation stopped")], notes


def test_a_motion_too_stiff_to_play_stops_with_the_fix_and_radau_plays_it(connect):
    """A damped bar at the inertia floor (1e-9 kg·m² about its joint, 10 N·m·s of damping: a time constant of
    1e-10 s) needs tens of millions of explicit steps per sample. The player's step cap stops doubling at
    PLAYABLE_STEPS and the run stops saying so and naming the fix; the long control run saw the doubling go on to
    the run's max_steps instead, and the restart never shown. Radau (implicit) plays the same motion."""
    from app.player import PLAYABLE_STEPS  # noqa: PLC0415

    _, session = connect()
    session.set_mechanism("single")
    assert session.player.wait_idle(120)
    session.pause()
    for name, value in (("L1", 1.0), ("d1", 0.0), ("m1", 1.0), ("I1", 1e-9), ("damping", 10.0),
                        ("integrator", "DOP853")):
        session.set(name, value)
    session.set_start(np.array([1.0]), np.array([1.0]))
    assert session.player.wait_idle(300), "the stiff start was never shown"
    run = session.player.runs[0]
    assert run.failed is not None and run.failed.startswith("too stiff to play: DOP853 took"), run.failed
    steps = int(run.failed.split(" took ")[1].split(" steps")[0].replace(",", ""))
    assert PLAYABLE_STEPS <= steps < 2 * PLAYABLE_STEPS and "Radau" in run.failed, run.failed
    session.set("integrator", "Radau")
    session.set_start(np.array([1.0]), np.array([1.0]))
    assert session.player.wait_idle(300)
    run = session.player.runs[0]
    assert run.failed is None and len(run.ring) > 1, run.failed
