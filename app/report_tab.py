"""The "Report" tab of one session: the seed report's companion (issue 15).

Three parts, each in its own module: the live free-body diagram of one bar in the 3D scene
(:mod:`app.free_body_view`; this tab holds its toggle and bar menu), the mechanism's rest positions with a jump
to each (:mod:`app.rest_view`), and the report's figures replayed with their verdicts (:mod:`app.report_view`).
The tab sees its session through :class:`ReportPort` only.
"""

from __future__ import annotations

from typing import Protocol

from .free_body_view import FreeBodyView, fbd_command
from .parameters import SessionParameters
from .report_view import SeedReportPanel
from .rest_view import RestPositionsPanel


class ReportPort(Protocol):
    """What the Report tab asks of its session."""

    @property
    def setup(self) -> SessionParameters: ...

    def set_start(self, theta0, omega0, play: bool = False) -> None: ...

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...


def bar_options(n: int) -> tuple[str, ...]:
    return tuple(str(k) for k in range(1, n + 1))


class ReportTab:
    """Adds the tab to ``panel``'s tab group (:class:`~app.controls.Controls`); ``free_body`` is the session's
    :class:`~app.free_body_view.FreeBodyView`, drawn by the session's frame callback."""

    def __init__(self, port: ReportPort, panel, free_body: FreeBodyView) -> None:
        self.port = port
        self.free_body = free_body
        self._panel = panel
        gui = panel.gui
        bind = panel.bind
        self.tab = panel.tabs.add_tab("Report")
        with self.tab:
            self.fbd_folder = gui.add_folder("Free-body diagram")
            with self.fbd_folder:
                self.fbd_box = gui.add_checkbox(
                    "Free-body diagram", initial_value=False,
                    hint="Every force on the chosen bar at the displayed instant, with its value: gravity at G, "
                         "the joint reactions (R_k on bar k+1 by bar k; -R_k at its far end), the pin's on a loop")
                bind(self.fbd_box, lambda value, event: self.free_body.set_on(value))
                self.fbd_bar = gui.add_dropdown("Bar", bar_options(port.setup.n), initial_value="1")
                bind(self.fbd_bar, lambda value, event: self._choose_bar(int(value)))
                self.fbd_help = gui.add_markdown(self.help_text())
            self.rests = RestPositionsPanel(port, gui, bind)
            self.seed_report = SeedReportPanel(gui, bind)

    def help_text(self) -> str:
        """The diagram's help, naming the preset shown and the bar chosen (issue 26: it named ``triple-a``)."""
        setup = self.port.setup
        command = fbd_command(setup.preset, links=setup.n, bar=self.free_body.bar)
        return ("Arrows to scale among themselves: the largest is one bar length long (times the arrow scale of "
                f"the Display tab); labels name each force and its value. The SVG of this bar: `{command}`.")

    def _choose_bar(self, bar: int) -> None:
        self.free_body.set_bar(bar)
        self.fbd_help.content = self.help_text()

    def rebuild(self) -> None:
        """The mechanism changed: new bar menu, and the rest list no longer applies."""
        n = self.port.setup.n
        options = bar_options(n)
        if tuple(self.fbd_bar.options) != options:
            keep = self.fbd_bar.value if self.fbd_bar.value in options else "1"
            self.fbd_bar.options = options
            self.fbd_bar.value = keep
            self.free_body.set_bar(int(keep))
        self.fbd_help.content = self.help_text()
        self.rests.forget()

    def remove(self) -> None:
        self.free_body.remove()
