"""What a session hands out: its stored history, the files it offers for download, its JSON snapshot.

Why apart from the session: these read the player's ring buffers and the parameters in force and change
nothing; the session's own module stays about changes and lifetime.
"""

from __future__ import annotations

from physics import LinkageError

from . import export, share
from .divergence import REFERENCE_LABEL
from .replay import replay_html


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
        return replay_html(samples, params, title=f"Linkage Lab replay: {label}")
    except ValueError as error:
        raise LinkageError(str(error)) from None


def download_file(session, kind: str) -> tuple[str, bytes]:
    """``(file name, content)`` of a download: the run as ``csv``, ``json``, ``html`` replay, or the equations
    as ``tex``."""
    p = session.params
    stem = f"linkage-{p.preset}-{p.method}"
    if kind == "csv":
        return f"{stem}.csv", export.to_csv(session.history(), p)
    if kind == "json":
        return f"{stem}.json", export.to_json(session.history(), p, session.run_label())
    if kind == "html":
        return f"{stem}-replay.html", replay(session.history(), p, session.run_label()).encode("utf-8")
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


def snapshot(session) -> dict:
    """JSON-able state of a session (tests and ``python -m app snapshot --json``)."""
    player = session.player
    with player.lock:
        runs = {run.spec.label: run for run in player.runs}
        out_runs = []
        reference = None  # compare mode's converged run (app/divergence.py): not one of the runs shown
        for run in player.runs:
            ring = run.ring
            if len(ring) == 0:
                continue
            i = ring.index_at(player.display_time)
            entry = (
                {
                    "label": run.spec.label,
                    "method": run.spec.settings.method,
                    "t": float(ring.t_first + i * ring.dt),
                    "theta": [float(v) for v in ring.get("theta", i)],
                    "omega": [float(v) for v in ring.get("omega", i)],
                    "joints": [[float(x), float(y)] for x, y in ring.get("joints", i)],
                    "trace_xy": [float(v) for v in ring.get("trace_xy", i)],
                    "samples_stored": len(ring),
                    "simulated_until": ring.t_last,
                    "failed": run.failed,
                }
            )
            if run.spec.label == REFERENCE_LABEL:
                reference = entry
            else:
                out_runs.append(entry)
        view = session.view
        nodes = view.scene_nodes()
        main = out_runs[0] if out_runs else None
        return {
            "session": session.id,
            "shared": session.shared,
            "parameters": session.params.as_dict(),
            "method": session.params.method,
            "compare": session.compare,
            "playing": player.playing,
            "speed": player.speed,
            "time": float(player.display_time),
            "theta": main["theta"] if main else None,
            "omega": main["omega"] if main else None,
            "joints": main["joints"] if main else None,
            "energy": view.current_values(runs),
            "runs": out_runs,
            "reference": reference,
            "notice": session.notice,
            "frames_sent": view.frames_sent,
            "scene": {"root": view.scene.root, "nodes": nodes, "names": sorted(nodes)},
        }
