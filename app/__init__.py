"""Linkage Lab in the browser: a viser server that animates planar linkages live.

``python -m app`` starts it (see :mod:`app.__main__`); :class:`app.server.LabServer` is the same server for
tests and scripts. The package imports only what ``physics`` exports, plus viser; nothing here integrates
equations of motion.
"""
