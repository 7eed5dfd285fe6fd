"""The one error type of Linkage Lab.

Bad input or an impossible request (an unreachable assembly, a singular chain) raises
:class:`LinkageError`; its text names the field, the value and the allowed range or the fix,
so the command line can print it as one line and the app as one notice.
A simulation that fails midway does not raise: its ``Trajectory`` carries ``status`` and ``message``.
"""


class LinkageError(ValueError):
    """Invalid input or impossible request; the message says which field and how to fix it."""
