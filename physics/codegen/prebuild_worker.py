"""The worker process of :mod:`physics.codegen.prebuild`: ``python -m physics.codegen.prebuild_worker METHOD N
open|pinned INTEGRATOR`` builds what such a run needs into the shared cache and exits (0: built; 2: bad
arguments or a build that failed, with one line on stderr).

A module of its own because ``import physics`` imports :mod:`physics.codegen.prebuild` (the app's warm-up
functions): run with ``-m``, that module would be imported twice, and runpy warns about it on every start.
"""

from __future__ import annotations

import sys

from ..errors import LinkageError
from .prebuild import prebuild

USAGE = "usage: python -m physics.codegen.prebuild_worker METHOD N open|pinned INTEGRATOR"


def main(argv: list[str]) -> int:
    """The worker's entry point: ``argv`` without the program name; the exit status."""
    if len(argv) != 4 or argv[2] not in ("open", "pinned") or not argv[1].isdigit():
        print(USAGE, file=sys.stderr)
        return 2
    try:
        prebuild(argv[0], int(argv[1]), argv[2] == "pinned", argv[3])
    except (LinkageError, ValueError) as error:
        print("prebuild: " + " ".join(str(error).split()), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
