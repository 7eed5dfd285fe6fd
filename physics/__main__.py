"""``python -m physics`` -> :func:`physics.cli.main`."""

import sys

from .cli import main

sys.exit(main())
