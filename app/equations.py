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

PANEL_LINE_CHARACTERS = 46  # about what a line of maths in the 384-px panel holds inside its padding (plain text)
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


def collected_terms(lhs_terms: list, unknowns: list) -> list[tuple]:
    """The left side as ``(coefficient, unknown)`` pairs, the coefficient of each unknown collected
    (``sympy.collect``), in the unknowns' order: ``I1 θ̈1 + d1² m1 θ̈1 + L1² m2 θ̈1`` reads
    ``(I1 + d1² m1 + L1² m2) θ̈1``, each acceleration once. For reading only: the derivation
    (``equations.system``) and its expanded rows are never changed. A term in no unknown (none in ``A x``) would
    come last as ``(term, None)``, never dropped."""
    by_unknown = sp.collect(sp.Add(*lhs_terms), unknowns, evaluate=False)
    pairs = [(by_unknown[unknown], unknown) for unknown in unknowns if by_unknown.get(unknown, 0) != 0]
    rest = by_unknown.get(sp.Integer(1), 0)
    pairs += [(term, None) for term in sp.Add.make_args(rest) if term != 0]
    return pairs or [(sp.Integer(0), None)]


# A piece of a printed sum: its sign ("+" or "-"), its MathML and its plain-text length (the width it takes).
Piece = tuple[str, str, int]
_MINUS = "-"  # as sympy prints a difference (θ1 - θ2)
_TIMES = "<mo>&InvisibleTimes;</mo>"


def _pieces(term, width: int, unknown=None) -> list[Piece]:
    """``term`` (times ``unknown``, printed after it, when given) as the pieces a line may break between: the
    whole term when it is short; a longer one with a sum in it (``(a + b + ...) θ̈``) opened up, its sum's terms
    pieces of their own (recursively), so that no line runs past the panel."""
    negative = term.could_extract_minus_sign()
    magnitude = -term if negative else term
    sign = "-" if negative else "+"
    tail = "" if unknown is None else _presentation(unknown)
    size = len(str(magnitude)) + 3 + (len(str(unknown)) if unknown is not None else 0)
    if unknown is not None and magnitude == 1:
        return [(sign, tail, size)]
    if isinstance(magnitude, sp.Add):  # a collected coefficient: (sum) unknown
        before, total, after = [], magnitude, []
    else:
        factors = list(magnitude.args) if isinstance(magnitude, sp.Mul) else []
        opened = next((k for k, factor in enumerate(factors) if isinstance(factor, sp.Add)), None)
        if size <= width or opened is None:
            return [(sign, _presentation(magnitude) + (_TIMES + tail if tail else ""), size)]
        before, total, after = factors[:opened], factors[opened], factors[opened + 1:]
    if size <= width:
        return [(sign, f"<mo>(</mo>{_presentation(total)}<mo>)</mo>{tail}", size)]
    # The parentheses of a sum broken over lines are plain (not stretched to what one line holds).
    pieces = [piece for inner_term in sp.Add.make_args(total) for piece in _pieces(inner_term, width)]
    first_sign, first_body, first_size = pieces[0]
    lead = (_presentation(sp.Mul(*before)) if before else "") + "<mo stretchy=\"false\">(</mo>"
    lead += f"<mo>{_MINUS}</mo>" if first_sign == "-" else ""
    pieces[0] = (sign, lead + first_body, first_size + 2)
    last_sign, last_body, last_size = pieces[-1]
    closing = "<mo stretchy=\"false\">)</mo>" + (_presentation(sp.Mul(*after)) if after else "") + tail
    pieces[-1] = (last_sign if len(pieces) > 1 else sign, last_body + closing,
                  last_size + 2 + len(str(sp.Mul(*after))) + len(str(unknown or "")))
    return pieces


def _piece_lines(pieces: list[Piece], width: int) -> list[list[Piece]]:
    """Pieces grouped greedily into lines of about ``width`` characters of their plain-text form."""
    lines: list[list[Piece]] = []
    current: list[Piece] = []
    used = 0
    for piece in pieces:
        if current and used + piece[2] > width:
            lines.append(current)
            current, used = [], 0
        current.append(piece)
        used += piece[2]
    if current:
        lines.append(current)
    return lines


