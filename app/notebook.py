"""A run shown inline in a Jupyter notebook as a 3D replay, or in a browser page from a script.

``physics`` never imports viser or the app (the import contracts of pyproject.toml), so the notebook's door is
here, exposed as ``app.show(run, chain)``: the run is drawn by the app's own scene on viser's recording server
and serialised into one self-contained HTML page (:mod:`app.replay`), the same page the app's "download replay"
gives. In IPython (Jupyter, JupyterLab, VS Code) the page is displayed inline in an iframe; elsewhere it is
written to a temporary file and opened in the default browser.
"""

from __future__ import annotations

import html
import tempfile
import webbrowser
from types import SimpleNamespace

import numpy as np

from physics import Chain, LinkageError, Trajectory

from .replay import replay_html


def _samples_per_second(t: np.ndarray) -> float:
    span = float(t[-1] - t[0])
    if not span > 0.0:
        raise LinkageError("run: nothing to replay, its samples span no time (at least two distinct times)")
    return (len(t) - 1) / span


def replay_page(run: Trajectory, chain: Chain, title: str | None = None) -> str:
    """The self-contained HTML page replaying ``run`` (the last 30 simulated seconds at most) of ``chain``."""
    if not isinstance(run, Trajectory):
        raise LinkageError(f"run: a physics.Trajectory (what physics.simulate returns), not {type(run).__name__}")
    if len(run.t) < 2:
        raise LinkageError(f"run: at least two samples to replay, it holds {len(run.t)}")
    if run.joints.shape[1] != chain.n + 1:
        raise LinkageError(f"chain: the run has {run.joints.shape[1] - 1} bars, the chain {chain.n}")
    history = {"t": run.t, "joints": run.joints, "trace_xy": run.trace_xy}
    params = SimpleNamespace(L=chain.array("L"), d=chain.array("d"), pin=chain.pin)
    label = title or f"Linkage Lab: {run.method}, {run.t[-1] - run.t[0]:g} s"
    return replay_html(history, params, title=label, rate=_samples_per_second(run.t))


def _ipython():
    try:
        from IPython.core.getipython import get_ipython  # type: ignore[import-not-found]  # noqa: PLC0415
    except ImportError:
        return None
    return get_ipython()


def show(run: Trajectory, chain: Chain, *, height: int = 420, title: str | None = None) -> str | None:
    """Show ``run`` as a 3D replay: inline under the cell in a notebook (returns None), else in a browser page
    written to a temporary file (returns its path)."""
    page = replay_page(run, chain, title)
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
