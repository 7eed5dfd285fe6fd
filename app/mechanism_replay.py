"""A run as a self-contained HTML replay page (what ``app.show(run, ...)`` and "download replay" give).

Every linkage is drawn as the app's view draws it (:class:`app.mechanism_scene.MechanismScene`: every body's
bars and points, the ground, the sliders' guides) on the private recording server of :mod:`app.replay`, under
its lock, frame by frame. A chain's run is drawn as the mechanism it is (:func:`physics.mechanism.chains.chain_mechanism`),
so a chain's page and a mechanism's are one drawing.
"""

from __future__ import annotations

import numpy as np

from physics import Chain
from physics.mechanism.chains import chain_mechanism

from .mechanism_runs import Drawing, centres_at, drawing, points_at
from .mechanism_scene import MechanismScene
from .overlays import TraceLine
from .replay import REPLAY_FPS, REPLAY_MAX_SECONDS, SOURCE_RATE, TRACE_SECONDS, recording_server
from .scene import camera_pose, pose_disc


def mechanism_replay_html(draw: Drawing, history: dict[str, np.ndarray], title: str = "Linkage Lab replay",
                          rate: float = SOURCE_RATE) -> str:
    """HTML replay of ``history`` (``t (T,)``, ``q (T, 3 B)``, ``trace_xy (T, 2)``, NaN without a traced point),
    ``rate`` samples per second, of the mechanism drawn by ``draw`` (:func:`app.mechanism_runs.drawing`)."""
    t = history["t"]
    if len(t) < 2:
        raise ValueError("nothing to replay yet: fewer than two samples")
    stride = max(1, int(round(rate / REPLAY_FPS)))
    first = max(0, len(t) - int(REPLAY_MAX_SECONDS * rate))
    points = points_at(draw, history["q"][first:])  # (T', P, 2)
    centres = centres_at(history["q"][first:])  # (T', B, 2)
    trace_xy = np.asarray(history["trace_xy"], dtype=float)
    traced = bool(np.all(np.isfinite(trace_xy[first:])))
    centre, radius = pose_disc(np.concatenate([points.reshape(-1, 2), draw.ground]), margin=1.3)  # the whole run
    trace_samples = int(TRACE_SECONDS * rate)
    with recording_server() as server:
        position, look_at = camera_pose(np.zeros(1), None, disc=(centre, radius))
        server.initial_camera.position = tuple(position)
        server.initial_camera.look_at = tuple(look_at)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        server.scene.add_grid("/floor", width=20.0, height=20.0, plane="xy", cell_size=0.25, section_size=1.0,
                              position=(float(centre[0]), 0.0, float(centre[1]) - 1.08 * radius))
        scene = MechanismScene(server, "/linkage")
        scene.build(draw, points[0], centres[0])
        trace = TraceLine(server.scene, "/linkage/trace")
        server.scene.add_label("/title", title, position=(look_at[0], 0.0, look_at[2] + 1.05 * radius))
        serializer = server.get_scene_serializer()
        for i in range(first, len(t), stride):
            scene.show(points[i - first], centres[i - first])
            if traced:
                trace.update(trace_xy[max(first, i - trace_samples) : i + 1])
            serializer.insert_sleep(stride / rate)
        return serializer.as_html()


def chain_replay_html(history: dict[str, np.ndarray], chain: Chain, title: str = "Linkage Lab replay",
                      rate: float = SOURCE_RATE) -> str:
    """HTML replay of a chain's ``history`` (``t (T,)``, ``joints (T, n + 1, 2)``, ``trace_xy (T, 2)``) of
    ``chain``: each bar's pose read off its two joints (centre of mass at ``d`` along it, its absolute angle),
    drawn as the chain's mechanism sketched at the first sample."""
    joints = np.asarray(history["joints"], dtype=float)
    if len(history["t"]) < 2:
        raise ValueError("nothing to replay yet: fewer than two samples")
    along = joints[:, 1:] - joints[:, :-1]  # (T, n, 2): L (sin theta, -cos theta)
    theta = np.arctan2(along[..., 0], -along[..., 1])
    share = chain.array("d") / chain.array("L")  # lengths are validated positive
    centres = joints[:, :-1] + share[None, :, None] * along
    sketch = theta[0]
    q = np.concatenate([centres, (theta - sketch)[..., None]], axis=2).reshape(len(joints), -1)
    samples = {"t": history["t"], "q": q, "trace_xy": history["trace_xy"]}
    return mechanism_replay_html(drawing(chain_mechanism(chain, sketch)), samples, title=title, rate=rate)
