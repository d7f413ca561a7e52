"""The README stays a short user's guide, and the README and the docs speak of the project only.

The docs site itself is built strictly by ``make docs`` (broken links and anchors, pages missing
from the nav); these checks need no MkDocs.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"
#: work-log language: the project speaks of the project, not of how it was made
HISTORY = re.compile(r"\bsession [0-9]|\bissue #?[0-9]|a reviewer", re.IGNORECASE)
#: an inline Markdown link or image: [text](target) or ![alt](target "title")
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)


def text_files() -> list[Path]:
    """README.md and every text file under docs/ (images and other binaries left out)."""
    files = [README]
    for path in sorted(DOCS.rglob("*")):
        if path.is_file():
            try:
                path.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                continue
            files.append(path)
    return files


def relative_links(markdown: str) -> list[str]:
    """The link targets of a Markdown text that point into the repository (no URL, no bare anchor),
    outside fenced code blocks."""
    prose = FENCE.sub("", markdown)
    targets = [m.group(1) for m in LINK.finditer(prose)]
    return [t for t in targets if not re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", t) and not t.startswith("#")]


def test_readme_is_short_and_names_the_test_command():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) < 150, f"README.md has {len(lines)} lines; measurements and history belong in docs/"
    assert any("make test" in line for line in lines), "README.md must show `make test`, the command CI runs"


@pytest.mark.parametrize("path", text_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_work_log_language(path):
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        match = HISTORY.search(line)
        assert match is None, f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r} in {line.strip()!r}"


def test_readme_links_point_at_existing_files():
    links = relative_links(README.read_text(encoding="utf-8"))
    assert links, "the README links the docs"
    missing = [t for t in links if not (ROOT / t.split("#", 1)[0]).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_the_link_finder_sees_links_and_skips_urls_anchors_and_code():
    text = ('See [a](docs/a.md#x), ![b](docs/img/b.png "t"), [c](https://example.org), [d](#top).\n'
            "```\n[e](not/a/link.md)\n```\n")
    assert relative_links(text) == ["docs/a.md#x", "docs/img/b.png"]


def test_every_docs_page_is_in_the_site_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    missing = [page for page in pages if page not in nav]
    assert not missing, f"docs pages missing from mkdocs.yml's nav: {missing}"
