"""What the panel (controls, analysis tab) may ask of a session: a narrow interface instead of the whole Session.

Why: the panel only reads the values in force and asks for changes by name; it must not reach into the
session's player, scene or target. :class:`SessionPort` is that contract (a ``typing.Protocol``; the
:class:`~app.session.Session` satisfies it), so the panel can be built and tested against anything that
offers these few members.
"""

from __future__ import annotations

from typing import Callable, Protocol

import numpy as np

from .parameters import Display, SessionParameters


class SessionPort(Protocol):
    """The session as the panel sees it."""

    id: int
    shared: bool

    @property
    def closed(self) -> bool: ...

    @property
    def setup(self) -> SessionParameters:
        """The parameters in force (immutable)."""

    @property
    def display(self) -> Display: ...

    @property
    def compare(self) -> bool: ...

    @property
    def reactions_on(self) -> bool: ...

    def guard(self, action: Callable[[], object]) -> object:
        """Run a GUI action; an error becomes a notice in this browser."""

    def set(self, name: str, value: object, units: str = ...) -> None:
        """Change one value by its ``--set`` name (see :mod:`app.commands`)."""

    def set_typed(self, name: str, text: str) -> None:
        """Change one value from the text typed into its box, in the control's units."""

    def set_mechanism(self, name: str, links: int | None = None) -> None: ...

    def set_links(self, links: object) -> None: ...

    def set_compare(self, on: bool) -> None: ...

    def set_reactions(self, on: bool) -> None: ...

    def set_camera_view(self, view: str) -> None:
        """Front or 3D view of the mechanism."""

    def play(self) -> None: ...

    def pause(self) -> None: ...

    def step(self) -> None: ...

    def scrub(self, t: object) -> None: ...

    def refresh_plots(self) -> None: ...

    def state_at(self, t: float, exact: bool = False) -> tuple[np.ndarray, np.ndarray] | None: ...

    def reset(self) -> None: ...

    def upload_setup(self, client_id: int | None, name: str, content: bytes) -> None: ...

    def download(self, kind: str, client: object | None) -> None:
        """Send the run (csv, json, html) or the equations (tex) to a browser."""

    def work_precision_chart(self) -> None: ...

    def chaos_map(self) -> None: ...

    def set_ensemble(self, on: bool, count: object | None = None) -> None: ...

    def displayed_state(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """``(t, theta, omega)`` shown now (or the pending start)."""

    def show_notice(self, title: str, body: str, color: str = ..., seconds: float | None = ...) -> None: ...
