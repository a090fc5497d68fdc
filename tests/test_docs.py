"""Docs are code: the README is a short front door whose commands and Python run as
written, the guide's specs parse, the generated references are current, the example files
are what the pages show, and the documentation site builds with warnings as errors."""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
PAGES = sorted((ROOT / "docs" / "guide").glob("*.md")) + sorted(
    (ROOT / "docs" / "reference").glob("*.md"))

#: The README's front-door limits (lines; the line by which a spec has appeared).
README_MAX_LINES = 250
SPEC_BY_LINE = 60


def _blocks(text: str, lang: str) -> list:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


def _workdir(tmp_path: Path) -> Path:
    """A folder holding what the README's commands read: examples/ and the gallery's specs
    (``docs/gallery/*.toml``), as in a clone."""
    work = tmp_path / "clone"
    shutil.copytree(ROOT / "examples", work / "examples")
    (work / "docs" / "gallery").mkdir(parents=True)
    for f in (ROOT / "docs" / "gallery").glob("*.toml"):
        shutil.copy(f, work / "docs" / "gallery" / f.name)
    return work


def readme_commands() -> list:
    """Every ``eyelab ...`` command the README shows, fenced or inline, that can run here
    as written: not a placeholder (``COMMAND``), not the window (``inspect``) and not a
    benchmark (their own tests run them); the install line is CI's (.ci/run)."""
    fenced = [ln.strip() for b in _blocks(README, "bash") for ln in b.splitlines()]
    inline = re.findall(r"`(eyelab [^`]+)`", README)
    out = []
    for cmd in fenced + inline:
        if not cmd.startswith("eyelab ") or re.search(r"\b[A-Z]{3,}\b", cmd):
            continue
        if cmd.split()[1] in ("inspect", "bench", "demo") or cmd in out:
            continue
        out.append(cmd)
    return out


def test_the_readme_is_a_front_door():
    lines = README.splitlines()
    assert len(lines) <= README_MAX_LINES, len(lines)
    first_spec = next(i for i, ln in enumerate(lines, 1) if ln.startswith("```toml"))
    assert first_spec <= SPEC_BY_LINE, first_spec
    assert _blocks(README, "toml")[0] == (ROOT / "examples" / "first.toml").read_text()


def test_the_readme_links_resolve():
    links = re.findall(r"\]\(([^)#\s]+)\)", README)
    missing = [t for t in links if "://" not in t and not (ROOT / t).exists()]
    assert not missing and len(links) > 20, missing


