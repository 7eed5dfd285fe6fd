"""The derived equations as LaTeX, for the app's equations panel and the docs (sympy: never on a hot path).

Each row of ``A x = b`` is printed as ``sum_j A_ij x_j = b_i`` after a light ``trigsimp`` per entry, with
the row's label (which balance or constraint it is). Results are cached beside the generated code, with an
HMAC of their name and content under the user's key (:mod:`physics.cache_folder`): the app shows them.
"""

from __future__ import annotations

import json

from ..cache_folder import UntrustedFile, discard, mac, mac_matches, read_trusted, warn
from .cache import _write_atomically, cache_dir, generator_digest

MAX_TERMS_SIMPLIFIED = 60  # entries larger than this are printed as derived, without trigsimp


def equations_latex(formulation: str, n: int, pinned: bool = False) -> dict:
    """``{"title", "unknowns": [latex], "rows": [{"label", "latex"}], "shape": [k, k]}`` for the system."""
    path = cache_dir() / f"latex-{formulation}-n{n}-{'pinned' if pinned else 'open'}-{generator_digest()}.json"
    try:
        stored = json.loads(read_trusted(path))
        body = json.dumps(stored["data"], sort_keys=True)
        if mac_matches(path.name, body.encode(), str(stored["hmac"])):
            return stored["data"]
        problem = "MAC differs"
    except FileNotFoundError:
        problem = None
    except UntrustedFile as error:
        problem = str(error)
    except (ValueError, KeyError, TypeError, RecursionError):  # not UTF-8, not JSON, not our shape
        problem = "not a complete entry"
    if problem is not None:
        warn(f"cached equations {path} are not trusted ({problem}); discarded and rebuilt")
        discard(path)
    data = _derive_latex(formulation, n, pinned)
    body = json.dumps(data, sort_keys=True)
    _write_atomically(path, json.dumps({"data": data, "hmac": mac(path.name, body.encode())}))
    return data


def _derive_latex(formulation: str, n: int, pinned: bool) -> dict:
    # sympy boundary: only when the LaTeX is not cached yet.
    import sympy as sp  # noqa: PLC0415

    from ..derive import FORMULATIONS  # noqa: PLC0415

    cls = FORMULATIONS[formulation]
    system = cls().derive(n, pinned)
    undamped = {system.symbols.damping: 0}  # joint damping is a test/teaching option: show the conservative system

    def tidy(expr):
        expr = expr.xreplace(undamped)
        if sp.count_ops(expr) <= MAX_TERMS_SIMPLIFIED:
            return sp.trigsimp(sp.expand(expr))
        return expr

    names = {}
    for u in system.unknowns:
        text = str(u)
        if text.startswith("theta_ddot_"):
            names[u] = sp.Symbol(r"\ddot{\theta}_{%s}" % text.split("_")[-1])
        elif text.startswith("a_x") or text.startswith("a_y"):
            names[u] = sp.Symbol(r"\ddot{%s}_{G%s}" % (text[2], text[3:]))
        else:
            names[u] = u
    rows = []
    k = len(system.unknowns)
    for i in range(k):
        lhs = sum((tidy(system.A[i, j]) * names[system.unknowns[j]] for j in range(k) if system.A[i, j].xreplace(undamped) != 0),
                  sp.Integer(0))
        rhs = tidy(system.b[i])
        rows.append({"label": system.equation_names[i], "latex": f"{sp.latex(lhs)} = {sp.latex(rhs)}"})
    return {
        "title": cls.title,
        "formulation": formulation,
        "links": n,
        "pinned": pinned,
        "shape": [k, k],
        "unknowns": [sp.latex(names[u]) for u in system.unknowns],
        "rows": rows,
    }
