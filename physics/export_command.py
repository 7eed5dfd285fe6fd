"""``python -m physics export``: a mechanism written in another tool's format, or another tool's file read in.

    python -m physics export --preset slider-crank --format mjcf --out sc.xml          # MuJoCo's MJCF
    python -m physics export --preset triple-a --format mjcf --out triple.xml          # a chain preset too
    python -m physics export --mechanism my.toml --format pylinkage --out my.json      # pylinkage's JSON
    python -m physics export --pylinkage four_bar.json --format toml --out four_bar.toml   # read pylinkage's

One command in both directions: the input is ``--preset`` (a mechanism or chain preset), ``--mechanism`` (our
file) or ``--pylinkage`` (pylinkage's JSON), the output ``--format`` mjcf, pylinkage, toml or json (our own
format, which ``python -m physics mechanism --file`` runs). Without ``--out`` the document goes to stdout.
Why a module apart from physics/cli.py: it is loaded by name only when asked for, like the other long-tail
subcommands, so ``simulate`` does not import it. Bad input is one line and exit 2 (printed by physics.cli).
"""

from __future__ import annotations

import json
import sys

from .arguments import Parser
from .chain_presets import get_preset, preset_names
from .errors import LinkageError
from .file_io import read_limited
from .mechanism.chains import chain_mechanism
from .mechanism.description import Mechanism
from .mechanism.files import MAX_FILE_BYTES, load_mechanism
from .mechanism.mjcf import MAX_TIMESTEP, MJCF_TIMESTEP, to_mjcf
from .mechanism.presets import MECHANISM_PRESETS
from .mechanism.pylinkage_format import DENSITY_NOTE, mechanism_from_pylinkage, to_pylinkage
from .mechanism.writer import to_json, to_toml
from .model import MAX_LINKS
from .outputs import check_output_path, write_output

FORMATS = ("mjcf", "pylinkage", "toml", "json")
PYLINKAGE_EXPORT_NOTE = ("note: pylinkage's JSON holds no masses, inertias, damping or gravity; only the geometry, "
                         "the joints and the speed motors are written")


def read_pylinkage(path: str) -> Mechanism:
    """A pylinkage JSON file as a Mechanism (read as our own files are: a regular file of at most MAX_FILE_BYTES,
    never a device or a FIFO, UTF-8)."""
    content = read_limited(path, MAX_FILE_BYTES, f"--pylinkage {path}")
    try:
        document = json.loads(content.decode("utf-8"))
    except UnicodeDecodeError:
        raise LinkageError(f"--pylinkage {path}: not UTF-8 text") from None
    except (ValueError, RecursionError) as error:
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise LinkageError(f"--pylinkage {path}: not valid JSON ({first})") from None
    return mechanism_from_pylinkage(document, path)


def _mechanism(args) -> Mechanism:
    given = [option for option in ("preset", "mechanism", "pylinkage") if getattr(args, option) is not None]
    if len(given) != 1:
        raise LinkageError("give exactly one of --preset NAME, --mechanism FILE.toml|.json or --pylinkage FILE.json")
    if args.links is not None and args.preset != "chain":
        raise LinkageError(f"--links {args.links}: applies to --preset chain only")
    if args.pylinkage is not None:
        mechanism = read_pylinkage(args.pylinkage)
        print(DENSITY_NOTE, file=sys.stderr)
        return mechanism
    if args.mechanism is not None:
        return load_mechanism(args.mechanism)
    if args.preset in MECHANISM_PRESETS:
        return MECHANISM_PRESETS[args.preset]()
    if args.preset in preset_names():
        if args.links is not None and not 1 <= args.links <= MAX_LINKS:
            raise LinkageError(f"--links {args.links}: allowed range 1..{MAX_LINKS}")
        preset = get_preset(args.preset, args.links)
        # the chain drawn at the preset's starting angles (a mechanism file has no velocities: at rest)
        return chain_mechanism(preset.chain, preset.theta0).model_copy(update={"name": preset.name})
    known = ", ".join([*sorted(MECHANISM_PRESETS), *preset_names()])
    raise LinkageError(f"--preset {args.preset!r}: allowed {known}")


def main(argv: list[str]) -> int:
    parser = Parser(prog="python -m physics export",
                    description="write a mechanism as MJCF (MuJoCo), pylinkage's JSON or our own TOML/JSON, or read "
                    "pylinkage's JSON (docs/mechanisms.md, 'Other tools' formats')")
    parser.add_argument("--preset", default=None, help="a mechanism preset or a chain preset")
    parser.add_argument("--links", type=int, default=None, help=f"with --preset chain: its bars (1..{MAX_LINKS})")
    parser.add_argument("--mechanism", default=None, metavar="FILE", help="our mechanism file, .toml or .json")
    parser.add_argument("--pylinkage", default=None, metavar="FILE", help="pylinkage's JSON (mechanism_to_json)")
    parser.add_argument("--format", required=True, help=f"what to write: {', '.join(FORMATS)}")
    parser.add_argument("--out", default=None, help="the file to write (default: stdout)")
    parser.add_argument("--timestep", type=float, default=MJCF_TIMESTEP,
                        help=f"with --format mjcf: MuJoCo's time step, s (0 < timestep <= {MAX_TIMESTEP}; default "
                        f"{MJCF_TIMESTEP})")
    args = parser.parse_args(argv)
    if args.format not in FORMATS:
        raise LinkageError(f"--format {args.format!r}: allowed {', '.join(FORMATS)}")
    if args.timestep != MJCF_TIMESTEP and args.format != "mjcf":
        raise LinkageError("--timestep: applies to --format mjcf only")
    if not (0 < args.timestep <= MAX_TIMESTEP):  # also refuses nan
        raise LinkageError(f"--timestep {args.timestep!r}: allowed 0 < timestep <= {MAX_TIMESTEP} s")
    if args.out is not None:
        check_output_path(args.out)
    mechanism = _mechanism(args)
    if args.format == "mjcf":
        text = to_mjcf(mechanism, args.timestep)
    elif args.format == "pylinkage":
        text = json.dumps(to_pylinkage(mechanism), indent=2) + "\n"
        print(PYLINKAGE_EXPORT_NOTE, file=sys.stderr)
    elif args.format == "toml":
        text = to_toml(mechanism)
    else:
        text = to_json(mechanism)
    if args.out is None:
        sys.stdout.write(text)
    else:
        write_output(args.out, text.encode("utf-8"))
        print(f"wrote {args.out} ({args.format}, {mechanism.name})", file=sys.stderr)
    return 0
