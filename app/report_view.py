"""The seed report's figures replayed, in the Report tab: one figure at a time, scaled to the panel, with its verdict.

Why pictures read from ``docs/seed-report/`` and not computed here: ``python -m physics seed-report --out
docs/seed-report`` replays every figure at the report's settings beside a converged run (tens of seconds of
tight integration); the app shows what that one command wrote (the SVGs and ``seed-report.json``), so the tab
opens at once and its numbers are the ones docs/seed-report.md quotes. Each verdict is one or two sentences
with the numbers read from the JSON; the full reading is in docs/seed-report.md.

The SVGs are shown as ``<img>`` with a data URI at 100 % of the panel's width: an image element runs no script
and keeps the file's own proportions, whatever the panel's width. They are drawn for the panel (about 380 px wide,
text of 14 px: physics/studies/charts.py ``panel_line_chart``, physics/fbd.py ``fbd_svg(text_px=...)``), so their
text is still at least 12 px there; a click shows one full-screen (static/page.html, in the page only).
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .page import FIGURE_CLASS
from .text import html_literal

SEED_REPORT_FOLDER = Path(__file__).resolve().parents[1] / "docs" / "seed-report"
DOC_POINTER = "docs/seed-report.md"
COMMAND = "python -m physics seed-report --out docs/seed-report"


@dataclass(frozen=True)
class ReportFigure:
    """One figure of the replay: the menu label, its SVG file, and its verdict from the numbers (a callable of the
    JSON document, so a missing number is a missing verdict, not a wrong one)."""

    label: str
    file: str
    verdict: Callable[[dict], str]


def _g(value, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value:.{digits}g}"


def _scipy(doc: dict, *keys: str):
    """The same number from the replay with scipy's RK45 (``scipy_rk45``), or None in an older document."""
    value = doc.get("scipy_rk45")
    for key in keys:
        if not isinstance(value, dict):
            return None
        value = value.get(key)
    return value


def _methods(doc: dict) -> tuple[str, str]:
    settings = doc.get("settings", {})
    return settings.get("report_integrator", "ode45"), settings.get("scipy_integrator", "RK45")


def _tip_path(case: str, note: str) -> Callable[[dict], str]:
    def verdict(doc: dict) -> str:
        c = doc["triple"][case]
        ours, scipy = _methods(doc)
        other = _scipy(doc, "triple", case, "departure_time")
        if c["departure_time"] is not None:
            return (f"Shows the true path only up to t = {_g(c['departure_time'], 4)} s with {ours} (the report's "
                    f"method; {_g(other, 4)} s with {scipy}): after that the report's tip leaves a converged run "
                    f"(by up to {_g(c['tip_error_max'])}). Chaos amplifies the 1e-6 tolerance until it is as large "
                    "as the pendulum; the controller moves the departure, never removes it. Fix: draw the path "
                    "only as far as a converged reference confirms it.")
        return (f"The true path: the report's tip stays within {_g(c['tip_error_max'])} of a converged run over "
                f"{_g(c['t_end'])} s with {ours} ({_g(_scipy(doc, 'triple', case, 'tip_error_max'))} with "
                f"{scipy}). {note}")
    return verdict


def _differences(case: str) -> Callable[[dict], str]:
    def verdict(doc: dict) -> str:
        c = doc["triple"][case]
        ours, _ = _methods(doc)
        wrong = max(c["x_error_max"].values())
        return (f"The methods differ by at most {_g(max(c['ne_minus_dae_max'], c['ne_minus_lagrange_max']), 2)} "
                f"(grey): rounding, since all three take the same {c['steps']['newton_euler']} {ours} steps. Each "
                f"is off a converged run by up to {_g(wrong)} in x (coloured): that is the method error. The app's "
                "compare mode plots the honest version (each method against a converged reference).")
    return verdict


def _four_bar(doc: dict) -> str:
    r = doc["four_bar"]["report"]
    p = doc["four_bar"]["projected"]
    ours, scipy = _methods(doc)
    scipy_energy = _scipy(doc, "four_bar", "report", "energy_error_max")
    return (f"At the report's settings ({ours}) the loop comes apart: the tip ends {_g(r['pin_gap_max'], 2)} off "
            f"its pin ({_g(_scipy(doc, 'four_bar', 'report', 'pin_gap_max'), 2)} with {scipy}), the energy drifts "
            f"by {_g(100 * r['energy_error_max'], 2)} % "
            f"({_g(None if scipy_energy is None else 100 * scipy_energy, 2)} % with {scipy}), "
            f"and theta1 is more than 0.01 rad off a converged run from t = {_g(r['theta1_departure'], 4)} s. "
            f"Projection after every step at the same tolerance keeps the pin to {_g(p['pin_gap_max'], 1)} and "
            f"theta1 right until {_g(p['theta1_departure'], 4)} s.")


