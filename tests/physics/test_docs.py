"""The documentation holds together: every relative link in README.md and docs/*.md reaches a file that exists, and
docs/physics.md covers every formulation the code registers."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

from physics.model import FORMULATION_NAMES

ROOT = Path(__file__).resolve().parents[2]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_FENCE = re.compile(r"^(`{3,}|~{3,}).*?^\1[ \t]*$", re.MULTILINE | re.DOTALL)  # fenced code blocks
_CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1", re.DOTALL)  # inline code: `x[i](y)` is not a link
_INLINE_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_REFERENCE_DEFINITION = re.compile(r"^ {0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", re.MULTILINE)
_EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//)", re.IGNORECASE)  # http:, https:, mailto:, //host


def relative_links(text: str) -> list[str]:
    """Link targets in markdown text that point into the repository (no scheme, not a bare #anchor)."""
    prose = _CODE_SPAN.sub("", _FENCE.sub("", text))
    targets = _INLINE_LINK.findall(prose) + _REFERENCE_DEFINITION.findall(prose)
    return [t for t in targets if not _EXTERNAL.match(t) and not t.startswith("#")]


def test_link_finder_sees_links_and_skips_code_and_external_targets():
    text = (
        "See [physics](docs/physics.md#1-conventions) and ![plot](img/a.png \"title\").\n"
        "[ref]: BENCHMARKS.md\n"
        "Not links: `x[i](y)`, [web](https://example.org), [mail](mailto:a@b.c), [here](#top).\n"
        "```python\nA[0](1)\n[code](inside/fence.md)\n```\n"
    )
    assert relative_links(text) == ["docs/physics.md#1-conventions", "img/a.png", "BENCHMARKS.md"]


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_points_to_an_existing_file(document):
    broken = []
    for target in relative_links(document.read_text(encoding="utf-8")):
        path = unquote(target.split("#", 1)[0].split("?", 1)[0])
        resolved = (ROOT / path.lstrip("/")) if path.startswith("/") else (document.parent / path)
        if not resolved.exists():
            broken.append(target)
    assert not broken, f"{document.relative_to(ROOT)} links to missing files: " + "; ".join(dict.fromkeys(broken))


def test_readme_and_docs_exist():
    assert (ROOT / "README.md").exists()
    assert (ROOT / "docs" / "physics.md") in DOCUMENTS


@pytest.mark.parametrize("name", FORMULATION_NAMES)
def test_physics_guide_names_every_formulation(name):
    text = (ROOT / "docs" / "physics.md").read_text(encoding="utf-8")
    assert f"`{name}`" in text, f"docs/physics.md never names the formulation `{name}`"
