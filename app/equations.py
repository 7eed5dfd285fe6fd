"""The equations of motion as derived, rendered as MathML for the Equations panel.

viser's markdown has no TeX renderer, but its HTML element shows raw HTML and browsers draw MathML natively,
so each row of the derived linear system ``A x = b`` is printed with sympy's presentation-MathML printer,
next to the name the derivation gave it (e.g. "AMB bar 2 about its centre of mass"). sympy is imported here
only (this module is imported on demand, in a worker thread); results are cached per (formulation, n, pinned).
"""

from __future__ import annotations

import functools
import html
import re

import sympy as sp
from sympy.printing.mathml import mathml

import physics
import physics.mechanism

from .math_lines import multline
from .parameters import METHOD_LABELS

PANEL_LINE_CHARACTERS = 56  # about what a line of maths in the 384-px panel holds (sympy's plain-text length)
MAX_ROW_CHARACTERS = 20000  # a row longer than this (n >= 6 Lagrange) is summarised, not printed
SIMPLIFY_MAX_LINKS = 4  # trig-simplify entries for display up to this many bars (seconds of sympy at n = 4)


def _display_names(system):
    """Symbols renamed for display: theta_ddot_i -> θ̈_i (sympy prints theta_i, omega_i, L_i as Greek/subscripts)."""

    mapping = {}
    for i, symbol in enumerate(system.symbols.theta_ddot, start=1):
        mapping[symbol] = sp.Symbol(f"\u03b8\u0308_{i}", real=True)
    mapping[system.symbols.damping] = sp.Symbol("c", real=True)
    return mapping


def _math(expr) -> str:

    return f'<math display="block">{mathml(expr, printer="presentation")}</math>'


def _heading(row_name: str) -> str:
    """A row's name for a heading: ``theta_2`` reads as θ with subscript 2, ``G3`` as G with subscript 3."""
    text = html.escape(row_name)
    text = re.sub(r"\btheta_(\d+)", "\u03b8<sub>\\1</sub>", text)
    return re.sub(r"\bG(\d+)\b", "G<sub>\\1</sub>", text)


def _term_lines(terms: list, width: int) -> list[list]:
    """Terms grouped greedily into lines of about ``width`` characters of their plain-text form."""
    lines: list[list] = []
    current: list = []
    used = 0
    for term in terms:
        size = len(str(term)) + 3
        if current and used + size > width:
            lines.append(current)
            current, used = [], 0
        current.append(term)
        used += size
    if current:
        lines.append(current)
    return lines


def _equation_lines(lhs_terms: list, rhs, width: int = PANEL_LINE_CHARACTERS) -> str:
    """``lhs = rhs`` as MathML lines that fit the panel: broken between terms (browsers do not break MathML
    themselves); a line that continues a sum starts with its sign, the right side starts with ``=``."""

    def block(terms, lead: str) -> str:
        expr = sp.Add(*terms, evaluate=False) if len(terms) > 1 else terms[0]
        body = mathml(expr, printer="presentation")
        negative = terms[0].could_extract_minus_sign()
        sign = "" if not lead else (f"<mo>{lead}</mo>" if lead == "=" or not negative else "")
        indent = "0" if not lead else "1.5em"
        return f'<div style="margin:0.35em 0 0.35em {indent};line-height:2"><math>{sign}{body}</math></div>'

    parts = [block(terms, "" if k == 0 else "+") for k, terms in enumerate(_term_lines(lhs_terms, width))]
    rhs_terms = list(sp.Add.make_args(rhs)) or [sp.Integer(0)]
    for k, terms in enumerate(_term_lines(rhs_terms, width)):
        parts.append(block(terms, "=" if k == 0 else "+"))
    return "".join(parts)


@functools.lru_cache(maxsize=32)
def equations_html(formulation: str, n: int, pinned: bool) -> str:
    """HTML (with MathML) of the system ``A x = b`` that the simulation integrates."""

    if formulation.startswith("reduced"):
        return (
            "<p>The <b>reduced</b> model integrates the closed loop in its one free coordinate and recovers "
            "the other angles by position analysis (physics.loop_closure). It has no symbolic system of its own "
            "to show here; choose Newton-Euler, Lagrange or DAE to see the equations of the loop.</p>"
        )

    system = physics.derived_system(formulation, n, pinned)
    label = METHOD_LABELS.get(formulation, formulation)
    closure = "closed loop (tip pinned)" if pinned else "open chain"
    return _system_html(
        system, _display_names(system), f"<b>{html.escape(label)}</b>, {n} bars, {closure}",
        "Symbols: θ angle of a bar from the downward vertical (counter-clockwise), ω its angular velocity, "
        "θ̈ its angular acceleration; L length, d centre-of-mass distance from the proximal joint, m mass, "
        "I centroidal inertia, g gravity, c joint damping; R reactions, a centre-of-mass accelerations.",
        simplify=n <= SIMPLIFY_MAX_LINKS)