def _free_body(doc: dict) -> str:
    return ("One free-body diagram per bar, from the DAE's reactions: the forces balance m a_G and I alpha. "
            "The live version: the Free-body diagram above.")


FIGURES = (
    ReportFigure("Figure 9 (case A): tip path", "figure-9-case-a.svg",
                 _tip_path("A", "It holds only just: at this tolerance (RK45) case A leaves the true motion at "
                                "about 21.6 s (stability.md, case 5).")),
    ReportFigure("Figure 10 (case B): tip path", "figure-10-case-b.svg",
                 _tip_path("B", "The report's tolerance is ample here (a regular, not chaotic, motion).")),
    ReportFigure("Figure 11 (case C): tip path", "figure-11-case-c.svg", _tip_path("C", "")),
    ReportFigure("Figures 12-13, case A: method differences", "figures-12-13-case-a.svg", _differences("A")),
    ReportFigure("Figures 12-13, case B: method differences", "figures-12-13-case-b.svg", _differences("B")),
    ReportFigure("Figures 12-13, case C: method differences", "figures-12-13-case-c.svg", _differences("C")),
    ReportFigure("Four-bar: tip distance from its pin", "four-bar-pin-gap.svg", _four_bar),
    ReportFigure("Four-bar: energy error", "four-bar-energy-error.svg", _four_bar),
    ReportFigure("Four-bar: crank angle theta1", "four-bar-theta1.svg", _four_bar),
    ReportFigure("Free-body diagrams, triple-a, bar 1", "fbd-triple-a-bar-1.svg", _free_body),
    ReportFigure("Free-body diagrams, four-bar, bar 3", "fbd-four-bar-bar-3.svg", _free_body),
)


def load_document(folder: Path = SEED_REPORT_FOLDER) -> dict | None:
    """``seed-report.json`` of the folder, or None when the command has not been run there."""
    try:
        return json.loads((folder / "seed-report.json").read_text())
    except (OSError, ValueError):
        return None


def figure_html(figure: ReportFigure, folder: Path = SEED_REPORT_FOLDER, document: dict | None = None) -> str:
    """The figure as an image as wide as the panel, its verdict and where to read more; a pointer to the command
    when the file is missing."""
    path = folder / figure.file
    try:
        svg = path.read_bytes()
    except OSError:
        return (f"<p>The figure <code>{html_literal(figure.file)}</code> is not there yet. Run "
                f"<code>{html_literal(COMMAND)}</code> in the project folder.</p>")
    try:
        verdict = figure.verdict(document) if document is not None else ""
    except (KeyError, TypeError, ValueError):
        verdict = ""
    data = base64.b64encode(svg).decode("ascii")
    image = (f'<img class="{FIGURE_CLASS}" alt="{html_literal(figure.label)}" src="data:image/svg+xml;base64,{data}" '
             'title="Click to see it full-screen" style="width:100%;height:auto;display:block;border:1px solid #ddd"/>')
    parts = [image]
    if verdict:
        parts.append(f'<p style="margin:6px 0;font-size:0.8em">{html_literal(verdict)}</p>')
    parts.append(f'<p style="margin:2px 0;font-size:0.75em;color:#666">Full size: '
                 f'<code>docs/seed-report/{html_literal(figure.file)}</code>; the reading of every figure: '
                 f'<code>{DOC_POINTER}</code>.</p>')
    return f'<div style="width:100%;max-width:100%;overflow:hidden">{"".join(parts)}</div>'


class SeedReportPanel:
    """A figure menu and the figure with its verdict, in the current GUI container of ``gui``."""

    def __init__(self, gui, bind: Callable, folder: Path = SEED_REPORT_FOLDER) -> None:
        self.folder = folder
        self.document = load_document(folder)
        self.folder_handle = gui.add_folder("Seed report, replayed")
        with self.folder_handle:
            gui.add_markdown("The course report's figures at its own settings (MATLAB's ode45 controller, "
                             "tolerance 1e-6; scipy's RK45 drawn beside it) with a converged run, and what each "
                             "shows. Made by `" + COMMAND + "`.")
            labels = tuple(f.label for f in FIGURES)
            self.choice = gui.add_dropdown("Figure", labels, initial_value=labels[0])
            self.figure = gui.add_html(figure_html(FIGURES[0], folder, self.document))
            bind(self.choice, lambda value, event: self.show(value))

    def show(self, label: str) -> None:
        for figure in FIGURES:
            if figure.label == label:
                self.figure.content = figure_html(figure, self.folder, self.document)
                return
