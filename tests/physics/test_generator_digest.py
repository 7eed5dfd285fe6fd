"""The generated code's name carries a digest of every source file that shapes it, so that a change of a
derivation is never hidden by code generated before it (a mechanism's cache key is its structure only)."""

from __future__ import annotations

import ast
from pathlib import Path

import physics
from physics.codegen.cache import _generator_sources

PACKAGE = Path(physics.__file__).resolve().parent


def _local_imports(path: Path, seen: set[Path]) -> None:
    """Every module of the package that ``path`` imports, directly or through another, into ``seen``."""
    if path in seen or not path.exists():
        return
    seen.add(path)
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.ImportFrom) or not node.level:
            continue
        base = path.parent
        for _ in range(node.level - 1):
            base = base.parent
        target = base.joinpath(*node.module.split(".")) if node.module else base
        candidates = [target.with_suffix(".py"), target / "__init__.py"]
        candidates += [target / f"{alias.name}.py" for alias in node.names]
        candidates += [target / alias.name / "__init__.py" for alias in node.names]
        for candidate in candidates:
            _local_imports(candidate.resolve(), seen)


def test_every_module_a_mechanism_derivation_reads_is_in_the_digest():
    roots = [*PACKAGE.glob("mechanism/symbolic*.py"), PACKAGE / "mechanism" / "parameters.py"]
    assert len(roots) >= 5, roots
    seen: set[Path] = set()
    for root in roots:
        _local_imports(root.resolve(), seen)
    digested = {path.resolve() for path in _generator_sources()}
    missing = sorted(str(path.relative_to(PACKAGE)) for path in seen - digested if path.name != "__init__.py")
    assert not missing, f"add to _GENERATOR_PATTERNS in physics/codegen/cache.py: {missing}"
    assert PACKAGE / "mechanism" / "joints" / "gear.py" in seen  # the walk does reach the joint kinds
