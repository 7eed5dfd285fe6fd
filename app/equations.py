"""The equations of motion a run integrates, rendered as MathML for the Equations tab and as a LaTeX download.

One view for every linkage: a chain's tab and a mechanism's show :func:`physics.equations_of_motion` of what
runs (a chain as the mechanism it is integrated as). viser's markdown has no TeX renderer, but its HTML element
shows raw HTML and browsers draw MathML natively, so each row of ``A x = b`` is printed with sympy's
presentation-MathML printer, next to the name the derivation gave it (e.g. "AMB of the bodies beyond J1 about
it"). sympy is imported here only (this module is imported on demand, in a worker thread); physics keeps the
derived, tidied rows per structure (per description for a mechanism: its names are in them).
"""

from __future__ import annotations

import html
import re
import textwrap

import sympy as sp
from sympy.printing.mathml import mathml

import physics

from .math_lines import TEX_LINE_CHARACTERS, multline
from .parameters import METHOD_LABELS

PANEL_LINE_CHARACTERS = 56  # about what a line of maths in the 384-px panel holds (sympy's plain-text length)
MAX_ROW_CHARACTERS = 20000  # a row longer than this (n >= 6 Lagrange) is summarised, not printed


def _presentation(expr) -> str:
    """sympy's presentation MathML, a dotted symbol (``θ̈``: a combining dot, which fonts draw poorly over Greek)
    as an accent over it."""
    text = mathml(expr, printer="presentation")
    return re.sub(r"<mi>([^<]*?)&#(775|776);</mi>",
                  lambda found: f'<mover accent="true"><mi>{found.group(1)}</mi>'
                                f'<mo>{"&#729;" if found.group(2) == "775" else "&#168;"}</mo></mover>', text)


def _math(expr) -> str:
    return f'<math display="block">{_presentation(expr)}</math>'


def _heading(row_name: str) -> str:
    """A row's name for a heading: ``theta_2`` reads as θ with subscript 2, ``G3`` as G with subscript 3."""
    text = html.escape(row_name)
    text = re.sub(r"\btheta_(\d+)", "\u03b8<sub>\\1</sub>", text)
    text = re.sub(r"(?<!\w)([θωφλs])_(\w+)", "\\1<sub>\\2</sub>", text)  # θ_1, s_O (physics.equations_of_motion)
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
        body = _presentation(expr)
        negative = terms[0].could_extract_minus_sign()
        sign = "" if not lead else (f"<mo>{lead}</mo>" if lead == "=" or not negative else "")
        indent = "0" if not lead else "1.5em"
        return f'<div style="margin:0.35em 0 0.35em {indent};line-height:2"><math>{sign}{body}</math></div>'

    parts = [block(terms, "" if k == 0 else "+") for k, terms in enumerate(_term_lines(lhs_terms, width))]
    rhs_terms = list(sp.Add.make_args(rhs)) or [sp.Integer(0)]
    for k, terms in enumerate(_term_lines(rhs_terms, width)):
        parts.append(block(terms, "=" if k == 0 else "+"))
    return "".join(parts)


REDUCED = ("<p>The <b>reduced</b> model integrates the linkage in its one free coordinate and places every body "
           "by position analysis; it has no symbolic system of its own to show here. Choose DAE, Lagrange or "
           "Newton-Euler to see its equations.</p>")
CHAIN_SYMBOLS = ("Symbols: θ<sub>k</sub> the angle of bar k from the downward vertical (counter-clockwise), ω its rate, "
                 "θ̈ its angular acceleration; x, y the centre of mass of a bar and φ its angle (the DAE), with dots "
                 "for rates; L length, d centre-of-mass distance from the bar's top joint, m mass, I centroidal "
                 "inertia, g gravity, c joint damping, x<sub>H</sub>, y<sub>H</sub> the pin of a closed loop; "
                 "λ the multipliers of the constraint rows (in the order of the headings). The chain is integrated "
                 "as a mechanism: bars bar1..barn, pins O (bar 1 at the origin), J1..J(n-1) (bar k+1 on bar k) and "
                 "H (the tip's pin).")
MECHANISM_SYMBOLS = ("Symbols: x, y the centre of mass of a body and φ its angle, with their rates (a dot) and "
                     "accelerations (two dots); s a spanning-tree joint's coordinate (Lagrange, Newton-Euler); λ the "
                     "multipliers of the constraint rows (in the order of the headings); m, I, cx, cy a body's "
                     "mass, inertia and centre of mass (by its number in the description), ax, ay, bx, by a joint's "
                     "points in its two bodies, ux, uy a guide's direction, c a joint's damping, g gravity.")


def _equations(linkage, method: str):
    """physics' equations of ``linkage`` for ``method``; ``None`` for the reduced methods (no system of their own)."""
    if method.startswith("reduced"):
        return None
    return physics.equations_of_motion(linkage, method)


