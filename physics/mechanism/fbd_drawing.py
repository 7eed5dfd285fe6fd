"""A free-body diagram of one body of a mechanism as SVG: ``python -m physics fbd --preset NAME --body BODY --out
FILE.svg``.

Why its own module: the chain's drawing (:func:`physics.fbd.fbd_svg`) draws a bar between two joints; a
mechanism's body is any set of named points (a bar, a plate, a piston), and its loads include couples (motor
torques, a slider's torque, damping). The body is drawn as the outline of its points where the run has it,
each force an arrow from its point (the largest as long as the body is wide), each couple a number beside G, and
a table gives every load and the balance ``sum F = m a_G``, ``sum M_G = I alpha``.
"""

from __future__ import annotations

from html import escape

import numpy as np

from .constraints import Constraints
from .description import Mechanism
from .statics import FreeBody

COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def fbd_svg(mechanism: Mechanism, q: np.ndarray, body: FreeBody, width: int = 760, height: int = 520) -> str:
    """The diagram of ``body`` (from :func:`physics.mechanism.statics.free_body`) at the pose ``q``."""
    k = [b.name for b in mechanism.bodies].index(body.body)
    constraints = Constraints(mechanism)
    corners = np.array([constraints.body_point(q, k, xy) for xy in mechanism.bodies[k].points.values()])
    names = list(mechanism.bodies[k].points)
    centre = np.array(body.centre)
    forces = [load for load in body.loads if load.at is not None and np.hypot(*load.force) > 0.0]
    couples = [load for load in body.loads if load.at is None or (np.hypot(*load.force) == 0.0 and load.moment)]
    size = max(float(np.max(np.ptp(np.vstack([corners, centre]), axis=0))), 1e-3)
    largest = max((float(np.hypot(*load.force)) for load in forces), default=1.0) or 1.0
    scale = size / largest
    tips = [np.array(load.at) + scale * np.array(load.force) for load in forces]
    cloud = np.vstack([corners, centre[None, :], *(tip[None, :] for tip in tips),
                       *(np.array(load.at)[None, :] for load in forces)])
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    panel, margin = width - 320, 40
    pixels = min(panel - 2 * margin, height - 2 * margin - 40) / max(float(np.max(hi - lo)), 1e-9)
    middle = (lo + hi) / 2

    def px(xy) -> tuple[float, float]:
        return (panel / 2 + (xy[0] - middle[0]) * pixels, 40 + (height - 40) / 2 - (xy[1] - middle[1]) * pixels)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" '
        'font-family="Helvetica, Arial, sans-serif" font-size="12">',
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        "<defs>" + "".join(
            f'<marker id="head{n}" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
            f'orient="auto-start-reverse"><path d="M0,0L10,5L0,10z" fill="{colour}"/></marker>'
            for n, colour in enumerate(COLOURS)) + "</defs>",
        f'<text x="12" y="22" font-size="15" font-weight="bold">{escape(mechanism.name)}: {escape(body.body)} at '
        f't = {body.time:g} s ({escape(body.method)})</text>',
    ]
    outline = " ".join(f"{x:.1f},{y:.1f}" for x, y in map(px, corners))
    shape = "polygon" if len(corners) > 2 else "polyline"
    out.append(f'<{shape} points="{outline}" fill="#eeeeee" stroke="#999999" stroke-width="10" '
               'stroke-linejoin="round" stroke-linecap="round"/>')
    for xy, name in zip(corners, names):
        x, y = px(xy)
        out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="4" fill="white" stroke="#444" stroke-width="1.5"/>')
        out.append(f'<text x="{x - 7:.1f}" y="{y + 16:.1f}" fill="#444" text-anchor="end">{escape(name)}</text>')
    gx, gy = px(centre)
    out.append(f'<circle cx="{gx:.1f}" cy="{gy:.1f}" r="4" fill="#444"/><text x="{gx + 7:.1f}" y="{gy - 7:.1f}" '
               'fill="#444">G</text>')
    for n, (load, tip) in enumerate(zip(forces, tips)):
        colour = COLOURS[n % len(COLOURS)]
        (ax, ay), (bx, by) = px(load.at), px(tip)
        out.append(f'<line x1="{ax:.1f}" y1="{ay:.1f}" x2="{bx:.1f}" y2="{by:.1f}" stroke="{colour}" '
                   f'stroke-width="2.5" marker-end="url(#head{n % len(COLOURS)})"><title>{escape(load.name)}: |F| = '
                   f'{np.hypot(*load.force):.4g} N</title></line>')
        out.append(f'<text x="{bx + 5:.1f}" y="{by + 4:.1f}" fill="{colour}">{escape(load.name.split(" (")[0])}</text>')
    for n, load in enumerate(couples):
        out.append(f'<text x="{gx + 10:.1f}" y="{gy + 18 + 15 * n:.1f}" fill="#444">&#x21BA; {escape(load.name)}: '
                   f'{load.moment:.4g} N m</text>')
    tx, ty = panel + 10, 54
    out.append(f'<text x="{tx}" y="{ty}" font-weight="bold">load</text>')
    for row, load in enumerate(body.loads, start=1):
        colour = COLOURS[forces.index(load) % len(COLOURS)] if load in forces else "#444"
        out.append(f'<text x="{tx}" y="{ty + 30 * row}" fill="{colour}">{escape(load.name)}</text>')
        out.append(f'<text x="{tx}" y="{ty + 30 * row + 14}" fill="{colour}" font-size="11">F = '
                   f'({load.force[0]:.5g}, {load.force[1]:.5g}) N   M_G = {load.moment:.5g} N m</text>')
    balance = body.as_dict()["balance"]
    bottom = ty + 30 * (len(body.loads) + 1) + 10
    for n, line in enumerate((
            f"sum F = ({balance['net_force'][0]:.6g}, {balance['net_force'][1]:.6g}) N",
            f"m a_G = ({balance['m_a'][0]:.6g}, {balance['m_a'][1]:.6g}) N",
            f"sum M_G = {balance['net_moment_about_com']:.6g} N m",
            f"I alpha = {balance['I_alpha']:.6g} N m")):
        out.append(f'<text x="{tx}" y="{bottom + 16 * n}" font-size="11">{escape(line)}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"