def mechanism_equations_html(mechanism, method: str) -> str:
    """HTML (with MathML) of the system ``A x = b`` a general mechanism's run integrates (``physics.mechanism``'s
    own derivation of ``method``), its coordinates named after its bodies."""
    if method == "reduced":
        return ("<p>The <b>reduced</b> model integrates the mechanism in its one free joint coordinate and places "
                "every body by position analysis; it has no symbolic system of its own to show here. Choose DAE, "
                "Lagrange or Newton-Euler to see the equations of the mechanism.</p>")
    system = physics.mechanism.derived_system(mechanism, method)
    by_name = {}  # q3b, q3b+1, q3b+2 are body b's x, y, phi (qd their rates, qdd their accelerations)
    for b, body in enumerate(mechanism.bodies):
        label = re.sub(r"\W", "", body.name) or f"b{b}"
        for k, coordinate in enumerate(("x", "y", "\u03c6")):
            for prefix, mark in (("q", ""), ("qd", "\u0307"), ("qdd", "\u0308")):
                by_name[f"{prefix}{3 * b + k}"] = sp.Symbol(f"{coordinate}{mark}_{label}", real=True)
    used = system.A.free_symbols | system.b.free_symbols | set(system.unknowns)
    names = {symbol: by_name[symbol.name] for symbol in used if symbol.name in by_name}
    label = METHOD_LABELS.get(method, method)
    return _system_html(
        system, names, f"<b>{html.escape(label)}</b>, {html.escape(mechanism.name)}, {len(mechanism.bodies)} bodies",
        "Symbols: x, y the centre of mass of a body and φ its angle, with their rates (a dot) and accelerations "
        "(two dots); λ (lam) the multipliers of the joints' rows in the order of the headings, whose reactions "
        "the arrows draw; m, I, cx, cy a body's mass, inertia and centre of mass in its frame (by its number in "
        "the description), ax, ay, bx, by a joint's points in its two bodies, c its damping, g gravity.",
        simplify=len(mechanism.bodies) <= SIMPLIFY_MAX_LINKS)


def _system_html(system, names: dict, title: str, symbols: str, simplify: bool) -> str:
    """``A x = b`` of ``system`` as headed rows of MathML lines that fit the panel (chains and mechanisms)."""
    unknowns = [names.get(u, u) for u in system.unknowns]
    parts = [
        f"<p>{title}: {len(unknowns)} equations, linear in the unknowns "
        f"below, written as <i>A x = b</i> and solved at every evaluation of the right-hand side.</p>",
        "<p>Unknowns <i>x</i>:</p>",
        _math(sp.Matrix(unknowns).T),
    ]

    def expand_for_display(expr):
        return sp.expand(expr) if simplify else expr

    def tidy(expr):
        # display only: products of sines and cosines become sin/cos of angle differences
        return sp.trigsimp(sp.expand(expr)) if simplify else expr

    parts.append('<div style="overflow-x:auto">')
    for i, row_name in enumerate(system.equation_names):
        lhs_terms = [
            term.xreplace(names)
            for j in range(len(unknowns))
            if system.A[i, j] != 0
            for term in sp.Add.make_args(expand_for_display(tidy(system.A[i, j]) * unknowns[j]))
        ]
        rhs = tidy(system.b[i]).xreplace(names)
        text = _equation_lines(lhs_terms or [sp.Integer(0)], rhs)
        if len(text) > MAX_ROW_CHARACTERS:
            text = f"<p><i>(this row prints to {len(text)} characters of MathML: too long to show)</i></p>"
        parts.append(f"<p><b>{i + 1}. {_heading(row_name)}</b></p>{text}")
    parts.append("</div>")
    parts.append(f"<p>{symbols}</p>")
    return "".join(parts)


def _tex_text(text: str) -> str:
    """Plain text for LaTeX's text mode."""
    for char in "\\&%$#_{}":
        text = text.replace(char, "\\" + char)
    return text


def equations_tex(formulation: str, n: int, pinned: bool) -> str:
    """A LaTeX document of the same system, from physics.codegen.equations_latex (cached beside the code)."""
    if formulation.startswith("reduced"):
        raise ValueError("the reduced model has no symbolic system of its own; choose a formulation")

    data = physics.equations_latex(formulation, n, pinned)
    label = METHOD_LABELS.get(formulation, formulation)
    closure = "closed loop (tip pinned)" if pinned else "open chain"
    lines = [
        r"\documentclass{article}",
        r"\usepackage{amsmath}",
        r"\usepackage[margin=1.5cm,landscape]{geometry}",
        r"\begin{document}",
        rf"\section*{{{label}, {n} bars, {closure}}}",
        _tex_text(str(data.get("title", ""))),
        "",
        r"Unknowns: $x = \left(" + ", ".join(data["unknowns"]) + r"\right)$.",
        r"\begin{enumerate}",
    ]
    for row in data["rows"]:
        lines.append(r"\item " + _tex_text(row["label"]))
        lines.append(multline(row["latex"]))
    lines += [r"\end{enumerate}", r"\end{document}", ""]
    return "\n".join(lines)
