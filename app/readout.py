"""What a session hands out: its stored history, the files it offers for download, its JSON snapshot.

Why apart from the session: these read the player's ring buffers and the parameters in force and change
nothing; the session's own module stays about changes and lifetime.
"""

from __future__ import annotations

from typing import Callable

from physics import LinkageError

from . import export, share
from .divergence import REFERENCE_LABEL


def history(player, label: str = "main") -> dict:
    """The stored samples of run ``label`` (or the first) up to the displayed time, as arrays."""
    with player.lock:
        runs = {run.spec.label: run for run in player.runs}
        run = runs.get(label) or (player.runs[0] if player.runs else None)
        if run is None or len(run.ring) == 0:
            raise LinkageError("nothing to export yet: the simulation has not produced samples")
        i = run.ring.index_at(player.display_time)
        return run.ring.window(0, i)


def replay(samples: dict, params, label: str) -> str:
    """The HTML replay of ``samples``; a run too short to replay is a refusal (LinkageError), not a fault."""
    try:
        from .mechanism_replay import chain_replay_html  # noqa: PLC0415 - the recorder: on export only

        return chain_replay_html(samples, params.chain, title=f"Linkage Lab replay: {label}")
    except ValueError as error:
        raise LinkageError(str(error)) from None


def download_file(session, kind: str) -> tuple[str, bytes]:
    """``(file name, content)`` of a download: the run as ``csv``, ``json``, ``html`` replay, or the equations
    as ``tex``."""
    return run_download(session.params, kind, session.history, session.run_label())


def run_download(p, kind: str, history: Callable[[], dict], label: str) -> tuple[str, bytes]:
    """:func:`download_file` of a chain's parameters ``p``, its stored history (``history()``: read only for the
    run's files) and its run's ``label``: a chain session's, or a chain hosted as a mechanism
    (app/chain_contract.py), written by the same code."""
    stem = f"linkage-{p.preset}-{p.method}"
    if kind == "csv":
        return f"{stem}.csv", export.to_csv(history(), p)
    if kind == "json":
        return f"{stem}.json", export.to_json(history(), p, label)
    if kind == "html":
        return f"{stem}-replay.html", replay(history(), p, label).encode("utf-8")
    if kind == "setup":
        return f"linkage-{p.preset}-setup.json", share.state_document(p)
    if kind == "tex":
        from . import equations  # noqa: PLC0415 - imports sympy: only when asked for

        try:
            text = equations.equations_tex(p.chain, p.method)
        except ValueError as error:
            raise LinkageError(str(error)) from None
        return f"equations-{p.method}-{p.n}{'-pinned' if p.pinned else ''}.tex", text.encode("utf-8")
    raise LinkageError(f"download = {kind!r}: allowed csv, json, html, setup, tex")


RUN_SAMPLE_FIELDS = ("theta", "omega", "joints", "trace_xy")  # a snapshot's run at its displayed sample


def ring_sample(run, i: int) -> dict:
    """Stored sample ``i`` of a chain's run, read from its own ring (its fields are the chain's)."""
    return {name: run.ring.get(name, i) for name in RUN_SAMPLE_FIELDS}


def snapshot(session) -> dict:
    """JSON-able state of a session (tests and ``python -m app snapshot --json``)."""
    view = session.view
    return snapshot_document(
        session_id=session.id, shared=session.shared, params=session.params, compare=session.compare,
        player=session.player, notice=session.notice, sample_of=ring_sample, energy=view.current_values,
        frames_sent=lambda: view.frames_sent, scene=lambda: {"root": view.scene.root, "nodes": view.scene_nodes()})


def snapshot_document(*, session_id, shared: bool, params, compare: bool, player, notice, sample_of: Callable,
                      energy: Callable[[dict], dict], frames_sent: Callable[[], int],
                      scene: Callable[[], dict]) -> dict:
    """:func:`snapshot` of a chain's parameters ``params`` and ``player``: ``sample_of(run, i)`` is a run's stored
    sample ``i`` in the chain's fields (:func:`ring_sample`, or a chain hosted as a mechanism mapped by
    app/chain_contract.py), ``energy(runs by label)`` the view's current values, ``frames_sent()`` and
    ``scene()`` (root and nodes) the view's; the callables are called under the player's lock."""
    with player.lock:
        runs = {run.spec.label: run for run in player.runs}
        out_runs = []
        reference = None  # compare mode's converged run (app/divergence.py): not one of the runs shown
        for run in player.runs:
            ring = run.ring
            if len(ring) == 0:
                continue
            i = ring.index_at(player.display_time)
            sample = sample_of(run, i)
            if sample is None:  # a run being replaced by another mechanism's (sample_of names when)
                continue
            entry = (
                {
                    "label": run.spec.label,
                    "method": run.spec.settings.method,
                    "t": float(ring.t_first + i * ring.dt),
                    "theta": [float(v) for v in sample["theta"]],
                    "omega": [float(v) for v in sample["omega"]],
                    "joints": [[float(x), float(y)] for x, y in sample["joints"]],
                    "trace_xy": [float(v) for v in sample["trace_xy"]],
                    "samples_stored": len(ring),
                    "simulated_until": ring.t_last,
                    "failed": run.failed,
                }
            )
            if run.spec.label == REFERENCE_LABEL:
                reference = entry
            else:
                out_runs.append(entry)
        shown = scene()
        nodes = shown["nodes"]
        main = out_runs[0] if out_runs else None
        return {
            "session": session_id,
            "shared": shared,
            "parameters": params.as_dict(),
            "method": params.method,
            "compare": compare,
            "playing": player.playing,
            "speed": player.speed,
            "time": float(player.display_time),
            "theta": main["theta"] if main else None,
            "omega": main["omega"] if main else None,
            "joints": main["joints"] if main else None,
            "energy": energy(runs),
            "runs": out_runs,
            "reference": reference,
            "notice": notice,
            "frames_sent": frames_sent(),
            "scene": {"root": shown["root"], "nodes": nodes, "names": sorted(nodes)},
        }
