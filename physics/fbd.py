"""Free-body diagrams: every force on one bar at one instant, with values, and an SVG drawing of them.

The seed report derives its Newton-Euler and DAE equations from one free-body diagram per bar (its Figures
3-8 and 14-17). Here the same diagrams are computed, not drawn by hand: the DAE formulation solves for every
joint reaction together with the accelerations, so the forces on a bar are

* gravity ``(0, -m g)`` at its centre of mass G;
* the reaction at its proximal joint, ``R_{k-1}``: the force ON bar k BY bar k-1 (or by the ground at O);
* at its distal joint, ``-R_k``: Newton's third law on the force bar k exerts on bar k+1 (absent on the
  last bar of an open chain);
* on the last bar of a closed chain, the pin reaction ``R_H``: the force ON bar n BY the ground at H.

These are the sign conventions of docs/architecture.md. A diagram also carries ``m a_G`` and ``I alpha`` so a
reader (and a test) can check that the arrows balance: sum of forces = m a_G, sum of moments about G = I alpha.
Joint damping is not drawn (the presets have none; a damped run's joint torques are not reactions).
"""

from __future__ import annotations

import html
import math
import textwrap
from dataclasses import dataclass

import numpy as np

from .errors import LinkageError
from .kinematics import com_accelerations, joint_positions
from .model import Chain, Settings, validated
from .registry import METHODS
from .simulate import simulate
from .simulate.chain_system import chain_system
from .simulate.trajectory import chain_joint_names

# The state at the requested time comes from a run tight enough that its error is far below the values drawn.
FBD_TOLERANCE = 1e-10
# Longest time a diagram may be asked for: a run beyond it costs minutes and, for a chaotic chain, no longer
# describes the true motion at any tolerance.
MAX_FBD_TIME = 1000.0


@dataclass(frozen=True)
class Force:
    """One force on the bar: ``force`` (2,) applied at ``point_xy`` (2,), the place named by ``point``."""

    name: str
    point: str
    point_xy: np.ndarray
    force: np.ndarray

    def as_dict(self) -> dict:
        return {"name": self.name, "point": self.point, "at": [float(v) for v in self.point_xy],
                "force": [float(v) for v in self.force], "magnitude": float(np.hypot(*self.force))}


@dataclass(frozen=True)
class FreeBody:
    """The free-body diagram of bar ``bar`` (1-based) at time ``time``.

    ``ends_xy`` (2, 2): proximal and distal joint; ``com_xy`` (2,): G; ``com_acceleration`` (2,): a_G from the
    chain's kinematics and the solved angular accelerations; ``alpha``: the bar's angular acceleration.
    """

    bar: int
    time: float
    mass: float
    inertia: float
    theta: float
    omega: float
    alpha: float
    ends_xy: np.ndarray
    com_xy: np.ndarray
    com_acceleration: np.ndarray
    forces: tuple[Force, ...]
    end_names: tuple[str, str] = ("", "")

    def net_force(self) -> np.ndarray:
        return np.sum([f.force for f in self.forces], axis=0)

    def net_moment_about_com(self) -> float:
        """Sum of ``(r_P - r_G) x F`` (z-component) over the forces."""
        total = 0.0
        for f in self.forces:
            r = f.point_xy - self.com_xy
            total += float(r[0] * f.force[1] - r[1] * f.force[0])
        return total

    def as_dict(self) -> dict:
        net = self.net_force()
        m_a = self.mass * self.com_acceleration
        return {
            "bar": self.bar, "time": self.time, "mass": self.mass, "inertia": self.inertia,
            "theta": self.theta, "omega": self.omega, "alpha": self.alpha,
            "ends": self.ends_xy.tolist(), "end_names": list(self.end_names), "com": self.com_xy.tolist(),
            "com_acceleration": self.com_acceleration.tolist(),
            "forces": [f.as_dict() for f in self.forces],
            "balance": {
                "net_force": net.tolist(), "mass_times_acceleration": m_a.tolist(),
                "net_moment_about_com": self.net_moment_about_com(), "inertia_times_alpha": self.inertia * self.alpha,
            },
        }


