"""A picture framed on the pose (``snapshot --frame pose``) holds the trace too (issue 26: the default framing cut
the trace at the picture's edge): the disc it frames contains every drawn point of the trace."""

from __future__ import annotations

import numpy as np

from app import snapshot
from app.scene import pose_disc
from conftest import wait_until


def test_the_pose_framing_includes_the_drawn_trace(connect):
    _, session = connect()  # triple-a, its tip traced
    snapshot.show_time(session, 3.0)
    assert wait_until(lambda: session.trace.points_shown >= 2, timeout=30), "no trace drawn at t = 3 s"
    trace = session.trace.shown_xy
    joints = np.array(session.snapshot()["joints"], dtype=float).reshape(-1, 2)
    center, radius = pose_disc(joints)
    assert np.any(np.linalg.norm(trace - center, axis=1) > radius), "the trace reaches past the pose alone"
    center, radius = pose_disc(snapshot.pose_points(session))
    assert np.all(np.linalg.norm(trace - center, axis=1) <= radius + 1e-9)
