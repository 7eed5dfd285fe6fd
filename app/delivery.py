"""Whether a browser has been sent everything queued for it: the player's cue to render the next frame.

A session's player thread turns frames into viser messages; viser's event-loop thread serialises, compresses
and sends them, one window per client at most 60 times a second. When that thread falls behind (many
sessions in one interpreter, a loaded machine, a slow network), a new pose replaces the unsent one in the
client's buffer: the frame was rendered for nothing, and the rendering took the interpreter lock from the
thread that sends. Measured with 100 own sessions on two cores (docs/reliability.md): the players rendered
three frames for each one a browser received. So a player renders the next frame only when the previous one
has left the buffer; the frame rate then follows what can really be delivered.
"""

from __future__ import annotations

from . import viser_compat


def caught_up(client) -> bool:
    """True when nothing queued for ``client`` waits to be sent (viser's buffer, read behind the one door)."""
    return viser_compat.client_caught_up(client)
