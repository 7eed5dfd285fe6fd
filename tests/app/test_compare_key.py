"""Compare mode: three opaque mechanisms in distinct colours, apart in depth, with a colour key in the scene."""

from __future__ import annotations

from app.frame_view import COMPARE_METHODS
from app.overlays import METHOD_COLORS
from app.parameters import METHOD_LABELS
from conftest import wait_until


def test_compare_mode_draws_a_colour_key_and_opaque_runs(connect):
    _, session = connect()
    session.set_compare(True)
    assert wait_until(lambda: session.compare and len(session.view.compare_scenes) == 3, timeout=60)
    names = [handle.name for handle in session.view._compare_key]  # noqa: SLF001 - the view's own nodes
    for method in COMPARE_METHODS:
        assert f"/compare_key/{method}/ball" in names and f"/compare_key/{method}/name" in names
        assert session.view.compare_scenes[method].opacity is None  # opaque: no blend into one colour
    labels = [handle.text for handle in session.view._compare_key if hasattr(handle, "text")]  # noqa: SLF001
    assert labels == [METHOD_LABELS[m] for m in COMPARE_METHODS]
    balls = [handle for handle in session.view._compare_key if not hasattr(handle, "text")]  # noqa: SLF001
    assert [tuple(int(c) for c in ball.color) for ball in balls] == [METHOD_COLORS[m] for m in COMPARE_METHODS]
    depths = [session.view._compare_frames[m].position[1] for m in COMPARE_METHODS]  # noqa: SLF001
    assert depths[0] < depths[1] < depths[2]
    session.set_compare(False)
    assert wait_until(lambda: not session.view._compare_key and not session.view._compare_frames, timeout=30)  # noqa: SLF001
