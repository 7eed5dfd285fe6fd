"""Reaction arrows and the CSV's reaction columns under every method (issue 14, item 7), and in compare mode."""

from __future__ import annotations

import numpy as np
import pytest

from app import export
from app.parameters import METHOD_LABELS
from conftest import wait_until


@pytest.mark.parametrize("preset, method", [
    ("triple-a", "newton_euler"), ("triple-a", "lagrange"), ("triple-a", "dae"), ("four-bar", "reduced"),
])
def test_arrows_are_drawn_under_every_method(connect, preset, method):
    _, session = connect()
    session.set_mechanism(preset)
    session.controls.method.value = METHOD_LABELS[method]
    assert session.params.method == method
    session.controls.reactions.value = True
    session.play()
    assert wait_until(lambda: session.arrows.handle is not None and session.arrows.handle.visible
                      and session.snapshot()["time"] > 0.5)
    expected = session.params.n + (1 if session.params.pinned else 0)  # every joint, and the pin of a loop
    assert session.arrows.count == expected
    shown = np.asarray(session.arrows.handle.points)
    lengths = np.linalg.norm(shown[:, 1] - shown[:, 0], axis=1)
    assert np.all(lengths > 1e-6)  # a hanging chain's joints all carry weight: no zero arrow
    # the CSV has the reaction columns, equal to the ring's values
    session.pause()
    history = session.history()
    columns = export.columns(history, session.params.method, session.params.pinned)
    assert "R0x" in columns and f"R{session.params.n - 1}y" in columns
    assert np.array_equal(columns["R0y"], history["reactions"][:, 0, 1])
    assert np.any(np.abs(columns["R0y"]) > 1e-3)


def test_arrows_are_drawn_in_compare_mode(connect):
    _, session = connect()
    session.controls.compare.value = True
    session.controls.reactions.value = True
    session.play()
    assert wait_until(lambda: session.arrows.handle is not None and session.arrows.handle.visible
                      and session.snapshot()["time"] > 0.5)
    assert session.arrows.count == session.params.n
    frame = session.last_frame
    first = frame.runs[0]
    assert first.label == "newton_euler"
    start = np.asarray(session.arrows.handle.points)[:, 0]
    assert np.allclose(start[:, [0, 2]], first.joints[:-1], atol=0.5)  # on the Newton-Euler mechanism
