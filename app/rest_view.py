"""The "Rest positions" list of the Report tab: where the current mechanism can stay at rest, and a jump there.

Why a list computed on request: :func:`physics.rest_positions.rest_positions` is exact for an open chain (every
bar straight down or up) but samples a four-bar's whole loop and refines each extremum (about a second), so it
runs in a worker when asked and the list is dropped when the mechanism changes. Jumping sets the start angles
to the chosen rest, omega = 0, and starts again at t = 0 (paused, or playing), through the session's
``set_start``: a stable rest then stays still, an unstable one stays only until rounding (or a nudge) tips it.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np

from physics import LinkageError
from physics.rest_positions import RestPosition, rest_positions

from .parameters import SessionParameters
from .text import markdown_literal

GO_OPTIONS = ("Go (paused)", "Go and play")
NO_LIST = "(press Find)"


class RestPort(Protocol):
    """What the rest list asks of its session."""

    @property
    def setup(self) -> SessionParameters: ...

    def set_start(self, theta0, omega0, play: bool = False) -> None: ...

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...


def rest_label(k: int, rest: RestPosition) -> str:
    """``"1: stable, V = -2.94 J, (0°, 0°, 0°)"``: number, kind, potential energy, angles in degrees."""
    kind = "stable" if rest.stable else "unstable"
    angles = ", ".join(f"{math.degrees(v):.1f}°" for v in rest.theta)
    return f"{k}: {kind}, V = {rest.potential:.4g} J, ({angles})"


class RestPositionsPanel:
    """A Find button, the list (a dropdown), and Go buttons, in the current GUI container of ``gui``.
    ``bind(handle, action)`` attaches a callback inside the session's error boundary."""

    def __init__(self, port: RestPort, gui, bind: Callable) -> None:
        self.port = port
        self.rests: list[RestPosition] = []
        self._chain = None  # the chain the list was found for
        self._generation = 0  # bumped when the mechanism changes: a late result for the old one is dropped
        self._lock = threading.Lock()
        self._job: threading.Thread | None = None
        self.folder = gui.add_folder("Rest positions")
        with self.folder:
            self.status = gui.add_markdown("Where the mechanism can stay at rest (potential energy V stationary), "
                                           "stable or not.")
            self.find_button = gui.add_button("Find rest positions")
            bind(self.find_button, lambda value, event: self.find())
            self.choice = gui.add_dropdown("Rest position", (NO_LIST,), initial_value=NO_LIST)
            self.go = gui.add_button_group("Jump there", GO_OPTIONS)
            bind(self.go, lambda value, event: self.jump(self.index_of(self.choice.value), play=value == GO_OPTIONS[1]))

    # ------------------------------------------------------------------ finding
    def find(self) -> None:
        """Compute the list for the parameters in force, in a worker."""
        chain = self.port.setup.chain
        with self._lock:
            if self._job is not None and self._job.is_alive():
                return
            generation = self._generation
            self._job = threading.Thread(target=self._work, args=(chain, generation), daemon=True,
                                         name="rest-positions")
            self.status.content = "**Finding** the rest positions..."
            self._job.start()

    def _work(self, chain, generation: int) -> None:
        try:
            found = rest_positions(chain)
        except LinkageError as error:
            self.status.content = f"No list: {markdown_literal(error)}"
            return
        except Exception as error:  # noqa: BLE001 (a worker's failure becomes a line in the panel, never a dead thread)
            self.status.content = f"Finding the rest positions failed: {markdown_literal(type(error).__name__)}"
            self.port.show_notice("Rest positions failed", f"{type(error).__name__}: {error}", color="red")
            return
        with self._lock:
            if generation != self._generation:
                return
            self.rests = found
            self._chain = chain
            labels = tuple(rest_label(k + 1, r) for k, r in enumerate(found)) or (NO_LIST,)
            self.choice.options = labels
            self.choice.value = labels[0]
            stable = sum(r.stable for r in found)
            self.status.content = (f"{len(found)} rest positions ({stable} stable), lowest potential energy first. "
                                   "Pick one and jump there: omega = 0, t = 0.")

    def wait(self, timeout: float = 60.0) -> None:
        """Wait for a running search (tests)."""
        job = self._job
        if job is not None:
            job.join(timeout)

    def forget(self) -> None:
        """The mechanism changed: the list no longer applies."""
        with self._lock:
            self._generation += 1
            self.rests = []
            self.choice.options = (NO_LIST,)
            self.choice.value = NO_LIST
            self.status.content = "Where the mechanism can stay at rest (potential energy V stationary), stable or not."

    # ------------------------------------------------------------------ jumping
    def index_of(self, label: str) -> int:
        labels = [rest_label(k + 1, r) for k, r in enumerate(self.rests)]
        if label not in labels:
            raise LinkageError("rest position: press 'Find rest positions' first, then pick one")
        return labels.index(label)

    def jump(self, index: int, play: bool = False) -> None:
        """Start again from rest position ``index`` (0-based in :attr:`rests`) with omega = 0."""
        if not 0 <= index < len(self.rests):
            raise LinkageError(f"rest position = {index + 1}: allowed 1 <= rest position <= {len(self.rests)}")
        if self.port.setup.chain != self._chain:
            raise LinkageError("rest position: the mechanism's parameters changed since the list was found; "
                               "press 'Find rest positions' again")
        theta = self.rests[index].theta
        self.port.set_start(theta, np.zeros_like(theta), play=play)
