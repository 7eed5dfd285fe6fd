"""``python -m app`` (console script ``linkage-lab``): serve the app; ``python -m app snapshot ...``: render a PNG.

Bad flags print one line and exit non-zero; the URL printed is the one really served.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from physics import METHOD_NAMES, LinkageError, preset_names
from physics.file_io import read_limited
from physics.mechanism import MECHANISM_PRESETS, Mechanism
from physics.notices import install_stderr_lines
from physics.program import program_name, version_text

from . import lifetime
from .server import DEFAULT_HOST, DEFAULT_MAX_SESSIONS, DEFAULT_PORT, DEFAULT_PRESET, MAX_SESSIONS_LIMIT, is_loopback


class _OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad flag in one line (no usage dump) and exits with status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"linkage-lab: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    """``prog`` defaults to the name typed: ``linkage-lab`` for the console script, else ``python -m app``."""
    prog = prog or program_name("linkage-lab", "python -m app")
    parser = _OneLineParser(
        prog=prog,
        description="Serve Linkage Lab: animate planar linkages live in the browser. "
        f"'{prog} snapshot --help' renders pictures instead.",
    )
    parser.add_argument("--version", action="version", version=version_text())
    parser.add_argument("--host", default=DEFAULT_HOST, help=f"address to listen on (default {DEFAULT_HOST}; "
                        "anything else exposes the app to the network)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT,
                        help=f"port (default {DEFAULT_PORT}; 0 picks a free one; a busy port moves to the next)")
    parser.add_argument("--preset", default=DEFAULT_PRESET, choices=[*preset_names(), *MECHANISM_PRESETS],
                        metavar="NAME", help="mechanism every new session starts with: "
                        + ", ".join([*preset_names(), *MECHANISM_PRESETS]))
    parser.add_argument("--mechanism", default=None, metavar="FILE",
                        help="a mechanism file (TOML or JSON, docs/mechanisms.md) every new session starts with")
    parser.add_argument("--links", type=int, default=None, help="number of bars for --preset chain")
    parser.add_argument("--method", default=None, choices=METHOD_NAMES, metavar="METHOD",
                        help="formulation to start with: " + ", ".join(METHOD_NAMES))
    parser.add_argument("--max-sessions", type=int, default=DEFAULT_MAX_SESSIONS,
                        help="most browsers served at once, each with its own simulation "
                        f"(default {DEFAULT_MAX_SESSIONS}, at most {MAX_SESSIONS_LIMIT})")
    parser.add_argument("--processes", type=int, default=None,
                        help="server processes sharing the port, each serving its share of the browsers "
                        "(default: one per core and one more; --shared uses one)")
    parser.add_argument("--shared", action="store_true",
                        help="one simulation that every browser watches; only the presenter's browser (the address "
                        "printed) changes it (a lecture: the presenter drives, the audience watches)")
    parser.add_argument("--lecture", action="store_true",
                        help="every browser's panel starts in lecture mode: larger text, a wider panel, larger "
                        "chart text (a link's ?lecture=1 does it for one browser; the Display tab switches it)")
    parser.add_argument("--autoplay", action="store_true",
                        help="with --shared: play from the start (by default the shared session waits at t = 0, "
                        "paused, until the presenter presses Play)")
    parser.add_argument("--state", default=None, metavar="FILE",
                        help="a setup saved from the Export tab (JSON): every new session starts from it")
    return parser


def read_state(path: str):
    """``--state FILE`` as read (an :class:`app.share.SavedSetup`): a chain's or a general mechanism's setup;
    LinkageError naming what is wrong."""
    from . import share  # noqa: PLC0415 - imports the models: after the argument check, as the rest of main

    # the real size of a file over the limit, and never a read that blocks (a FIFO) or never ends (/dev/zero)
    data = read_limited(path, share.MAX_STATE_BYTES, f"--state {path}")
    return share.setup_from_state(data, f"--state {path}")


def read_setup(path: str, preset: str, links: int | None) -> list[tuple[str, str]]:
    """``--state FILE`` of a chain: the saved setup's pairs, checked as a whole (LinkageError naming what is
    wrong)."""
    from . import share  # noqa: PLC0415 - imports the models: after the argument check, as the rest of main

    saved = read_state(path)
    if saved.mechanism is not None:
        raise LinkageError(f"--state {path}: mechanism: holds a general mechanism's description, not a chain's setup")
    try:
        share.check_setup(saved.pairs, preset, links)
    except LinkageError as error:
        raise LinkageError(f"--state {path}: {error}") from None
    return saved.pairs


def start_from_state(path: str, preset: str, links: int | None, mechanism: Mechanism | None, label: str | None,
                     from_file: bool) -> tuple[Mechanism | None, str | None, list[tuple[str, str]]]:
    """``--state FILE`` with the start the other flags chose (``mechanism``/``label``: a mechanism preset's or,
    ``from_file``, ``--mechanism``'s; else the chain ``preset``): ``(mechanism, label, pairs)`` every new session
    starts from. The setup's own mechanism (a preset it names, or its description) replaces ``--preset``;
    with ``--mechanism`` it is refused (two mechanisms). Checked as a whole: LinkageError naming the first
    value refused."""
    saved = read_state(path)
    named = saved.preset
    if from_file and (saved.mechanism is not None or named is not None):
        raise LinkageError(f"--state {path}: it names its own mechanism; leave out --mechanism")
    if saved.mechanism is not None:
        mechanism, label = saved.mechanism, saved.label
    elif named is not None and named in MECHANISM_PRESETS:
        mechanism, label = MECHANISM_PRESETS[named](), named
    elif named is not None and named not in preset_names():
        allowed = ", ".join([*preset_names(), *MECHANISM_PRESETS])
        raise LinkageError(f"--state {path}: preset = {named!r}: allowed {allowed}")
    elif named is not None:
        mechanism, label = None, None  # a chain's setup: it replaces a mechanism --preset
    if mechanism is None:
        return None, None, read_setup(path, preset, links)
    from .mechanism_setups import check_mechanism_setup  # noqa: PLC0415 - only for a mechanism

    try:
        check_mechanism_setup(saved.pairs, mechanism)  # it must assemble too (one line naming the joint)
    except LinkageError as error:
        raise LinkageError(f"--state {path}: {error}") from None
    return mechanism, label, saved.pairs


def _announce(args, server) -> None:
    """The address really served, and warnings about it."""
    if not is_loopback(args.host):
        print(f"linkage-lab: warning: listening on {args.host}, not loopback: anyone who can reach this "
              "machine can open the app", file=sys.stderr)
    if args.port not in (0, server.port):
        print(f"linkage-lab: port {args.port} is busy; using {server.port}", file=sys.stderr)
    count = len(server.pids)
    mode = "one shared session" if args.shared else (
        f"up to {args.max_sessions} sessions" + (f" in {count} processes" if count > 1 else ""))
    print(f"Linkage Lab serving at {server.url}  ({mode}; Ctrl+C to stop)", flush=True)
    if server.presenter_url is not None:
        print(f"Presenter (only this browser can change anything; keep it to yourself): {server.presenter_url}",
              flush=True)
        print(f"Viewers: {server.url}", flush=True)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    install_stderr_lines()  # physics' notices (a cache file rebuilt, ...) one line each on stderr, as before
    if argv and argv[0] == "snapshot":
        from . import snapshot  # noqa: PLC0415 - playwright and the browser helpers only for snapshots

        return snapshot.main(argv[1:]) or 0
    args = build_parser().parse_args(argv)
    lifetime.end_on_signals()  # SIGTERM and SIGHUP stop the server as Ctrl+C does (also as PID 1 in a container)
    try:
        from . import warm  # noqa: PLC0415 - the warm-up starts before viser is imported (below)
        from .parameters import SessionParameters  # noqa: PLC0415 - same reason

        mechanism, label = None, None
        if args.mechanism is not None or args.preset in MECHANISM_PRESETS:
            from physics.mechanism.files import load_mechanism  # noqa: PLC0415 - only for a mechanism

            from .mechanism_runs import start_state  # noqa: PLC0415 - same reason

            if args.mechanism is not None:
                mechanism, label = load_mechanism(args.mechanism), Path(args.mechanism).name
            else:
                mechanism, label = MECHANISM_PRESETS[args.preset](), args.preset
            start_state(mechanism)  # it must assemble: one line naming the joint that stays open
            args.preset = DEFAULT_PRESET  # the chain a switch from it starts with
        SessionParameters.from_preset(args.preset, links=args.links, method=args.method)  # fail before warming
        setup: list[tuple[str, str]] = []
        if args.state:
            mechanism, label, setup = start_from_state(args.state, args.preset, args.links, mechanism, label,
                                                       from_file=args.mechanism is not None)
        if mechanism is None:
            warm.start_warm_up(args.preset, args.links, args.method)  # loads compiled code while viser imports
        from .processes import default_processes  # noqa: PLC0415 - imports viser: after the warm-up started
        from .server import LabServer  # noqa: PLC0415 - same reason

        server = LabServer(
            host=args.host,
            port=args.port,
            preset=args.preset,
            links=args.links,
            method=args.method,
            max_sessions=args.max_sessions,
            shared=args.shared,
            warm=False,  # started above
            processes=default_processes() if args.processes is None else args.processes,
            setup=setup,
            mechanism=mechanism,
            mechanism_label=label,
            lecture=args.lecture,
            autoplay=args.autoplay or not args.shared,
        )
    except LinkageError as error:
        print(f"linkage-lab: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # a signal while starting: what was started ends with this process
        return 130
    try:
        _announce(args, server)
        server.serve_forever()  # until Ctrl+C, SIGTERM or SIGHUP: stops the sessions and the sibling processes
    except KeyboardInterrupt:  # a signal before serving began
        server.stop()
    stop_workers = getattr(sys.modules.get("app.mechanism_workers"), "POOL", None)
    if stop_workers is not None:  # a general mechanism's worker processes, if any session started them
        stop_workers.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