def test_the_readme_commands_run_as_written(tmp_path):
    work = _workdir(tmp_path)
    cmds = readme_commands()
    assert {c.split()[1] for c in cmds} >= {"render", "analyze", "maps", "surface", "psf",
                                            "batch"}, cmds
    env = dict(os.environ, COLUMNS="100")
    for cmd in cmds:
        r = subprocess.run([sys.executable, "-P", "-m", "eyelab.apps.cli",
                            *shlex.split(cmd)[1:]], cwd=work, env=env,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, f"{cmd}: {r.stdout[-800:]}{r.stderr[-800:]}"
    assert (work / "first.png").stat().st_size and (work / "first.json").exists()
    assert (work / "batch-out" / "summary.csv").exists()


def test_the_readme_python_runs(tmp_path, monkeypatch):
    work = _workdir(tmp_path)
    monkeypatch.chdir(work)
    (code,) = _blocks(README, "python")
    exec(compile(code, "README.md", "exec"), {})
    assert (work / "first-api.png").stat().st_size > 0


def _is_jobspec(data: dict) -> bool:
    return bool({"sweep", "cases", "output", "base"} & set(data)) or "spec" in data


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_every_spec_in_the_docs_is_valid(page, tmp_path):
    """Every TOML block of the guide and the references is a spec (or job spec) that
    eyelab accepts, its files read from examples/ (where the page names its example file,
    the block is that file)."""
    from eyelab.jobs.batch import load_job_spec, validate_jobs
    from eyelab.spec.load import parse_spec

    text = page.read_text()
    for block in _blocks(text, "toml"):
        named = re.search(r"This is\s+`examples/(\w+\.toml)`", text[:text.index(block)][-300:])
        if named:
            assert block == (ROOT / "examples" / named.group(1)).read_text(), named.group(1)
        data = tomllib.loads(block)
        if _is_jobspec(data):
            p = ROOT / "examples" / "base.toml"
            job = tmp_path / "job.toml"
            job.write_text(block)
            if "spec" in data:
                shutil.copy(p, tmp_path / data["spec"])
            validate_jobs(load_job_spec(job, out_dir=tmp_path / "out"))
        else:
            parse_spec(data, base=ROOT / "examples")


def test_the_examples_are_valid():
    """Every example spec loads as itself (its files read from examples/), with the lens
    and the eye it says it has."""
    from eyelab.spec.load import load_spec

    specs = {f.name: load_spec(f) for f in sorted((ROOT / "examples").glob("*.toml"))
             if f.name != "batch.toml"}              # the job spec: test_every_spec_in_the_docs
    assert len(specs) >= 6, sorted(specs)
    for name, spec in specs.items():
        has_lens = "[lens" in (ROOT / "examples" / name).read_text()
        assert (spec.lens is not None) == has_lens, name
    assert specs["aberrometer.toml"].eye.aberrations is not None
    assert specs["frame.toml"].lens.outline is not None


def test_the_command_reference_is_generated():
    from eyelab.apps.clidoc import markdown

    have = (ROOT / "docs" / "reference" / "cli.md").read_text()
    assert have == markdown(), "run: python -m eyelab.apps.clidoc --write docs/reference/cli.md"


@pytest.mark.skipif(importlib.util.find_spec("sphinx") is None
                    and not os.environ.get("EYELAB_REQUIRE_DOCS"),
                    reason="the docs extra is not installed (CI sets EYELAB_REQUIRE_DOCS)")
def test_the_documentation_builds_without_warnings(tmp_path):
    r = subprocess.run([sys.executable, "-P", "-m", "sphinx", "-W", "--keep-going", "-q",
                        "-b", "html", str(ROOT / "docs"), str(tmp_path / "html")],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    pages = ["index", "guide/commands", "reference/spec", "reference/cli", "reference/api",
             "_generated/benchmarks", "gallery_examples/index"]
    pages += [f"gallery_examples/{p.stem}" for p in (ROOT / "examples" / "gallery").glob(
        "plot_*.py")]
    for page in pages:
        assert (tmp_path / "html" / f"{page}.html").exists(), page
    images = list((tmp_path / "html" / "_images").glob("sphx_glr_plot_*.png"))
    assert len(images) >= len(pages) - 7, images          # every example drew its figure
    api = (tmp_path / "html" / "reference" / "api.html").read_text()
    assert "eyelab.jobs.api.render" in api and "Session" in api


def test_the_corpus_size_the_guide_quotes_is_the_generators():
    sys.path.insert(0, str(ROOT / "tests"))
    import badspecs

    text = (ROOT / "docs" / "guide" / "commands.md").read_text()
    quoted = re.search(r"generated corpus of ([\d,]+)\s+bad specs", text).group(1)
    assert int(quoted.replace(",", "")) == len(badspecs.corpus())


def test_the_install_numbers_the_readme_quotes_are_the_measured_ones():
    import json

    bench = json.loads((ROOT / "docs" / "bench" / "newcomer.json").read_text())
    size = re.search(r"The environment holds ([\d,]+) MB", README).group(1)
    assert int(size.replace(",", "")) == round(bench["venv_size_mb"])
    line, demo = re.search(r"install line took (\d+) s.*?demo\s+(\d+) s", README, re.S).groups()
    steps = bench["steps_s"]
    assert (int(line), int(demo)) == (round(steps["apt-get"]), round(steps[".venv/bin/eyelab"]))


def test_the_notebook_page_runs(tmp_path, monkeypatch):
    """The notebook guide's code, executed as written (then its inspector closed)."""
    pytest.importorskip("ipywidgets")
    work = _workdir(tmp_path)
    monkeypatch.chdir(work)
    (code,) = _blocks((ROOT / "docs" / "guide" / "notebook.md").read_text(), "python")
    scope = {}
    exec(compile(code, "notebook.md", "exec"), scope)
    ins = scope["inspector"]
    try:
        assert ins.image.value[:8] == b"\x89PNG\r\n\x1a\n"
    finally:
        ins.close()


#: The share of a gallery picture's pixels that may differ by more than 2 levels from what
#: its documented command writes now (the rasteriser's last-bit differences between
#: machines; a stale picture differs in 1-12 % of its pixels).
GALLERY_TOLERANCE = 0.005


def gallery_commands() -> list:
    """(command, picture) for every documented command that draws a picture of the
    gallery folder (``eyelab demo`` or ``render`` with ``-o`` there), from the README and
    the guide."""
    texts = [README] + [p.read_text() for p in PAGES]
    found = []
    for text in texts:
        for cmd in re.findall(r"`(eyelab (?:demo|render)\s[^`]*-o\s+docs/gallery/[\w-]+\.png)`",
                              text):
            cmd = " ".join(cmd.split())
            if cmd not in [c for c, _ in found]:
                found.append((cmd, cmd.split("-o ")[1].split()[0]))
    return found


def test_the_gallery_pictures_are_what_their_commands_draw(tmp_path):
    from PIL import Image

    found = gallery_commands()
    assert {Path(p).name for _, p in found} >= {"demo.png", "etdrs_demo.png", "binocular.png",
                                                 "binocular_anaglyph.png"}, found
    for cmd, picture in found:
        out = tmp_path / Path(picture).name
        argv = shlex.split(cmd.replace(f"-o {picture}", f"-o {out}"))[1:]
        r = subprocess.run([sys.executable, "-P", "-m", "eyelab.apps.cli", *argv], cwd=ROOT,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"{cmd}: {r.stderr[-800:]}"
        have = np.asarray(Image.open(ROOT / picture).convert("RGB"), np.int16)
        now = np.asarray(Image.open(out).convert("RGB"), np.int16)
        assert have.shape == now.shape, (cmd, have.shape, now.shape)
        differ = float((np.abs(have - now).max(-1) > 2).mean())
        assert differ <= GALLERY_TOLERANCE, f"{picture} is stale ({differ:.1%}): run {cmd}"
