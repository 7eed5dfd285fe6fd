"""The "Rest positions" list: where the current mechanism can stay at rest, and a jump there; one panel for a
chain (its Report tab) and for any general mechanism (its Display tab).

Why a list computed on request: :func:`physics.rest_positions.rest_positions` is exact for an open chain (every
bar straight down or up) but samples a four-bar's whole loop and refines each extremum (about a second), and a
general mechanism's :func:`physics.mechanism.statics.rest_poses` runs Newton's method from 40 assembled poses
(about a second for a six-bar), so it runs in a worker when asked and the list is dropped when the mechanism
changes. Jumping sets the start to the chosen rest, speeds 0, and starts again at t = 0 (paused, or playing),
through the session (:class:`RestPort` for a chain, :class:`MechanismRestPort` for a mechanism): a stable rest
then stays still, an unstable one stays only until rounding (or a nudge) tips it. A mechanism with nothing free
to come to rest (a speed motor turning, as the Jansen leg's) gets physics' one-line reason in the panel, as the
``equilibrium`` command prints it.

The two kinds differ only in where the list comes from and where a jump goes: a :class:`RestSource` says that
(:class:`ChainRests`, :class:`MechanismRests`); the panel, its wording and its checks are one.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np

from physics import LinkageError
from physics.mechanism import Mechanism
from physics.mechanism.statics import RestPose, rest_poses
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


class MechanismRestPort(Protocol):
    """What the rest list asks of a general mechanism's session."""

    mechanism: Mechanism

    def set_start_pose(self, q0: np.ndarray, qdot0: np.ndarray, play: bool = False) -> None: ...

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...


Rest = RestPosition | RestPose


def rest_label(k: int, rest: Rest) -> str:
    """``"1: stable, V = -2.94 J, (0°, 0°, 0°)"``: number, kind, potential energy, angles in degrees (a chain's
    bar angles; a mechanism's body rotations, in the description's order)."""
    kind = "stable" if rest.stable else "neutral" if getattr(rest, "neutral", False) else "unstable"
    values = rest.theta if isinstance(rest, RestPosition) else rest.q[2::3]
    angles = ", ".join(f"{math.degrees(v):.1f}°" for v in values)
    return f"{k}: {kind}, V = {rest.potential:.4g} J, ({angles})"


class RestSource(Protocol):
    """Where a panel's list comes from and where a jump goes."""

    def current(self) -> object:
        """What the list is for (compared for equality: a list found for another is stale)."""

    def find(self, model) -> list: ...

    def start(self, rest, play: bool) -> None: ...

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...


class ChainRests:
    """A chain's: :func:`physics.rest_positions.rest_positions` of the chain in force; a jump sets theta0."""

    def __init__(self, port: RestPort) -> None:
        self.port = port

    def current(self):
        return self.port.setup.chain

    def find(self, chain) -> list[RestPosition]:
        return rest_positions(chain)

    def start(self, rest: RestPosition, play: bool) -> None:
        self.port.set_start(rest.theta, np.zeros_like(rest.theta), play=play)

    def show_notice(self, title: str, body: str, color: str = "red", seconds: float | None = None) -> None:
        self.port.show_notice(title, body, color=color)


class MechanismRests:
    """A general mechanism's: :func:`physics.mechanism.statics.rest_poses` (the ``equilibrium`` command's
    search); a jump starts from the pose ``q`` with every speed zero."""

    def __init__(self, port: MechanismRestPort) -> None:
        self.port = port

    def current(self):
        return self.port.mechanism

    def find(self, mechanism: Mechanism) -> list[RestPose]:
        return rest_poses(mechanism)

    def start(self, rest: RestPose, play: bool) -> None:
        self.port.set_start_pose(rest.q.copy(), np.zeros_like(rest.q), play=play)

    def show_notice(self, title: str, body: str, color: str = "red", seconds: float | None = None) -> None:
        self.port.show_notice(title, body, color=color)


