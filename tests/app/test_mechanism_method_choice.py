"""The reduced model takes no stabilisation: choosing it after "none" or "baumgarte" must not stop the run.

The long property run over every control (tests/app/test_every_control.py, 10,000 examples) found it: with the
slider-crank's stabilisation on "none", choosing the reduced model started runs that the physics refused
("stabilization = 'none': does not apply to method 'reduced'"), and the simulation stopped.
"""

from __future__ import annotations

import pytest

from app.server import LabServer
from app.session import Session
from conftest import wait_until


@pytest.fixture(scope="module")
def crank_lab():
    server = LabServer(port=0, warm=False, preset="slider-crank")
    yield server
    server.stop()


def _moving(session, seconds: float = 0.3) -> bool:
    first = session.player.display_time
    return wait_until(lambda: session.player.display_time > first + seconds, timeout=60)


@pytest.mark.parametrize("stabilization", ["none", "baumgarte"])
def test_choosing_the_reduced_model_after_another_stabilisation_plays_on(crank_lab, connect, stabilization):
    _, session = connect(crank_lab)
    assert isinstance(session, Session) and session.mobility == 1
    session.guard(lambda: session.set_stabilization(stabilization))
    assert session.settings.stabilization == stabilization and session.notices.text is None
    session.guard(lambda: session.set_method("reduced"))
    assert session.notices.text is None, session.notices.text
    assert session.settings.method == "reduced" and session.settings.stabilization == "projection"
    assert session.stabilization.value == "projection"  # the menu shows what is in force
    assert wait_until(lambda: session.player.runs and session.player.runs[0].spec.settings.method == "reduced",
                      timeout=60)
    assert _moving(session)
    assert session.player.error is None and session.notices.text is None, session.notices.text
