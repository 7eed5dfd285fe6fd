"""Compare mode: three opaque mechanisms in distinct colours, apart in depth, with a colour key in the scene."""

from __future__ import annotations

from app.mechanism_compare import COMPARE_METHODS
from app.overlays import METHOD_COLORS
from app.parameters import METHOD_LABELS
from app.scene import instance_colors
from conftest import wait_until


def test_compare_mode_draws_a_colour_key_and_opaque_runs(connect):
    _, session = connect()
    view = session.compare_view  # the one session's compare mode (app/mechanism_compare.py)
    session.set_compare(True)
    assert wait_until(lambda: session.compare and len(view.scenes) == 3, timeout=60)
    names = [handle.name for handle in view._key]  # noqa: SLF001 - the view's own nodes
    for method in COMPARE_METHODS:
        assert f"/compare_key/{method}/ball" in names and f"/compare_key/{method}/name" in names
        bars = view.scenes[method]._bars  # noqa: SLF001
        assert bars is not None and bars.opacity is None  # opaque: no blend into one colour
        # every bar of a method's mechanism in that method's colour (as viser's linear instance colours)
        colors = {tuple(int(c) for c in rgb) for rgb in bars.batched_colors}
        assert colors == {tuple(int(c) for c in instance_colors([METHOD_COLORS[method]])[0])}, (method, colors)
    labels = [handle.text for handle in view._key if hasattr(handle, "text")]  # noqa: SLF001
    assert labels == [METHOD_LABELS[m] for m in COMPARE_METHODS]
    balls = [handle for handle in view._key if not hasattr(handle, "text")]  # noqa: SLF001
    assert [tuple(int(c) for c in ball.color) for ball in balls] == [METHOD_COLORS[m] for m in COMPARE_METHODS]
    depths = [view._frames[m].position[1] for m in COMPARE_METHODS]  # noqa: SLF001
    assert depths[0] < depths[1] < depths[2]
    session.set_compare(False)
    assert wait_until(lambda: not view._key and not view._frames, timeout=30)  # noqa: SLF001
