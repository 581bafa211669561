"""Tuning constants say in the source what they mean; why they have their value lives in ``docs/decisions/``.

Each decision is a heading of a page in ``docs/decisions/`` with its question, evidence, command and answer; a source
points to it as ``docs/decisions/PAGE.md#anchor`` (``(why: ...)``). These tests keep the pointers resolving and the
sources from citing seed numbers and benchmark scripts themselves again.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
DECISIONS = ROOT / "docs" / "decisions"

#: A pointer from a source to a decision: the page, and the heading's anchor.
POINTER = re.compile(r"docs/decisions/([\w.-]+\.md)(?:#([\w-]+))?")
#: A seed number or a benchmark script path cited in a source (a line break, in a comment too, may follow ``seed``).
CITATION = re.compile(r"benchmarks/|\bseeds?(?:\s+#:?)?\s+\d")
#: At most this many such citations in ``src/`` (issue 55): what is left names what a function does or what the
#: README's figure is, not the evidence for a tuning constant.
MAX_CITATIONS = 5
#: What every decision entry says, in this order.
ENTRY_PARTS = ("**Question.**", "**Evidence.**", "**Command.**", "**Answer.**")


def slug(heading: str) -> str:
    """The anchor the documentation site gives a heading: Python-Markdown's default ``toc`` slug of its text.

    Examples
    --------
    >>> slug("LAZY_LAST_LEVEL_ABOVE")
    'lazy_last_level_above'
    >>> slug("uncut boxes elongated alike")
    'uncut-boxes-elongated-alike'
    """
    text = re.sub(r"[`*]", "", heading)  # inline code and emphasis marks are not part of the text
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def headings(page: Path) -> list[str]:
    """The Markdown headings of ``page`` (their text), outside code blocks."""
    out, fenced = [], False
    for line in page.read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and (m := re.match(r"#{1,6} (.+)", line)):
            out.append(m.group(1).strip())
    return out


def broken_pointers(text: str, where: str) -> list[str]:
    """Each pointer in ``text`` to a page of ``docs/decisions/`` that does not exist, or to a heading it lacks."""
    bad = []
    for m in POINTER.finditer(text):
        page, anchor = DECISIONS / m.group(1), m.group(2)
        if not page.is_file():
            bad.append(f"{where}: {m.group(0)}: no such page")
        elif anchor is not None and anchor not in {slug(h) for h in headings(page)}:
            bad.append(f"{where}: {m.group(0)}: no such heading")
    return bad


def sources() -> list[Path]:
    return sorted(SRC.rglob("*.py"))


def test_every_pointer_in_the_sources_resolves() -> None:
    texts = {p.relative_to(ROOT).as_posix(): p.read_text() for p in sources()}
    assert sum(len(POINTER.findall(t)) for t in texts.values()) >= 20  # the constants of issue 55 point here
    bad = [b for where, text in texts.items() for b in broken_pointers(text, where)]
    assert bad == [], "\n".join(bad)


def test_a_broken_pointer_is_caught() -> None:
    text = "(why: docs/decisions/threads.md#no_such_constant) (why: docs/decisions/missing.md#x)"
    assert broken_pointers(text, "here") == [
        "here: docs/decisions/threads.md#no_such_constant: no such heading",
        "here: docs/decisions/missing.md#x: no such page",
    ]
    assert broken_pointers("(why: docs/decisions/threads.md#min_work_per_thread)", "here") == []


def test_the_sources_cite_few_seed_numbers_or_benchmark_scripts() -> None:
    hits = []
    for p in sources():
        text = p.read_text()
        for m in CITATION.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            hits.append(f"{p.relative_to(ROOT).as_posix()}:{line}: {text.splitlines()[line - 1].strip()}")
    assert len(hits) <= MAX_CITATIONS, "move the evidence to docs/decisions/ and point there:\n" + "\n".join(hits)


def test_the_citation_count_sees_a_citation() -> None:
    assert CITATION.search("seed 7552 of the greenhouse") and CITATION.search("(seeds\n#: 3000-3039)")
    assert CITATION.search("``python benchmarks/threads.py``")
    assert not CITATION.search("rng = np.random.default_rng(seed)")


def test_every_entry_states_question_evidence_command_answer() -> None:
    pages = sorted(p for p in DECISIONS.glob("*.md") if p.name != "index.md")
    assert pages
    for page in pages:
        entries = re.split(r"^## ", page.read_text(), flags=re.M)[1:]
        assert entries, page.name
        for entry in entries:
            name = entry.splitlines()[0]
            where = [entry.find(part) for part in ENTRY_PARTS]
            assert -1 not in where and where == sorted(where), f"{page.name}, {name}: needs {ENTRY_PARTS} in order"


def test_the_index_and_the_site_list_every_page() -> None:
    index = (DECISIONS / "index.md").read_text()
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in DECISIONS.glob("*.md"):
        assert f"decisions/{page.name}" in nav, page.name
        if page.name != "index.md":
            assert f"]({page.name})" in index, page.name


def test_the_anchors_are_the_sites() -> None:
    """:func:`slug` gives the anchors the documentation site renders (Python-Markdown's ``toc``, as mkdocs uses it)."""
    markdown = pytest.importorskip("markdown")
    for page in DECISIONS.glob("*.md"):
        md = markdown.Markdown(extensions=["toc"])
        html = md.convert(page.read_text())
        rendered = re.findall(r'<h[1-6] id="([^"]+)"', html)
        assert rendered == [slug(h) for h in headings(page)], page.name
