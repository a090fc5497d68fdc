"""The gallery's examples (examples/gallery/, executed by sphinx-gallery at every docs
build): its sections and their headers, each example's title and cells, and — slow-marked,
since the docs build runs them anyway — that each one runs on its own and writes nothing
outside a temporary folder of its own."""

import ast
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "examples" / "gallery"
SECTIONS = sorted(p for p in GALLERY.iterdir() if p.is_dir() and p.name != "__pycache__")
EXAMPLES = sorted(GALLERY.glob("*/plot_*.py"))


def rst_title(text: str):
    """(title, its underline character) when ``text`` starts with an RST title, else None."""
    lines = text.strip("\n").splitlines()
    if len(lines) < 2 or not lines[0].strip():
        return None
    title, rule = lines[0].rstrip(), lines[1].rstrip()
    if len(set(rule)) != 1 or rule[0] not in "=-~^*+#" or len(rule) < len(title):
        return None
    return title, rule[0]


def test_the_gallery_has_its_sections_and_examples():
    assert len(EXAMPLES) >= 15, [p.name for p in EXAMPLES]
    names = [p.name for p in SECTIONS]
    assert len(names) >= 4, names
    for name in ("first-steps", "lenses", "eyes", "myopia-control", "tools"):
        assert name in names, names
    for section in SECTIONS:
        assert list(section.glob("plot_*.py")), f"{section.name}: no example"
    assert not list(GALLERY.glob("plot_*.py")), "every example sits in a section's folder"
    stems = [p.stem for p in EXAMPLES]          # sphinx-gallery names figures by the stem
    assert len(set(stems)) == len(stems), stems


def test_the_gallery_and_each_section_have_a_header():
    assert rst_title((GALLERY / "GALLERY_HEADER.rst").read_text()) is not None
    for section in SECTIONS:
        header = section / "GALLERY_HEADER.rst"
        assert header.exists(), section.name
        text = header.read_text()
        assert rst_title(text) is not None, header
        body = text.strip().splitlines()[2:]
        assert " ".join(body).strip().endswith("."), f"{header}: a title and a sentence"


def test_the_conf_orders_every_section():
    conf = (ROOT / "docs" / "conf.py").read_text()
    for section in SECTIONS:
        assert f'"{section.name}"' in conf, f"docs/conf.py's subsection_order: {section.name}"


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_each_example_has_a_title_text_and_cells(path):
    source = path.read_text()
    doc = ast.get_docstring(ast.parse(source), clean=False)
    assert doc is not None, f"{path.name}: no module docstring"
    title = rst_title(doc)
    assert title is not None and title[1] == "=", f"{path.name}: starts with an RST title"
    body = " ".join(doc.strip().splitlines()[2:])
    sentences = len(re.findall(r"[.!?](\s|$)", body))
    assert sentences >= 2 and len(body.split()) <= 120, \
        f"{path.name}: a few sentences under the title (2-4, at most 120 words)"
    assert "# %%" in source, f"{path.name}: code cells with # %% comments"
    assert "matplotlib.pyplot" in source, f"{path.name}: draws a matplotlib figure"
    for cell in re.split(r"^# %%.*$", source, flags=re.M)[1:]:
        body = ast.parse(cell).body
        last = body[-1] if body else None
        # sphinx-gallery prints the repr of a cell's last bare expression under it
        if isinstance(last, ast.Expr) and isinstance(last.value, ast.Call):
            called = ast.unparse(last.value.func)
            assert called in ("print", "plt.show"), f"{path.name}: a cell ends in {called}()"


def git_status() -> set:
    out = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"],
                         cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(out.splitlines())


@pytest.mark.slow
@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_each_example_runs_and_writes_only_into_a_temporary_folder(path):
    before = git_status()
    with tempfile.TemporaryDirectory() as cwd:
        env = dict(os.environ, MPLBACKEND="Agg")
        r = subprocess.run([sys.executable, str(path)], cwd=cwd, env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
        left = sorted(os.listdir(cwd))
    assert not left, f"{path.name} wrote into the current folder: {left}"
    changed = git_status() ^ before
    assert not changed, f"{path.name} changed the checkout: {sorted(changed)}"
