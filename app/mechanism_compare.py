"""Compare mode for a general mechanism: Newton-Euler, Lagrange and the DAE from one start, side by side.

Why: the three formulations of ``physics.mechanism`` are derived independently (docs/mechanisms.md); run with
the same integrator and tolerance they take the same steps, and where they part the motion is no longer
trustworthy. This is compare mode (with app/divergence.py's plots) for any mechanism, chains included, built
from the chain's parts: the runs are :class:`~app.mechanism_runs.MechanismSpec` labelled by method, plus a
converged reference (the DAE at :data:`~app.divergence.REFERENCE_TOLERANCE`, projected) that only the
divergence plots read; each method is drawn as its own mechanism in its colour, a little apart in depth, with
the chain's colour key; the plots are :class:`~app.divergence.DivergencePlots` fed the traced point.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

import physics
from physics.mechanism import Mechanism

from .divergence import REFERENCE_LABEL, REFERENCE_TOLERANCE, DivergencePlots
from .logs import quietly
from .mechanism_runs import Drawing, MechanismSettings, MechanismSpec, is_reduced
from .mechanism_scene import MechanismScene
from .overlays import METHOD_COLORS, Plot
from .parameters import METHOD_LABELS
from .runs import RunFrame
from .scene import pose_disc

COMPARE_DEPTH_STEP = 0.01  # depth between the compare runs' mechanisms, as a fraction of the reach
COMPARE_METHODS = tuple(physics.FORMULATION_NAMES)  # side by side, in this order

# The chain's visible gap (0.1 m) is for bars of about 1 m; a mechanism's is this fraction of its size
GAP_FRACTION = 0.1


def compare_specs(mechanism: Mechanism, settings: MechanismSettings,
                  runner: Callable[..., object] | None) -> list[MechanismSpec]:
    """The three formulations with the session's stabilisation (projection when the session runs the reduced
    model, which has none), then the converged reference that the divergence plots measure them against."""
    stabilization = "projection" if is_reduced(settings.method) else settings.stabilization
    base = settings.model_copy(update={"stabilization": stabilization})
    first = MechanismSpec(COMPARE_METHODS[0], mechanism, base.model_copy(update={"method": COMPARE_METHODS[0]}),
                          runner=runner)
    rows = first.row_names  # the same joints for every formulation: counted once
    specs = [first, *(MechanismSpec(method, mechanism, base.model_copy(update={"method": method}), rows, runner)
                      for method in COMPARE_METHODS[1:])]
    reference = base.model_copy(update={"method": "dae", "stabilization": "projection", "rtol": REFERENCE_TOLERANCE,
                                        "integrator": "DOP853"})  # converged whatever the runs' integrator
    return [*specs, MechanismSpec(REFERENCE_LABEL, mechanism, reference, rows, runner)]


def visible_gap(size: float) -> float:
    """The gap called visible for a mechanism of this size, to one significant figure (a label reads it)."""
    gap = GAP_FRACTION * max(size, 1e-6)
    return float(f"{gap:.1g}")


class MechanismCompare:
    """Three mechanisms in the scene and the two divergence plots in the panel, while compare mode is on."""

    def __init__(self, target) -> None:
        self.target = target
        self.scenes: dict[str, MechanismScene] = {}
        self._frames: dict[str, object] = {}
        self._key: list = []
        self._built: tuple | None = None  # what the nodes were built for (see build)
        self.between: Plot | None = None
        self.divergence: DivergencePlots | None = None

    @property
    def on(self) -> bool:
        return bool(self.scenes)

    def build(self, draw: Drawing, points_xy: np.ndarray, com_xy: np.ndarray, trace_label: str,
              gap: float | None = None) -> None:
        """(Re)make the three mechanisms for ``draw`` and the plots for a mechanism of its size; the same
        drawing and traced point again (an edit of a mass or a motor) only moves them to the new start."""
        key = (draw.labels, draw.size, trace_label)
        if self.on and key == self._built:
            for scene in self.scenes.values():
                scene.build(draw, points_xy, com_xy)
            return
        self.remove()
        self._built = key
        scene = self.target.scene
        reach = draw.size
        for k, method in enumerate(COMPARE_METHODS):
            # opaque, one colour each, a little apart in depth: where the runs agree the front one shows
            self._frames[method] = scene.add_frame(f"/compare/{method}", show_axes=False,
                                                   position=(0.0, COMPARE_DEPTH_STEP * k * reach, 0.0))
            self.scenes[method] = MechanismScene(self.target, f"/compare/{method}", palette=[METHOD_COLORS[method]])
            self.scenes[method].build(draw, points_xy, com_xy)
        # the key top left of the disc the camera frames (as app/session.py frames it)
        centre, radius = pose_disc(np.concatenate([points_xy, draw.ground]), margin=1.3)
        self._key = compare_key(scene, radius, (float(centre[0]), float(centre[1])))
        gui = self.target.gui
        noun = f"Traced point {trace_label}"
        self.between = Plot(gui, f"{noun}: divergence from {METHOD_LABELS[COMPARE_METHODS[0]]}",
                            [METHOD_LABELS[m] for m in COMPARE_METHODS[1:]],
                            [METHOD_COLORS[m] for m in COMPARE_METHODS[1:]], log=True, height=150, y_label="m")
        self.divergence = DivergencePlots(gui, COMPARE_METHODS, self.between, point="trace_xy", noun=noun,
                                          gap=visible_gap(draw.size) if gap is None else gap)
        self.divergence.set_visible(True)

    def show(self, frames: list[RunFrame]) -> None:
        """Move each method's mechanism to its run's frame (the reference is not drawn)."""
        for rf in frames:
            scene = self.scenes.get(rf.label)
            if scene is not None:
                scene.show(rf.joints, rf.com)

    def update_plots(self, runs: dict, t_shown: float) -> None:
        if self.divergence is not None:
            self.divergence.update(runs, t_shown)

    def passing_times(self) -> dict[str, float | None]:
        return dict(self.divergence.passing_times) if self.divergence is not None else {}

    def poses(self) -> dict[str, dict]:
        nodes: dict[str, dict] = {}
        for scene in self.scenes.values():
            nodes.update(scene.poses())
        return nodes

    def remove(self) -> None:
        for scene in self.scenes.values():
            scene.remove()
        for handle in [*self._frames.values(), *self._key]:
            quietly(handle.remove, "removing a compare node")
        self.scenes, self._frames, self._key, self._built = {}, {}, [], None
        if self.divergence is not None:
            self.divergence.remove()
        if self.between is not None:
            self.between.remove()
        self.divergence = self.between = None


def compare_key(scene, reach: float, centre: tuple[float, float] = (0.0, 0.0)) -> list:
    """The colour key of compare mode in the scene: a ball of each run's colour and its method's name, top left
    of the disc of radius ``reach`` about ``centre`` (the plane's x, y) that the mechanism sweeps (where no motion
    passes); returns the nodes (chains and mechanisms alike)."""
    handles = []
    x, y = centre
    for k, method in enumerate(COMPARE_METHODS):
        z = y + reach * (0.9 - 0.12 * k)
        handles.append(scene.add_icosphere(f"/compare_key/{method}/ball", radius=0.025 * reach,
                                           color=METHOD_COLORS[method], position=(x - 0.85 * reach, 0.0, z)))
        handles.append(scene.add_label(f"/compare_key/{method}/name", METHOD_LABELS[method],
                                       position=(x - 0.8 * reach, 0.0, z)))
    return handles
