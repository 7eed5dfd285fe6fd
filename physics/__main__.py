"""``python -m physics`` -> :func:`physics.cli.main`, then the exit of :mod:`physics.process_exit` (the command's
exit code without the interpreter's teardown: a sixth of a new mechanism's first run)."""

from .cli import main
from .process_exit import exit_without_teardown

exit_without_teardown(int(main() or 0))
