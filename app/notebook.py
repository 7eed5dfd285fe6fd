"""A run shown inline in a Jupyter notebook as a 3D replay, or in a browser page from a script.

``physics`` never imports viser or the app (the import contracts of pyproject.toml), so the notebook's door is
here, exposed as ``app.show(run, chain)`` for a chain's run and ``app.show(run, mechanism)`` for a general
mechanism's (both runs are a :class:`physics.Trajectory`): the run is drawn by the app's own scene on viser's
recording server and serialised into one self-contained HTML page (:mod:`app.mechanism_replay`, the same page the app's
"download replay" gives, a chain drawn as the mechanism it is). In IPython (Jupyter, JupyterLab, VS Code) the page is displayed inline in an iframe; elsewhere it is
written to a temporary file and opened in the default browser.
"""

from __future__ import annotations

import html
import tempfile
import webbrowser

import numpy as np

from physics import Chain, LinkageError, Trajectory
from physics.mechanism import Mechanism

from .mechanism_replay import chain_replay_html, mechanism_replay_html
from .mechanism_runs import drawing


def _samples_per_second(t: np.ndarray) -> float:
    span = float(t[-1] - t[0])
    if not span > 0.0:
        raise LinkageError("run: nothing to replay, its samples span no time (at least two distinct times)")
    return (len(t) - 1) / span


def replay_page(run: Trajectory, model: Chain | Mechanism, title: str | None = None) -> str:
    """The self-contained HTML page replaying ``run`` (the last 30 simulated seconds at most) of ``model``: the
    chain a chain's run was made of, or the mechanism of a mechanism's run."""
    if not isinstance(run, Trajectory):
        raise LinkageError(f"run: a physics.Trajectory (what physics.simulate returns), not {type(run).__name__}")
    if len(run.t) < 2:
        raise LinkageError(f"run: at least two samples to replay, it holds {len(run.t)}")
    label = title or f"Linkage Lab: {run.method}, {run.t[-1] - run.t[0]:g} s"
    if run.is_mechanism:
        return _mechanism_page(run, model, label)
    if not isinstance(model, Chain):
        raise LinkageError(f"chain: the physics.Chain of the run (a chain's run), not {type(model).__name__}")
    if run.joints.shape[1] != model.n + 1:
        raise LinkageError(f"chain: the run has {run.joints.shape[1] - 1} bars, the chain {model.n}")
    history = {"t": run.t, "joints": run.joints, "trace_xy": run.trace_xy}
    return chain_replay_html(history, model, title=label, rate=_samples_per_second(run.t))


def _mechanism_page(run: Trajectory, mechanism, label: str) -> str:
    """A mechanism's run drawn by its mechanism."""
    if not isinstance(mechanism, Mechanism):
        raise LinkageError(f"mechanism: the physics.mechanism.Mechanism of the run (a mechanism's run), not "
                           f"{type(mechanism).__name__}")
    if 3 * len(mechanism.bodies) != run.q.shape[1]:
        raise LinkageError(f"mechanism: the run has {run.bodies} bodies, {mechanism.name} "
                           f"{len(mechanism.bodies)}")
    history = {"t": run.t, "q": run.q, "trace_xy": run.trace_xy}
    return mechanism_replay_html(drawing(mechanism), history, title=label, rate=_samples_per_second(run.t))


def _ipython():
    try:
        from IPython.core.getipython import get_ipython  # type: ignore[import-not-found]  # noqa: PLC0415
    except ImportError:
        return None
    return get_ipython()


def show(run: Trajectory, model: Chain | Mechanism, *, height: int = 420, title: str | None = None) -> str | None:
    """Show ``run`` of ``model`` (its chain, or its mechanism) as a 3D replay: inline under the cell in a notebook
    (returns None), else in a browser page written to a temporary file (returns its path)."""
    page = replay_page(run, model, title)
    if _ipython() is not None:
        from IPython.display import HTML, display  # type: ignore[import-not-found]  # noqa: PLC0415

        frame = (f'<iframe srcdoc="{html.escape(page, quote=True)}" width="100%" height="{int(height)}" '
                 'style="border:1px solid #ddd"></iframe>')
        display(HTML(frame))
        return None
    with tempfile.NamedTemporaryFile("w", suffix=".html", prefix="linkage-lab-replay-", delete=False,
                                     encoding="utf-8") as handle:
        handle.write(page)
    webbrowser.open("file://" + handle.name)
    return handle.name
