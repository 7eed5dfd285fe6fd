"""The seed-report companion commands of ``python -m physics``: ``fbd``, ``equilibrium`` and ``seed-report``.

Each is a ``main(argv) -> exit code`` that :mod:`physics.cli` dispatches to; bad input raises
:class:`LinkageError`, which the CLI prints as one line with exit code 2.

    python -m physics fbd --preset triple-a --time 2.5 --bar 2 --out fbd.svg [--json]
    python -m physics equilibrium --preset four-bar [--json]
    python -m physics seed-report --out docs/seed-report [--quick]
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from .arguments import Parser
from .chain_presets import get_preset, preset_names
from .fbd import MAX_FBD_TIME, fbd_svg, free_body_at
from .outputs import check_output_folder, check_output_path, write_output
from .rest_positions import rest_positions
from .seed_report import print_summary, write_study


def _preset_options(parser: Parser, default: str) -> None:
    parser.add_argument("--preset", default=default, choices=preset_names())
    parser.add_argument("--links", type=int, default=None, help="number of bars for --preset chain (1..12)")


def fbd_main(argv: list[str]) -> int:
    """Free-body diagram of one bar at one instant of a preset's run: SVG (``--out``), JSON (``--json``),
    or a short text listing of the forces."""
    parser = Parser(prog="python -m physics fbd",
                     description="forces on one bar at one instant (gravity, joint reactions, pin reaction)")
    _preset_options(parser, "triple-a")
    parser.add_argument("--time", type=float, default=0.0, help=f"instant of the run, 0..{MAX_FBD_TIME:g} s")
    parser.add_argument("--bar", type=int, default=1, help="bar number, 1..n")
    parser.add_argument("--out", default=None, help="write the diagram to this SVG file")
    parser.add_argument("--json", action="store_true", help="print the forces and the balance as JSON")
    args = parser.parse_args(argv)
    preset = get_preset(args.preset, args.links)
    if args.out is not None:
        check_output_path(args.out, suffixes=(".svg",))
    body = free_body_at(preset.chain, preset.theta0, preset.omega0, args.time, args.bar)
    if args.out:
        title = f"{preset.name}: bar {body.bar} at t = {body.time:g} s"
        write_output(args.out, fbd_svg(body, title=title).encode("utf-8"))
    if args.json:
        print(json.dumps({"preset": preset.name, **body.as_dict()}))
    elif not args.out:
        print(f"{preset.name}, bar {body.bar} at t = {body.time:g} s (theta = {math.degrees(body.theta):.3f} deg):")
        for force in body.forces:
            print(f"  {force.name:<32} at {force.point:<3} F = ({force.force[0]: .6g}, {force.force[1]: .6g})")
        net, m_a = body.net_force(), body.mass * body.com_acceleration
        print(f"  sum F = ({net[0]:.6g}, {net[1]:.6g}); m a_G = ({m_a[0]:.6g}, {m_a[1]:.6g})")
        print(f"  sum M about G = {body.net_moment_about_com():.6g}; I alpha = {body.inertia * body.alpha:.6g}")
    return 0


def equilibrium_main(argv: list[str]) -> int:
    """The rest positions of a preset's chain: angles in degrees, stable or not, potential energy."""
    parser = Parser(prog="python -m physics equilibrium",
                     description="rest positions of a chain: angles, stability, potential energy")
    _preset_options(parser, "four-bar")
    parser.add_argument("--json", action="store_true", help="print as JSON")
    args = parser.parse_args(argv)
    preset = get_preset(args.preset, args.links)
    positions = rest_positions(preset.chain)
    if args.json:
        print(json.dumps({"preset": preset.name, "pin": preset.chain.pin,
                          "rest_positions": [p.as_dict() for p in positions]}))
        return 0
    pin = preset.chain.pin
    closure = f"tip pinned at ({pin[0]:.6g}, {pin[1]:.6g})" if pin is not None else "open chain"
    print(f"{preset.name} ({closure}): {len(positions)} rest positions, lowest potential energy first")
    header = "  ".join(f"theta{i + 1} (deg)".rjust(13) for i in range(preset.chain.n))
    print(f"{header}  {'stable':>6}  {'V':>12}")
    for p in positions:
        angles = "  ".join(f"{math.degrees(v):13.4f}" for v in p.theta)
        print(f"{angles}  {'yes' if p.stable else 'no':>6}  {p.potential:12.6f}")
    return 0


def seed_report_main(argv: list[str]) -> int:
    """Replay the seed report's figures at its settings beside converged runs; write SVGs and JSON; print."""
    parser = Parser(prog="python -m physics seed-report",
                     description="the seed report's figures at its own settings, beside converged runs")
    parser.add_argument("--out", default="docs/seed-report", help="folder for the SVG figures and seed-report.json")
    parser.add_argument("--quick", action="store_true", help="short horizons (a check that it runs, not the figures)")
    args = parser.parse_args(argv)
    check_output_folder(args.out)
    out = Path(args.out)
    document = write_study(out, quick=args.quick)
    print_summary(document, sys.stdout)
    return 0