# The free-body diagrams need every joint reaction: the formulation whose unknowns include them (the DAE).
REACTION_FORMULATION = next(name for name, spec in METHODS.items() if spec.has_reactions)


def free_bodies(chain: Chain, theta, omega) -> list[FreeBody]:
    """Every bar's free-body diagram at one state, from the DAE's reactions (damping is taken as zero)."""
    n = chain.n
    theta = np.asarray(theta, dtype=float).reshape(n)
    omega = np.asarray(omega, dtype=float).reshape(n)
    # the DAE's system physics.simulate integrates (the chain written as a mechanism): its unknowns hold every
    # joint's reaction
    system = chain_system(chain, REACTION_FORMULATION)
    x, _ = system.solve(theta, omega)
    alpha = x[system.theta_ddot_index]
    reactions = x[system.reaction_index]  # (n, 2)
    tip_reaction = x[system.tip_reaction_index] if system.tip_reaction_index.size else None
    L, d, m, inertia = (chain.array(f) for f in "LdmI")
    joints = joint_positions(L, theta)
    accelerations = com_accelerations(L, d, theta, omega, alpha)
    joint_names = chain_joint_names(n)
    bodies = []
    for i in range(n):
        e = np.array([math.sin(theta[i]), -math.cos(theta[i])])
        com = joints[i] + d[i] * e
        forces = [Force("gravity", f"G{i + 1}", com, np.array([0.0, -m[i] * chain.g]))]
        by = "the ground" if i == 0 else f"bar {i}"
        forces.append(Force(f"R{i} (by {by})", joint_names[i], joints[i].copy(), reactions[i].copy()))
        if i + 1 < n:
            forces.append(Force(f"-R{i + 1} (by bar {i + 2})", joint_names[i + 1], joints[i + 1].copy(),
                                -reactions[i + 1]))
        elif tip_reaction is not None:
            forces.append(Force("RH (by the ground at the pin)", "H", joints[n].copy(), tip_reaction.copy()))
        bodies.append(FreeBody(bar=i + 1, time=0.0, mass=float(m[i]), inertia=float(inertia[i]), theta=float(theta[i]),
                               omega=float(omega[i]), alpha=float(alpha[i]), ends_xy=joints[i:i + 2].copy(),
                               com_xy=com, com_acceleration=accelerations[i], forces=tuple(forces),
                               end_names=(joint_names[i], joint_names[i + 1])))
    return bodies


def check_request(chain: Chain, time: float, bar: int) -> None:
    """Refuse a bar or time out of range, naming the option and the allowed range."""
    if not 1 <= bar <= chain.n:
        raise LinkageError(f"--bar = {bar}: allowed range 1 <= bar <= {chain.n}")
    if not (math.isfinite(time) and 0.0 <= time <= MAX_FBD_TIME):
        raise LinkageError(f"--time = {time}: allowed range 0 <= time <= {MAX_FBD_TIME:g} s")


def free_body_at(chain: Chain, theta0, omega0, time: float, bar: int) -> FreeBody:
    """Bar ``bar``'s diagram at ``time`` s of the run from ``(theta0, omega0)`` (DAE, DOP853 at
    :data:`FBD_TOLERANCE`, projection on a closed chain). A run that fails before ``time`` raises, with its
    message."""
    check_request(chain, time, bar)
    theta, omega = np.asarray(theta0, dtype=float), np.asarray(omega0, dtype=float)
    if time > 0.0:
        settings = validated(Settings, method=REACTION_FORMULATION, integrator="DOP853", rtol=FBD_TOLERANCE, atol=FBD_TOLERANCE,
                             t_end=time, samples=2)
        run = simulate(chain, theta, omega, settings)
        if not run.success:
            raise LinkageError(f"--time = {time}: the run stopped before it ({run.message})")
        theta, omega = run.theta[-1], run.omega[-1]
    body = free_bodies(chain, theta, omega)[bar - 1]
    return FreeBody(**{**body.__dict__, "time": float(time)})


