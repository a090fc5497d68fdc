"""Every file the repository cites is in the repository.

The text files of the repository (``git ls-files``: tracked, plus new files git does not
ignore; build outputs and other ignored paths are not part of it) are searched for cited
files — a token ending in .md, .json, .toml, .txt, .csv, .png or .py:

* a path (``docs/SCIENCE.md``, ``docs/gallery/pal.toml``, ``eyelab/optics/eye/thin.py``) whose
  first folder is one of the repository's top-level folders must be a file of the
  repository; so must any path to a Markdown document, whatever its first folder (a
  document outside the repository, such as ``elsewhere/docs/NOTES.md``, is a broken
  citation);
* a bare document name (``SCIENCE.md``) must name exactly one Markdown file of the
  repository (``SCIENCE.md`` resolves to ``docs/SCIENCE.md``);
* bare names and paths of other files under folders that are not the repository's
  (``out.png``, ``tmp/r.json``) are files a command writes, not citations, and are
  skipped; so are templates (``{name}.toml``, ``job-*.png``), URLs and absolute paths.

A cited section (``docs/SCIENCE.md §9b``, ``SCIENCE.md §3``, ``docs/VTK_NOTES.md Q2``)
must be a heading of that document.
"""

from __future__ import annotations

import re
import subprocess
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: This file: its examples of broken citations are deliberate, so it is not searched.
SELF = Path(__file__).resolve().relative_to(ROOT).as_posix()
#: Files searched for citations.
TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt", ".cfg", ".ini", ".yml", ".yaml", ".glsl",
                 ".rst"}
#: What a cited file may be.
CITED = ("md", "json", "toml", "txt", "csv", "png", "py")
_TOKEN = re.compile(r"[\w./*{}…<>$~-]*\.(?:" + "|".join(CITED) + r")(?![\w/-])")
_URL = re.compile(r"\b[a-z][a-z0-9+.-]*://\S+", re.IGNORECASE)
_SECTION = re.compile(r"([\w./-]*\b[A-Z][A-Z_]*\.md)\s+(§\s?\d+[a-z]?|Q\d+)")


def repository_files(root: Path = ROOT) -> list[str]:
    """The repository's files (relative POSIX paths): tracked and not-ignored new files."""
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                             cwd=root, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return sorted({p for p in out.splitlines() if (root / p).is_file()})


def citations(text: str) -> list[str]:
    """The candidate file citations in ``text``: path-like tokens with a cited suffix,
    outside URLs, without template characters, neither absolute nor hidden."""
    out = []
    for m in _TOKEN.finditer(_URL.sub(" ", text)):
        tok = m.group(0).removeprefix("./")
        if any(c in tok for c in "*{}…<>$~") or tok.startswith((".", "/")):
            continue
        out.append(tok)
    return out


def unresolved(text: str, files: list[str]) -> list[str]:
    """The citations in ``text`` that name no file of ``files`` (see the module text)."""
    have = set(files)
    top = {f.split("/", 1)[0] for f in files if "/" in f}
    by_name = defaultdict(list)
    for f in files:
        by_name[f.rsplit("/", 1)[-1]].append(f)
    bad = []
    for tok in citations(text):
        if "/" in tok:
            if (tok.split("/", 1)[0] in top or tok.endswith(".md")) and tok not in have:
                bad.append(tok)
        elif tok.endswith(".md") and len(by_name.get(tok, [])) != 1:
            bad.append(tok)
    return bad


def resolve(doc: str, files: list[str]) -> str | None:
    """The repository file a document citation names (a path, or a unique bare name)."""
    if doc in files:
        return doc
    match = [f for f in files if f.rsplit("/", 1)[-1] == doc.rsplit("/", 1)[-1]]
    return match[0] if len(match) == 1 and "/" not in doc else None


def headings(path: Path) -> set[str]:
    """Section labels of a Markdown document: '§9b' for '## 9b. ...', 'Q2' for '## Q2 ...'."""
    out = set()
    for line in path.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#+\s+(?:§\s?)?(\d+[a-z]?)[.:\s]", line)
        if m:
            out.add("§" + m.group(1))
        m = re.match(r"#+\s+(Q\d+)\b", line)
        if m:
            out.add(m.group(1))
    return out


def missing_sections(text: str, files: list[str], root: Path = ROOT) -> list[str]:
    """'doc §N' citations in ``text`` whose document has no such heading."""
    bad = []
    for doc, sec in _SECTION.findall(text):
        path = resolve(doc, files)
        if path is None:
            continue                                  # reported by unresolved()
        if sec.replace(" ", "") not in headings(root / path):
            bad.append(f"{doc} {sec}")
    return bad


def _texts(files):
    for f in files:
        if Path(f).suffix in TEXT_SUFFIXES and f != SELF:
            yield f, (ROOT / f).read_text(encoding="utf-8", errors="replace")


def test_every_cited_file_is_in_the_repository():
    files = repository_files()
    bad = {f: sorted(set(b)) for f, text in _texts(files) if (b := unresolved(text, files))}
    assert not bad, f"citations of files that are not in the repository: {bad}"


def test_every_cited_section_exists():
    files = repository_files()
    bad = {f: b for f, text in _texts(files) if (b := missing_sections(text, files))}
    assert not bad, f"citations of sections that their documents lack: {bad}"


def test_the_science_sheet_has_the_cited_sections():
    files = repository_files()
    assert "docs/SCIENCE.md" in files
    want = {f"§{n}" for n in range(1, 12)} | {"§9b"}
    assert want <= headings(ROOT / "docs" / "SCIENCE.md")


def test_the_checks_fail_on_broken_citations(tmp_path):
    """The checker itself: missing files, outside documents, ambiguous or unknown bare
    names and missing sections are reported; real files, outputs, templates and URLs
    are not."""
    files = ["README.md", "docs/SCIENCE.md", "docs/gallery/pal.toml", "eyelab/optics/eye/thin.py",
             "docs/a/NOTES.md", "docs/b/NOTES.md"]
    text = ("see docs/SCIENCE.md §2 and SCIENCE.md, docs/gallery/pal.toml, "
            "`eyelab/optics/eye/thin.py`; writes out.png, tmp/r.json, {name}.toml, job-*.png, "
            "path.with_suffix('.png'); https://example.org/x/MISSING.md; /tmp/abs.md.\n"
            "Broken: docs/gallery/gone.toml, eyelab/optics/gone.py, elsewhere/docs/SCIENCE.md, "
            "OTHER.md, NOTES.md.")
    assert sorted(unresolved(text, files)) == sorted([
        "docs/gallery/gone.toml", "eyelab/optics/gone.py", "elsewhere/docs/SCIENCE.md",
        "OTHER.md", "NOTES.md"])
    assert resolve("SCIENCE.md", files) == "docs/SCIENCE.md"
    assert resolve("NOTES.md", files) is None
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "SCIENCE.md").write_text("# Sheet\n## 1. One\n## 9b. Nine b\n"
                                                  "## Q2 – Route\n")
    cited = "docs/SCIENCE.md §1, SCIENCE.md §9b, docs/SCIENCE.md Q2; SCIENCE.md §9, §12"
    assert missing_sections(cited, files, tmp_path) == ["SCIENCE.md §9"]
