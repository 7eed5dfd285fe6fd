"""Lecture mode's switches that need no browser: a link's ``lecture=`` value and the ``--lecture`` flag."""

from __future__ import annotations

from app.__main__ import build_parser
from app.server import lecture_from


def test_a_link_lecture_value_is_taken_out_of_the_setup():
    setup = [("preset", "double"), ("lecture", "1"), ("L1", "1.5")]
    rest, on, refused = lecture_from(setup, False)
    assert rest == [("preset", "double"), ("L1", "1.5")] and on and not refused
    assert lecture_from([("lecture", "0")], True)[1] is False
    assert lecture_from([("preset", "double")], True) == ([("preset", "double")], True, [])


def test_a_bad_lecture_value_is_one_reason_naming_the_field():
    rest, on, refused = lecture_from([("lecture", "maybe")], False)
    assert rest == [] and on is False
    assert refused == ["lecture: 'maybe' is not 0 or 1 (lecture=1 opens the page in lecture mode)"]


def test_the_lecture_flag():
    assert build_parser().parse_args(["--lecture"]).lecture is True
    assert build_parser().parse_args([]).lecture is False