# ------------------------------------------------------------------------------------------------
# SVG

_FORCE_COLOURS = ("#222222", "#4e79a7", "#e15759", "#59a14f")


def _esc(text: str) -> str:
    return html.escape(text, quote=True)


PANEL_WIDTH = 380
"""px: the natural width of :func:`fbd_svg`'s panel layout (about the app's panel width, so it is shown at nearly
1:1)."""


def fbd_svg(body: FreeBody, title: str = "", width: int = 720, height: int = 520,
            text_px: float | None = None) -> str:
    """The bar drawn where it is, each force an arrow from its point (length proportional to magnitude, the
    largest one bar length long), and a table of the values and the balance check beside it.

    ``text_px``: the panel layout instead (``width`` :data:`PANEL_WIDTH` unless given, ``height`` as the text
    needs): the table under the drawing and every text at least ``text_px``, so the figure stays readable shown
    at a 384-px panel's width (the side-by-side layout shrunk there shows 5-px text)."""
    narrow = text_px is not None
    f = float(text_px) if text_px is not None else 12.0
    small = f if narrow else 11.0  # the table's second lines and the check
    line = 1.25 * f
    heading = title or f"Free-body diagram of bar {body.bar} at t = {body.time:g} s"
    if narrow:
        width = PANEL_WIDTH if width == 720 else width
        title_lines = textwrap.wrap(heading, max(8, int((width - 20) / (0.6 * (f + 1))))) or [""]
        draw_left, draw_top, draw_w, draw_h = 0.0, 8 + len(title_lines) * line + 4, float(width), 0.8 * width
    else:
        title_lines = [heading]
        draw_left, draw_top, draw_w, draw_h = 0.0, 40.0, float(width - 300), float(height - 40)
    ends = body.ends_xy
    length = float(np.hypot(*(ends[1] - ends[0]))) or 1.0
    largest = max(float(np.hypot(*f.force)) for f in body.forces) or 1.0
    arrow_scale = length / largest
    tips = [f.point_xy + arrow_scale * f.force for f in body.forces]
    points = np.vstack([ends, *tips, body.com_xy])
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-9)
    margin = 40
    pixels = min(draw_w - 2 * margin, draw_h - 2 * margin) / span
    centre = (lo + hi) / 2

    def px(xy) -> tuple[float, float]:
        return (draw_left + draw_w / 2 + (xy[0] - centre[0]) * pixels,
                draw_top + draw_h / 2 - (xy[1] - centre[1]) * pixels)

    rows = [("force", "at", "Fx", "Fy")] + [
        (f.name, f.point, f"{f.force[0]:.5g}", f"{f.force[1]:.5g}") for f in body.forces]
    net, m_a = body.net_force(), body.mass * body.com_acceleration
    check = [
        "balance (sum of the arrows):",
        f"sum F = ({net[0]:.6g}, {net[1]:.6g})",
        f"m a_G = ({m_a[0]:.6g}, {m_a[1]:.6g})",
        f"sum M about G = {body.net_moment_about_com():.6g}",
        f"I alpha = {body.inertia * body.alpha:.6g}",
        f"theta = {math.degrees(body.theta):.2f} deg, omega = {body.omega:.4g} rad/s",
    ]
    footer = ("arrows to scale: the largest force is drawn one bar length long; R_k is the force ON bar k+1 BY bar "
              "k (or the ground)")
    if narrow:
        tx, ty = 10.0, draw_top + draw_h + f
        row_step, check_step = 2 * line + 4, line
        footer_lines = textwrap.wrap(footer, max(8, int((width - 20) / (0.55 * f))))
        base = ty + row_step * len(rows) + 4
        footer_top = base + check_step * len(check) + 4
        height = int(math.ceil(footer_top + line * len(footer_lines) + 4))
    else:
        tx, ty = float(width - 300 + 10), 54.0
        row_step, check_step = 34.0, 16.0
        footer_lines = [footer]
        base = ty + row_step * len(rows) + 10
        footer_top = float(height - 8)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" '
        f'font-family="Helvetica, Arial, sans-serif" font-size="{f:g}">',
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        '<defs>' + "".join(
            f'<marker id="head{k}" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
            f'orient="auto-start-reverse"><path d="M0,0L10,5L0,10z" fill="{c}"/></marker>'
            for k, c in enumerate(_FORCE_COLOURS)) + '</defs>',
        _text_lines(title_lines, 12, 22 if not narrow else 8 + f, line,
                    f' font-size="{(f + 1) if narrow else 15:g}" font-weight="bold"'),
    ]
    (x0, y0), (x1, y1) = px(ends[0]), px(ends[1])
    out.append(f'<line x1="{x0:.1f}" y1="{y0:.1f}" x2="{x1:.1f}" y2="{y1:.1f}" stroke="#bbbbbb" stroke-width="14" '
               'stroke-linecap="round"/>')
    for xy, name in zip(ends, body.end_names):
        cx, cy = px(xy)
        out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="5" fill="white" stroke="#444" stroke-width="1.5"/>')
        out.append(f'<text x="{cx - 8:.1f}" y="{cy + 18:.1f}" fill="#444" text-anchor="end">{_esc(name)}</text>')
    gx, gy = px(body.com_xy)
    out.append(f'<circle cx="{gx:.1f}" cy="{gy:.1f}" r="4" fill="#444"><title>G{body.bar}</title></circle>')
    out.append(f'<text x="{gx + 7:.1f}" y="{gy - 7:.1f}" fill="#444">G{body.bar}</text>')
    for k, (force, tip) in enumerate(zip(body.forces, tips)):
        colour = _FORCE_COLOURS[k % len(_FORCE_COLOURS)]
        (ax, ay), (bx, by) = px(force.point_xy), px(tip)
        label = f"{force.name}: |F| = {np.hypot(*force.force):.4g}"
        head = f"url(#head{k % len(_FORCE_COLOURS)})"
        out.append(f'<line x1="{ax:.1f}" y1="{ay:.1f}" x2="{bx:.1f}" y2="{by:.1f}" stroke="{colour}" '
                   f'stroke-width="2.5" marker-end="{head}"><title>{_esc(label)}</title></line>')
        out.append(f'<text x="{bx + 5:.1f}" y="{by + 4:.1f}" fill="{colour}">{_esc(force.name.split(" ")[0])}</text>')
    # Table of values.
    second = 15.0 if not narrow else line
    for r, row in enumerate(rows):
        colour = "#000" if r == 0 else _FORCE_COLOURS[(r - 1) % len(_FORCE_COLOURS)]
        weight = ' font-weight="bold"' if r == 0 else ""
        out.append(f'<text x="{tx:g}" y="{ty + row_step * r:.1f}" fill="{colour}"{weight}>{_esc(row[0])}</text>')
        out.append(f'<text x="{tx:g}" y="{ty + row_step * r + second:.1f}" fill="{colour}" font-size="{small:g}"'
                   f'{weight}>{_esc(row[1])}   Fx = {_esc(row[2])}   Fy = {_esc(row[3])}</text>' if r else
                   f'<text x="{tx:g}" y="{ty + second:.1f}" font-size="{small:g}">point, components</text>')
    for r, text in enumerate(check):
        out.append(f'<text x="{tx:g}" y="{base + check_step * r:.1f}" font-size="{small:g}">{_esc(text)}</text>')
    out.append(_text_lines(footer_lines, 12, footer_top if not narrow else footer_top + f, line,
                           f' font-size="{f if narrow else 10:g}" fill="#666"'))
    out.append("</svg>")
    return "\n".join(out) + "\n"


def _text_lines(lines: list[str], x: float, y: float, step: float, attributes: str = "") -> str:
    """Lines of text, one under the other (an SVG ``text`` with a ``tspan`` per line)."""
    spans = "".join(f'<tspan x="{x:g}" dy="{0 if k == 0 else step:.1f}">{_esc(text)}</tspan>'
                    for k, text in enumerate(lines))
    return f'<text x="{x:g}" y="{y:.1f}"{attributes}>{spans}</text>'
