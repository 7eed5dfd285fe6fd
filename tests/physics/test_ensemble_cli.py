"""``python -m physics ensemble`` for a chain and for a mechanism: one writer (physics.outputs.write_ensemble), so
the same files and the same exit status when a copy dies (3, the message on stderr, what was computed written)."""

from __future__ import annotations

import csv
import json
import math

import pytest

from physics.cli import main
from physics.kernels.first_compile import compile_line
from physics.outputs import EXIT_RUN_STOPPED, write_ensemble

CHAIN_KEYS = ["preset", "method", "count", "spread", "step", "t", "tip_spread", "alive", "energy_drift", "message",
              "final_tips"]
MECHANISM_KEYS = ["mechanism", "mobility", "method", "stabilization", "count", "spread", "t_end", "probe", "t",
                  "tip_spread", "alive", "energy_drift", "message", "note", "final_tips"]
COLUMNS = ["t", "tip_spread", "alive", "energy_drift"]

# A chain whose copies die: the change-point four-bar with all four links within 1e-8 rad of one line (singular).
CHAIN_DIES = ["--preset", "change-point", "--count", "2", "--spread", "0", "--t-end", "0.05", "--samples", "3",
              "--set", f"theta1={math.pi / 2 - 1e-8!r}", "--set", f"theta2={math.pi / 2!r}",
              "--set", f"theta3={math.pi / 2 - 1e-8 + math.pi!r}", "--set", "omega1=0", "--set", "omega2=0",
              "--set", "omega3=0"]
CHAIN_LIVES = ["--preset", "double", "--count", "3", "--t-end", "0.2", "--samples", "3"]
# A mechanism whose copies die: two integration steps allowed, far fewer than 0.2 s needs.
MECHANISM_DIES = ["--preset", "slider-crank", "--count", "2", "--t-end", "0.2", "--samples", "3", "--max-steps", "2"]
MECHANISM_LIVES = ["--preset", "slider-crank", "--count", "2", "--t-end", "0.2", "--samples", "3"]


def _refuse_constant(name: str):
    raise AssertionError(f"the JSON holds {name}, which strict JSON readers refuse")


def said_at_most_the_first_compile_line(err: str) -> bool:
    """Whether stderr holds nothing, or only the one line a process says before its first numba compilation
    (physics.kernels.first_compile): a run from an empty cache (CI's, or a test worker that is the first to need
    the ensemble's kernel) says it, a warm one does not, and which a test gets depends on the order of the tests."""
    lines = err.splitlines()
    if not lines:
        return True
    what = lines[0].removeprefix("linkage-lab: compiling the ").partition(" integrator once")[0]
    return len(lines) == 1 and err == compile_line(what) + "\n"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["ensemble", *argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("argv, keys", [(CHAIN_LIVES, CHAIN_KEYS), (MECHANISM_LIVES, MECHANISM_KEYS)],
                         ids=["chain", "mechanism"])
def test_every_copy_alive_exits_0_with_the_documented_keys(capsys, tmp_path, argv, keys):
    code, out, err = run(capsys, *argv)
    document = json.loads(out)
    assert code == 0 and said_at_most_the_first_compile_line(err) and list(document) == keys, err
    assert document["alive"] == [document["count"]] * 3
    code, out, err = run(capsys, *argv, "--out", str(tmp_path / "fan.csv"))  # compiled by now: nothing to say
    rows = list(csv.reader((tmp_path / "fan.csv").open()))
    assert code == 0 and out == "" and err == "" and rows[0] == COLUMNS and len(rows) == 4
    assert [float(v) for v in rows[1]] == [document[name][0] for name in COLUMNS]


@pytest.mark.parametrize("argv, keys", [(CHAIN_DIES, CHAIN_KEYS), (MECHANISM_DIES, MECHANISM_KEYS)],
                         ids=["chain", "mechanism"])
def test_a_copy_that_dies_exits_3_with_its_message_and_writes_every_format(capsys, tmp_path, argv, keys):
    code, out, err = run(capsys, *argv)
    document = json.loads(out, parse_constant=_refuse_constant)  # strict JSON: no NaN or Infinity
    assert code == EXIT_RUN_STOPPED == 3
    assert list(document) == keys and document["alive"][0] == 2 and document["alive"][-1] < 2
    assert err.strip().splitlines()[-1] == f"error: {document['message']}" and "copy 0" in document["message"]
    for name in ("fan.json", "fan.csv", "fan.png"):
        code, out, err = run(capsys, *argv, "--out", str(tmp_path / name))
        assert code == 3 and out == "" and err.strip().splitlines()[-1].startswith("error: copy 0")
    assert list(json.loads((tmp_path / "fan.json").read_text())) == keys
    rows = list(csv.reader((tmp_path / "fan.csv").open()))
    assert rows[0] == COLUMNS and len(rows) == 4 and float(rows[-1][2]) < 2
    assert (tmp_path / "fan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_writer_writes_floats_as_python_does_and_draws_only_for_png(tmp_path, capsys):
    drawn = []

    def picture() -> bytes:
        drawn.append(1)
        return b"picture"

    columns = {"t": [0.0, 0.1], "alive": [2, 1]}
    assert write_ensemble(str(tmp_path / "a.csv"), {}, columns, picture, True, "ok") == 0
    assert (tmp_path / "a.csv").read_text() == "t,alive\n0.0,2.0\n0.1,1.0\n" and not drawn
    assert write_ensemble(str(tmp_path / "a.png"), {}, columns, picture, False, "copy 1 died") == 3
    assert (tmp_path / "a.png").read_bytes() == b"picture" and drawn == [1]
    assert capsys.readouterr().err == "error: copy 1 died\n"
    assert write_ensemble(None, {"x": 1}, columns, picture, True, "ok") == 0
    assert capsys.readouterr().out == '{"x": 1}\n'