def _equation_lines(lhs_pairs: list, rhs, width: int = PANEL_LINE_CHARACTERS) -> str:
    """``lhs = rhs`` (the left side as :func:`collected_terms`) as MathML lines that fit the panel: broken between terms, or inside a long term between the
    terms of its sum (browsers do not break MathML themselves); a line that continues a sum starts with its sign,
    the right side starts with ``=``."""

    def side(pairs: list, first_lead: str) -> list[str]:
        pieces = [piece for term, unknown in pairs for piece in _pieces(term, width, unknown)]
        blocks = []
        for k, line in enumerate(_piece_lines(pieces, width)):
            body = ""
            for j, (sign, piece_body, _) in enumerate(line):
                starts_side = k == 0 and j == 0
                if sign == "-":
                    body += f"<mo>{_MINUS}</mo>"
                elif not starts_side:
                    body += "<mo>+</mo>"
                body += piece_body
            lead = f"<mo>{first_lead}</mo>" if k == 0 and first_lead else ""
            indent = "1.5em" if k or first_lead else "0"
            blocks.append(f'<div style="margin:0.35em 0 0.35em {indent};line-height:2"><math>{lead}{body}</math></div>')
        return blocks

    rhs_pairs = [(term, None) for term in sp.Add.make_args(rhs)] or [(sp.Integer(0), None)]
    return "".join(side(lhs_pairs, "") + side(rhs_pairs, "="))


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
        return _padded(REDUCED)
    symbols = CHAIN_SYMBOLS if isinstance(linkage, physics.Chain) else MECHANISM_SYMBOLS
    return _system_html(equations, _title(linkage, equations), symbols)


def _system_html(equations, title: str, symbols: str) -> str:
    """``A x = b`` as headed rows of MathML lines that fit the panel."""
    parts = [
        f"<p>{title}: {len(equations.unknowns)} equations, linear in the unknowns "
        f"below, written as <i>A x = b</i> and solved at every evaluation of the right-hand side. State: "
        f"{_heading(equations.coordinates)}.</p>",
        f"<p>Unknowns <i>x</i>: {_unknowns_list(equations.unknowns)}</p>",
        "<div>",
    ]
    for i, (row_name, lhs_terms, rhs) in enumerate(equations.rows):
        text = _equation_lines(collected_terms(lhs_terms, equations.unknowns), rhs)
        if len(text) > MAX_ROW_CHARACTERS:
            text = f"<p><i>(this row prints to {len(text)} characters of MathML: too long to show)</i></p>"
        parts.append(f"<p><b>{i + 1}. {_heading(row_name)}</b></p>{text}")
    parts.append("</div>")
    parts.append(f"<p>{symbols}</p>")
    return _padded("".join(parts))


def _unknowns_list(unknowns: list) -> str:
    """The vector of unknowns as ``(x1, x2, ...)`` in running text, one small formula per entry, so the browser
    wraps it at the panel's edge (a MathML row vector does not wrap: 72 unknowns of a 12-bar DAE ran off it)."""
    entries = [f'<span style="white-space:nowrap"><math>{_presentation(unknown)}</math>'
               f'{"," if k < len(unknowns) - 1 else ")"}</span>' for k, unknown in enumerate(unknowns)]
    return "(" + " ".join(entries)


def _padded(content: str) -> str:
    """The tab's content with a margin inside the panel's border (the maths sat flush against it)."""
    return f'<div style="padding:0.25em 0.9em;overflow-wrap:anywhere">{content}</div>'


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


def _latex_product(coefficient, unknown) -> str:
    """A collected term in LaTeX: ``\\left(sum\\right) unknown``, the coefficient first as the tab shows it."""
    if unknown is None:
        return _latex(coefficient)
    if coefficient == 1 or coefficient == -1:
        return ("- " if coefficient == -1 else "") + _latex(unknown)
    if isinstance(coefficient, sp.Add):
        return rf"\left({_latex(coefficient)}\right) {_latex(unknown)}"
    return f"{_latex(coefficient)} {_latex(unknown)}"


def latex_rows(equations) -> list[tuple[str, str]]:
    """``(row name, "lhs = rhs" in LaTeX)`` per row of ``equations`` (:func:`physics.equations_of_motion`)."""
    rows = []
    for row_name, lhs_terms, rhs in equations.rows:
        lhs = " + ".join(_latex_product(coefficient, unknown)
                         for coefficient, unknown in collected_terms(lhs_terms, equations.unknowns)).replace("+ -", "- ")
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
