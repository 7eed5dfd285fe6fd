"""Linkage Lab in the browser: a viser server that animates planar linkages live.

``python -m app`` starts it (see :mod:`app.__main__`); :class:`app.server.LabServer` is the same server for
tests and scripts. The package imports only what ``physics`` exports, plus viser; nothing here integrates
equations of motion.
"""


def show(run, model, **options):
    """Show a :class:`physics.Trajectory` of ``model`` (the chain of a chain's run, the ``physics.mechanism``
    Mechanism of a mechanism's) as a 3D replay: inline in a notebook, else in a browser (:func:`app.notebook.show`;
    imported on first use, so ``import app`` stays light)."""
    from .notebook import show as show_run  # noqa: PLC0415

    return show_run(run, model, **options)
