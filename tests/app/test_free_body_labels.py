"""The free-body view's labels (issue 26): no label box meets another, on a chain and on a general mechanism, and
the help names the preset shown. Geometric: the boxes are where the view put the labels (the scene's label
nodes sit at their corners, their text height is the boxes' height), compared pairwise."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from app.free_body_view import CHAR_WIDTH, LABEL_HEIGHT, boxes_meet, label_box, layout_labels
from app.scene import mechanism_reach, to_world
from conftest import lab_of, wait_until

rocker_lab = lab_of("crank-rocker")


def assert_apart(boxes) -> None:
    for a, b in itertools.combinations(boxes, 2):
        assert not boxes_meet(a, b), f"label boxes {a} and {b} overlap"


def drawn_labels(view):
    """The boxes, the arrow heads and the scene's label nodes of one drawing (read under the view's lock: the
    player thread draws), after checking that the nodes are at the boxes' corners, as high as the boxes, and
    the boxes as wide as the texts shown."""
    with view._lock:
        boxes, heads, handles = list(view.label_boxes), view.label_heads.copy(), list(view._labels)
        assert len(boxes) == len(handles) == len(view.shown) == len(heads)
        for box, handle in zip(boxes, handles):
            check_node(box, handle)
    return boxes, heads


def check_node(box, handle) -> None:
    """One label node: at its box's bottom-left corner, text as high as the box, the box as wide as its text."""
    assert np.allclose(handle.position, to_world(np.array(box[:2])))
    assert handle.font_size_mode == "scene" and handle.anchor == "bottom-left"
    assert handle.font_scene_height == pytest.approx(box[3] - box[1])
    assert box[2] - box[0] >= label_box(np.zeros(2), handle.text, box[3] - box[1])[2] - 1e-12


def test_labels_at_one_point_are_stacked_apart():
    heads = np.zeros((4, 2))
    texts = ["m1·g = 1 N", "-R1 = 5.42 N", "R0 = 6.1 N", "RH = 0.3 N"]
    boxes = layout_labels(heads, texts, 0.1)
    assert_apart(boxes)
    assert boxes[0] == label_box(heads[0], texts[0], 0.1)  # the first stays at its arrow's head
    rng = np.random.default_rng(1)
    for _ in range(200):
        heads = rng.normal(scale=0.2, size=(5, 2))
        assert_apart(layout_labels(heads, [f"F{k} = {rng.uniform(0, 99):.3g} N" for k in range(5)], 0.1))


def test_chain_labels_never_overlap(connect):
    """The issue's case: the triple pendulum's bars, where "-R1" was drawn over "m1·g"; several instants each."""
    _, session = connect()
    session.set_mechanism("triple-a")
    session.free_body_box.value = True  # the Display tab's box (viser runs its callback)
    view = session.free_body
    met_at_heads = 0  # cases where the labels at the arrow heads would have met: the layout had work to do
    for t in (0.0, 0.7, 1.3, 2.5):
        assert session.goto_time(t)
        for bar in (1, 2, 3):
            session.body_menu.value = f"bar{bar}"
            assert wait_until(lambda bar=bar: view.shown_bar == bar and view.shown
                              and abs(view.shown_t - t) < 0.1, timeout=30)
            boxes, heads = drawn_labels(view)
            assert_apart(boxes)
            height = boxes[0][3] - boxes[0][1]
            assert height == pytest.approx(LABEL_HEIGHT * mechanism_reach(session.params.chain.array("L"), session.params.chain.pin), rel=1e-9)
            at_heads = [label_box(head, "x" * round((b[2] - b[0]) / (b[3] - b[1]) / CHAR_WIDTH), height)
                        for head, b in zip(heads, boxes)]
            met_at_heads += any(boxes_meet(a, b) for a, b in itertools.combinations(at_heads, 2))
    assert met_at_heads > 0, "no case where labels at the arrow heads would overlap: the test checks nothing"


def test_chain_help_names_the_preset_shown(connect):
    _, session = connect()
    session.set_mechanism("double")
    assert "--preset double --bar 1" in session.free_body_help.content
    session.body_menu.value = "bar2"
    assert wait_until(lambda: "--preset double --bar 2" in session.free_body_help.content, timeout=30)
    session.set_mechanism("chain", links=4)
    assert "--preset chain --links 4" in session.free_body_help.content
    assert "triple-a" not in session.free_body_help.content


def test_mechanism_labels_never_overlap_and_its_help_names_the_body(rocker_lab, connect):
    _, session = connect(rocker_lab)
    session.guard(lambda: session.set_free_body(True))
    view = session.free_body
    for body in ("crank", "coupler", "rocker"):
        session.guard(lambda body=body: session.set_free_body_body(body))
        assert f"--preset crank-rocker --body {body}" in session.free_body_help.content
        number = [b.name for b in session.mechanism.bodies].index(body) + 1
        assert wait_until(lambda number=number: view.shown_bar == number and view.visible(), timeout=60)
        for _ in range(3):
            shown = view.shown_t
            assert wait_until(lambda shown=shown: view.shown_t != shown, timeout=60)
            assert_apart(drawn_labels(view)[0])
