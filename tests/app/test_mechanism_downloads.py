"""Downloads of a general mechanism's run (issue 24): the run up to the displayed time, in the columns of the
``mechanism`` command (docs/mechanisms.md), equal to what physics computes from the same start."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from conftest import lab_of, wait_until
from physics import LinkageError
from physics.mechanism.command import run_table
from physics.mechanism.simulate import simulate_mechanism

crank_lab = lab_of("slider-crank")


class Receiver:
    """Stands in for the browser a file is sent to."""

    def __init__(self) -> None:
        self.files: list[tuple[str, bytes]] = []

    def send_file_download(self, name: str, content: bytes) -> None:
        self.files.append((name, content))


def test_the_csv_is_the_mechanism_commands_table_of_the_run_shown(crank_lab, connect):
    _, session = connect(crank_lab)
    session.guard(lambda: session.set_trace("rod.B"))
    assert wait_until(lambda: session.player.runs[0].spec.settings.trace == "rod.B"
                      and session.player.runs[0].ring.t_last > 0.6, timeout=60)
    assert session.goto_time(0.5)
    receiver = Receiver()
    session.guard(lambda: session.download("csv", receiver))
    assert session.notices.text is None, session.notices.text
    (name, content), = receiver.files
    assert name == "mechanism-slider-crank-dae.csv"
    rows = list(csv.reader(io.StringIO(content.decode("utf-8"))))
    traced = session.mechanism.model_copy(update={"trace": "rod.B"})
    direct = simulate_mechanism(traced, 0.5, 31)  # every 1/60 s, as the app's samples
    expected_rows = list(csv.reader(io.StringIO(run_table(direct).decode("utf-8"))))
    assert rows[0] == expected_rows[0]
    assert "constraint_residual" in rows[0] and any(h.startswith("lambda[") for h in rows[0])
    table = np.array(rows[1:], dtype=float)
    assert len(table) == 31 and table[0, 0] == 0.0 and table[-1, 0] == pytest.approx(0.5)
    # the app's run is physics' own from the same start: every column at every sample, the traced point too
    expected = np.array(expected_rows[1:], dtype=float)
    assert np.allclose(table[:, :7], expected[:, :7], rtol=1e-7, atol=1e-9)
    assert np.allclose(table[:, 7:], expected[:, 7:], rtol=1e-6, atol=1e-6 * np.abs(expected[:, 7:]).max())


def test_the_json_has_the_same_columns_and_a_bad_kind_is_one_notice(crank_lab, connect):
    _, session = connect(crank_lab)
    assert session.goto_time(0.25)
    name, content = session.download_file("json")
    document = json.loads(content)
    assert name.endswith("-dae.json") and len(document["t"]) == 16
    assert {"t", "trace_x", "trace_y", "kinetic", "potential", "energy", "constraint_residual"} <= set(document)
    with pytest.raises(LinkageError, match="download = 'pdf': allowed csv, json"):
        session.download_file("pdf")
    session.guard(lambda: session.download("pdf", Receiver()))
    assert "download = 'pdf'" in (session.notices.text or "")