def _title(linkage, equations) -> str:
    label = html.escape(METHOD_LABELS.get(equations.method, equations.method))
    if isinstance(linkage, physics.Chain):
        closure = "closed loop (tip pinned)" if linkage.pinned else "open chain"
        return f"<b>{label}</b>, {linkage.n} bars, {closure}"
    return f"<b>{label}</b>, {html.escape(equations.name)}, {equations.bodies} bodies"


def equations_html(linkage, method: str) -> str:
    """HTML (with MathML) of the system ``A x = b`` the run of ``linkage`` (a chain or a mechanism) integrates
    for ``method``: :func:`physics.equations_of_motion`, the one view of both panels."""
    equations = _equations(linkage, method)
    if equations is None:
        return REDUCED
    symbols = CHAIN_SYMBOLS if isinstance(linkage, physics.Chain) else MECHANISM_SYMBOLS
    return _system_html(equations, _title(linkage, equations), symbols)


def _system_html(equations, title: str, symbols: str) -> str:
    """``A x = b`` as headed rows of MathML lines that fit the panel."""
    parts = [
        f"<p>{title}: {len(equations.unknowns)} equations, linear in the unknowns "
        f"below, written as <i>A x = b</i> and solved at every evaluation of the right-hand side. State: "
        f"{_heading(equations.coordinates)}.</p>",
        "<p>Unknowns <i>x</i>:</p>",
        f'<div style="overflow-x:auto">{_math(sp.Matrix(equations.unknowns).T)}</div>',
        '<div style="overflow-x:auto">',
    ]
    for i, (row_name, lhs_terms, rhs) in enumerate(equations.rows):
        text = _equation_lines(lhs_terms, rhs)
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


_TEX_LETTERS = {"θ": r"\theta", "ω": r"\omega", "φ": r"\varphi", "λ": r"\lambda"}
_TEX_MARKS = {"\u0307": r"\dot", "\u0308": r"\ddot"}


def tex_symbol(name: str) -> str:
    """A readable symbol's name (``θ̈_1``, ``ẋ_crank``, ``s_O``, ``m_2``) as LaTeX (``\\ddot{\\theta}_{1}``,
    ``\\dot{x}_{\\mathrm{crank}}``): pdflatex reads no Unicode letters."""
    base, _, label = name.partition("_")
    numbered = re.fullmatch(r"([A-Za-z]+)(\d+)", name)  # a mechanism's parameter: m0, ax3
    if numbered:
        base, label = numbered.groups()
    mark = ""
    while base and base[-1] in _TEX_MARKS:
        mark, base = _TEX_MARKS[base[-1]], base[:-1]
    base = "".join(_TEX_LETTERS.get(char, char) for char in base)
    base = f"{mark}{{{base}}}" if mark else base
    if not label:
        return base
    return f"{base}_{{{label}}}" if label.isdigit() or len(label) == 1 else f"{base}_{{\\mathrm{{{_tex_text(label)}}}}}"


def _tex_prose(text: str) -> str:
    """Text for LaTeX's text mode with the readable symbols in it (``θ_k``, ``λ``) as maths."""
    parts = re.split(r"([θωφλ](?:_\w+)?)", text)
    return "".join(f"${tex_symbol(part)}$" if k % 2 else _tex_text(part) for k, part in enumerate(parts))


def _latex(expr) -> str:
    return sp.latex(expr, symbol_names={symbol: tex_symbol(symbol.name) for symbol in expr.free_symbols})


def latex_rows(equations) -> list[tuple[str, str]]:
    """``(row name, "lhs = rhs" in LaTeX)`` per row of ``equations`` (:func:`physics.equations_of_motion`)."""
    rows = []
    for row_name, lhs_terms, rhs in equations.rows:
        lhs = " + ".join(_latex(term) for term in lhs_terms).replace("+ -", "- ")
        rows.append((row_name, f"{lhs} = {_latex(rhs)}"))
    return rows


def equations_tex(linkage, method: str) -> str:
    """A LaTeX document of the same system the Equations tab shows (:func:`equations_html`), for any linkage."""
    equations = _equations(linkage, method)
    if equations is None:
        raise ValueError("the reduced model has no symbolic system of its own; choose DAE, Lagrange or Newton-Euler")
    title = re.sub(r"<[^>]+>", "", _title(linkage, equations))
    lines = [
        r"\documentclass{article}",
        r"\usepackage{amsmath}",
        r"\usepackage[margin=1.5cm,landscape]{geometry}",
        r"\begin{document}",
        rf"\section*{{{_tex_text(title)}}}",
        textwrap.fill(_tex_prose(f"{len(equations.unknowns)} equations A x = b, solved at every evaluation of the "
                                 f"right-hand side. State: {equations.coordinates}."), TEX_LINE_CHARACTERS,
                      break_long_words=False, break_on_hyphens=False),
        "",
        r"Unknowns: $x = \left(" + ", ".join(_latex(u) for u in equations.unknowns) + r"\right)$.",
        r"\begin{enumerate}",
    ]
    for row_name, row in latex_rows(equations):
        lines.append(r"\item " + _tex_prose(row_name))
        lines.append(multline(row))
    lines += [r"\end{enumerate}", r"\end{document}", ""]
    return "\n".join(lines)
