"""Long equations broken into lines that fit a panel or a page.

A Lagrange row of a 3-bar chain is a sum of dozens of terms: printed on one line it is ~1700 px wide in a
384-px panel, or 2,700 characters on one line of a LaTeX file. Both printers here break a sum between its
top-level terms, never inside one, so every line stays a valid piece of mathematics.
"""

from __future__ import annotations

# LaTeX source characters per line of the exported document (landscape A4 at 10 pt holds about this much
# rendered maths; the source is longer than what it draws, so this errs on the short side).
TEX_LINE_CHARACTERS = 140


def split_latex_terms(latex: str) -> list[str]:
    """The top-level terms of a LaTeX sum, each with its sign: ``"a + b \\left(c - d\\right) - e"`` ->
    ``["a", "+ b \\left(c - d\\right)", "- e"]``. Signs inside braces, brackets or ``\\left...\\right``
    pairs stay where they are; a leading sign stays with the first term."""
    terms: list[str] = []
    depth = 0
    start = 0
    i = 0
    while i < len(latex):
        if latex.startswith("\\left", i):
            depth += 1
            i += 5
            continue
        if latex.startswith("\\right", i):
            depth -= 1
            i += 6
            continue
        char = latex[i]
        if char == "\\":  # a command or an escaped character: skip its name
            i += 2
            while i < len(latex) and latex[i].isalpha():
                i += 1
            continue
        if char in "{[(":
            depth += 1
        elif char in "}])":
            depth -= 1
        elif char in "+-" and depth == 0 and latex[start:i].strip():
            previous = latex[start:i].rstrip()
            if previous and previous[-1] not in "=+-^_{":  # a binary sign, not a unary one or an exponent
                terms.append(latex[start:i].strip())
                start = i
        i += 1
    terms.append(latex[start:].strip())
    return [term for term in terms if term]


def _matching_right(latex: str, start: int) -> int:
    """Index of the ``\\right`` that closes the ``\\left`` at ``start``."""
    depth = 0
    i = start
    while i < len(latex):
        if latex.startswith("\\left", i):
            depth += 1
            i += 5
        elif latex.startswith("\\right", i):
            depth -= 1
            if depth == 0:
                return i
            i += 6
        else:
            i += 1
    return -1


def _fragments(term: str, width: int) -> list[str]:
    """A term too long for a line, opened up: its first ``\\left( ... \\right)`` becomes ``\\Bigl( ... \\Bigr)``
    (delimiters that may span lines) and the sum inside is broken between its terms, recursively."""
    if len(term) <= width:
        return [term]
    start = term.find("\\left(")
    while start >= 0:
        end = _matching_right(term, start)
        if end < 0:
            return [term]
        if term.startswith("\\right)", end):
            inner_terms = split_latex_terms(term[start + 6 : end])
            if len(inner_terms) >= 2:  # a parenthesised sum: open it here
                break
        start = term.find("\\left(", end)
    else:
        return [term]  # no parenthesised sum to open: the term stays whole
    prefix, suffix = term[:start], term[end + 7 :]
    pieces = [piece for inner_term in inner_terms for piece in _fragments(inner_term, width)]
    pieces[0] = f"{prefix}\\Bigl({pieces[0]}"
    pieces[-1] = f"{pieces[-1]}\\Bigr){suffix}"
    if suffix.strip() and len(pieces[-1]) > width:  # another parenthesised factor after this one
        opened = _fragments(pieces[-1], width)
        if len(opened) > 1:
            pieces[-1:] = opened
    return pieces


def wrap_latex_equation(latex: str, width: int = TEX_LINE_CHARACTERS) -> list[str]:
    """``lhs = rhs`` as lines of at most about ``width`` source characters, broken between terms; the first
    line starts the left side and a line begins with ``=`` where the right side starts."""
    lhs, sep, rhs = latex.partition(" = ")
    pieces = split_latex_terms(lhs) + ([f"= {term}" if k == 0 else term for k, term in enumerate(split_latex_terms(rhs))]
                                       if sep else [])
    lines: list[str] = []
    current = ""
    for piece in [fragment for piece in pieces for fragment in _fragments(piece, width)]:
        starts_rhs = piece.startswith("= ")
        if current and (starts_rhs or len(current) + 1 + len(piece) > width):
            lines.append(current)
            current = piece
        else:
            current = f"{current} {piece}".strip()
    if current:
        lines.append(current)
    return lines


def multline(latex: str, width: int = TEX_LINE_CHARACTERS) -> str:
    r"""A ``multline*`` environment of the equation, broken into lines (``\\`` between them)."""
    return "\\begin{multline*}\n" + " \\\\\n".join(wrap_latex_equation(latex, width)) + "\n\\end{multline*}"