class RestPositionsPanel:
    """A Find button, the list (a dropdown), and Go buttons, in the current GUI container of ``gui``.
    ``bind(handle, action)`` attaches a callback inside the session's error boundary; ``source`` is a chain's
    (``ChainRests(port)``, the default for a chain's ``port``) or a mechanism's (:class:`MechanismRests`)."""

    def __init__(self, port: RestPort | None, gui, bind: Callable, source: RestSource | None = None) -> None:
        if source is None:
            if port is None:
                raise ValueError("a rest panel needs its session (port) or a source")
            source = ChainRests(port)
        self.source = source
        self.rests: list = []  # RestPosition (a chain) or RestPose (a mechanism), lowest potential first
        self._model = None  # the chain or mechanism the list was found for
        self._shown_for: object | None = None  # the one the panel's content is about (a search running, its list or refusal)
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
        model = self.source.current()
        with self._lock:
            if self._job is not None and self._job.is_alive():
                return
            generation = self._generation
            self._shown_for = model
            self._job = threading.Thread(target=self._work, args=(model, generation), daemon=True,
                                         name="rest-positions")
            self.status.content = "**Finding** the rest positions..."
            self._job.start()

    def _work(self, model, generation: int) -> None:
        try:
            found = self.source.find(model)
        except LinkageError as error:
            with self._lock:  # a refusal for a mechanism no longer shown is dropped, as a late list is
                if generation == self._generation:
                    self.status.content = f"No list: {markdown_literal(error)}"
            return
        except Exception as error:  # noqa: BLE001 (a worker's failure becomes a line in the panel, never a dead thread)
            with self._lock:
                if generation == self._generation:
                    self.status.content = ("Finding the rest positions failed: "
                                           f"{markdown_literal(type(error).__name__)}")
            self.source.show_notice("Rest positions failed", f"{type(error).__name__}: {error}", color="red")
            return
        with self._lock:
            if generation != self._generation:
                return
            self.rests = found
            self._model = model
            labels = tuple(rest_label(k + 1, r) for k, r in enumerate(found)) or (NO_LIST,)
            self.choice.options = labels
            self.choice.value = labels[0]
            stable = sum(r.stable for r in found)
            self.status.content = (f"{len(found)} rest positions ({stable} stable), lowest potential energy first. "
                                   "Pick one and jump there: speeds 0, t = 0.")

    def wait(self, timeout: float = 60.0) -> None:
        """Wait for a running search (tests)."""
        job = self._job
        if job is not None:
            job.join(timeout)

    def forget(self) -> None:
        """The mechanism changed: the list no longer applies."""
        with self._lock:
            self._generation += 1
            self._shown_for = None
            self.rests = []
            self.choice.options = (NO_LIST,)
            self.choice.value = NO_LIST
            self.status.content = "Where the mechanism can stay at rest (potential energy V stationary), stable or not."

    def forget_if_stale(self) -> None:
        """Forget the list (or the search running, or its refusal) if it is about another mechanism (or other
        numbers) than the one in force; a Reset of the same one keeps it."""
        if self._shown_for is not None and self.source.current() != self._shown_for:
            self.forget()

    # ------------------------------------------------------------------ jumping
    def index_of(self, label: str) -> int:
        labels = [rest_label(k + 1, r) for k, r in enumerate(self.rests)]
        if label not in labels:
            raise LinkageError("rest position: press 'Find rest positions' first, then pick one")
        return labels.index(label)

    def jump(self, index: int, play: bool = False) -> None:
        """Start again from rest position ``index`` (0-based in :attr:`rests`) with every speed 0."""
        if not 0 <= index < len(self.rests):
            raise LinkageError(f"rest position = {index + 1}: allowed 1 <= rest position <= {len(self.rests)}")
        if self.source.current() != self._model:
            raise LinkageError("rest position: the mechanism's parameters changed since the list was found; "
                               "press 'Find rest positions' again")
        self.source.start(self.rests[index], play)
