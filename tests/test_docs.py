"""Docs are code: the README is a short front door whose commands and Python run as
written, the guide's specs parse, the generated references are current, the example files
are what the pages show, and the documentation site builds with warnings as errors."""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
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
    (ROOT / "docs" / "reference").glob("*.md")) + sorted(
    (ROOT / "docs" / "checking").glob("*.md")) + [
    p for p in [ROOT / "docs" / "getting-started.md"] if p.exists()]

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


#: The pages whose commands a reader runs: the README, Getting started, the guide and the
#: checking pages (their benchmark commands).
SHOWN_IN = [ROOT / "README.md"] + [
    p for p in [ROOT / "docs" / "getting-started.md"] if p.exists()] + sorted(
    (ROOT / "docs" / "guide").glob("*.md")) + sorted(
    (ROOT / "docs" / "checking").glob("*.md"))
_FENCE = re.compile(r"^```(\w*)\n(.*?)^```", flags=re.S | re.M)
#: A placeholder for the reader to fill in (SPEC, FILE, R U), or a choice or an option
#: of a synopsis ([--json FILE], front|back, ...).
_PLACEHOLDER = re.compile(r"\b[A-Z][A-Z0-9_]*\b|[\[\]|]|\.\.\.")


def shown_commands(pages=SHOWN_IN) -> list:
    """(page, command) for every command that runs eyelab which the pages show: ``eyelab
    ...`` (the README's ``.venv/bin/eyelab ...`` too) or ``python -m eyelab....``, a line
    of a ``bash`` block (``\\`` continuations joined) or a code span of the prose (across
    its line breaks), each once per page."""
    out = []
    for page in pages:
        text = page.read_text()
        found = []
        for lang, body in _FENCE.findall(text):
            if lang in ("bash", "sh", "shell", "console"):
                found += [ln.strip() for ln in re.sub(r"\\\n\s*", " ", body).splitlines()]
        found += [" ".join(c.split()) for c in re.findall(r"`([^`]+)`", _FENCE.sub("", text))]
        for cmd in found:
            cmd = re.sub(r"^\.venv/bin/eyelab ", "eyelab ", cmd)
            if cmd.startswith(("eyelab ", "python -m eyelab.")) and (page, cmd) not in out:
                out.append((page, cmd))
    return out


def _parses(args: list) -> bool:
    from eyelab.apps.cli import _build_parser

    try:
        with contextlib.redirect_stderr(io.StringIO()):
            _build_parser().parse_args(args)
    except SystemExit:
        return False
    return True


def runnable(cmd: str) -> list | None:
    """The arguments after ``eyelab`` (or ``python``) of a shown command that runs as
    written, or None. The rule: a command runs unless it holds a placeholder
    (:data:`_PLACEHOLDER`), is the window (``inspect``), a benchmark (``bench``: minutes to
    hours; their own tests run them, and the fast test below checks what they write) or a
    generated page's own generator (``--write``), or is a mention: the command's name and
    flags alone, which its parser refuses as written (``eyelab render --report`` names
    the flag). Install, test and build lines are not eyelab commands."""
    if _PLACEHOLDER.search(cmd):
        return None
    argv = shlex.split(cmd, comments=True)
    if argv[0] == "python":
        return None if "--write" in argv else argv[1:]
    if argv[1] in ("inspect", "bench"):
        return None
    if all(a.startswith("-") for a in argv[2:]) and not _parses(argv[1:]):
        return None
    return argv[1:]


def readme_commands() -> list:
    """Every command of the README that runs as written (:func:`runnable`)."""
    return [c for _, c in shown_commands([ROOT / "README.md"]) if runnable(c) is not None]


def _run_shown(cmd: str, work: Path, home: Path, timeout=600):
    """``cmd`` run as written in ``work`` (``~`` is ``home``), by this interpreter."""
    args = [home.as_posix() + a[1:] if a.startswith("~/") else a for a in runnable(cmd)]
    if cmd.startswith("eyelab "):
        args = ["-m", "eyelab.apps.cli", *args]
    env = dict(os.environ, COLUMNS="100", HOME=str(home))
    return subprocess.run([sys.executable, "-P", *args], cwd=work, env=env,
                          capture_output=True, text=True, timeout=timeout)


def _git_status():
    """The checkout's ``git status`` (untracked files each named), or None without git."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        return None
    r = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                       capture_output=True, text=True)
    return r.stdout if r.returncode == 0 else None


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
    """The README's commands run as written in a folder of the reader's (the README's
    ``~/eyelab-work``, with ``~`` a temporary home), and the checkout stays as it was."""
    work, home = _workdir(tmp_path), tmp_path / "home"
    home.mkdir()
    cmds = readme_commands()
    assert {c.split()[1] for c in cmds} >= {"render", "analyze", "maps", "surface", "psf",
                                            "batch", "demo"}, cmds
    before = _git_status()
    for cmd in cmds:
        r = _run_shown(cmd, work, home, timeout=300)
        assert r.returncode == 0, f"{cmd}: {r.stdout[-800:]}{r.stderr[-800:]}"
    assert (work / "first.png").stat().st_size and (work / "first.json").exists()
    assert (work / "batch-out" / "summary.csv").exists()
    assert (home / "eyelab-work" / "eyelab-demo.png").stat().st_size
    assert _git_status() == before


@pytest.mark.slow
def test_every_shown_command_runs_and_leaves_the_checkout_as_it_was(tmp_path):
    """Every command the README and the guide show that runs as written (:func:`runnable`:
    no placeholder, not the window, not a benchmark, not a page's own generator, not a
    bare mention of a flag) runs in a folder holding what they read (:func:`_workdir`),
    ``~`` a temporary home, and exits 0; the checkout's ``git status`` is what it was."""
    work, home = _workdir(tmp_path), tmp_path / "home"
    home.mkdir()
    cmds = list(dict.fromkeys(c for _, c in shown_commands() if runnable(c) is not None))
    assert len(cmds) >= 30, cmds
    before = _git_status()
    failed = []
    for cmd in cmds:
        r = _run_shown(cmd, work, home)
        if r.returncode:
            failed.append(f"{cmd}: {r.stderr.strip()[-400:]}")
    assert not failed, "\n".join(failed)
    assert _git_status() == before


def _written(cmd: str, page: Path) -> list:
    """The paths a shown command writes, as it names them: its output flags' values (not
    placeholders), else the default its parser or benchmark gives (``eyelab-render.png``,
    ``bench-WHAT.json``), ``demo``'s JSON beside its picture, and a generator module's
    output folder; a generated page's own generator (``--write`` that page) writes
    nothing else."""
    from eyelab.apps.cli import _build_parser

    argv = [a.strip("[]") for a in shlex.split(cmd, comments=True)]
    flags = ("-o", "--output", "--report", "--json", "--plot", "--screenshot",
             "--truth-cache", "--write")
    out = [v for f, v in zip(argv, argv[1:], strict=False)
           if f in flags and not v.startswith("-")]
    if argv[0] == "python":
        out = out or [a for a in argv[3:] if not a.startswith("-")][:1]
        out = [p for p in out if (ROOT / p).resolve() != page.resolve()]
    elif not {"-o", "--output"} & set(argv):
        sub = argv[1]
        if sub == "bench" and len(argv) > 2:
            out.append(f"bench-{argv[2]}.json")
        else:
            choices = next(a for a in _build_parser()._actions
                           if isinstance(a, argparse._SubParsersAction)).choices
            d = choices[sub].get_default("output") if sub in choices else None
            out += [d] if isinstance(d, str) and "--help" not in argv else []
    if argv[1] == "demo":
        out += [str(Path(p).with_suffix(".json")) for p in out if p.endswith(".png")]
    return [p for p in out if not _PLACEHOLDER.search(p)]


@pytest.mark.skipif(_git_status() is None, reason="needs git and a checkout")
def test_no_shown_command_writes_into_the_checkout():
    """No command the README or the guide shows (:func:`shown_commands`, benchmarks and
    synopses included) writes into the repository where a reader who ran it in the clone
    would find it: every path it writes (:func:`_written`) lies outside the clone (``~``,
    an absolute path) or is a bare name in the current folder — none inside ``docs/``,
    ``examples/`` or another folder — that is not a tracked file, and (the second line of
    defence, for a reader who runs it in the clone) that .gitignore ignores. The pictures
    of docs/gallery/ are the gallery test's (:func:`test_the_gallery_pictures_are_what_
    their_commands_draw`), never a command's."""
    tracked = set(subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True,
                                 text=True, check=True).stdout.splitlines())
    bare, bad = {}, []
    for page, cmd in shown_commands():
        for path in _written(cmd, page):
            if path.startswith("~") or Path(path).is_absolute():
                if ROOT in Path(path).expanduser().resolve().parents:
                    bad.append(f"{page.name}: {cmd}: {path} is in the checkout")
            elif path != "." and len(Path(path).parts) > 1:
                bad.append(f"{page.name}: {cmd}: writes into the repository's {path}")
            elif path in tracked:
                bad.append(f"{page.name}: {cmd}: overwrites the tracked {path}")
            elif path != ".":
                bare.setdefault(path, f"{page.name}: {cmd}")
    r = subprocess.run(["git", "check-ignore", "--stdin"], cwd=ROOT, input="\n".join(bare),
                       capture_output=True, text=True)
    ignored = set(r.stdout.split())
    bad += [f"{where}: {p} is not in .gitignore" for p, where in bare.items()
            if p not in ignored]
    assert not bad, "\n".join(bad)
    assert len(bare) >= 20, bare


def test_the_readme_python_runs(tmp_path, monkeypatch, capsys):
    """The README's Python runs in a reader's folder and prints what the README shows
    after it."""
    work = _workdir(tmp_path)
    monkeypatch.chdir(work)
    (code,) = _blocks(README, "python")
    exec(compile(code, "README.md", "exec"), {})
    assert (work / "first-api.png").stat().st_size > 0
    shown = README[README.index(code):]
    shown = shown[shown.index("```text\n") + 8:]
    assert capsys.readouterr().out == shown[:shown.index("```")]


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
    examples = sorted((ROOT / "examples" / "gallery").glob("*/plot_*.py"))
    assert len(examples) >= 15, examples
    pages += [f"gallery_examples/{p.parent.name}/{p.stem}" for p in examples]
    for page in pages:
        assert (tmp_path / "html" / f"{page}.html").exists(), page
    images = list((tmp_path / "html" / "_images").glob("sphx_glr_plot_*.png"))
    assert len(images) >= len(pages) - 7, images          # every example drew its figure
    api = (tmp_path / "html" / "reference" / "api.html").read_text()
    assert "eyelab.render" in api and "eyelab.Session" in api
    render = (tmp_path / "html" / "reference" / "generated" / "eyelab.render.html").read_text()
    assert 'id="eyelab.render"' in render and "eyelab.jobs.api.render" not in render


def test_the_corpus_size_the_guide_quotes_is_the_generators():
    sys.path.insert(0, str(ROOT / "tests"))
    import badspecs

    text = (ROOT / "docs" / "checking" / "refusals.md").read_text()
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
    """(command, picture) for every command the README and the guide show that draws a
    picture of the gallery: ``eyelab demo`` or ``render`` writing ``-o NAME.png`` into the
    current folder, where the same page shows the gallery picture of that name."""
    found = []
    for page, cmd in shown_commands():
        m = re.fullmatch(r"eyelab (?:demo|render)\s.*-o\s+([\w-]+\.png)(\s.*)?", cmd)
        if m and runnable(cmd) and f"gallery/{m.group(1)}" in page.read_text():
            if cmd not in [c for c, _ in found]:
                found.append((cmd, f"docs/gallery/{m.group(1)}"))
    return found


def test_the_gallery_pictures_are_what_their_commands_draw(tmp_path):
    """Each gallery picture a page shows beside its command is what that command, run as
    written in a reader's folder, draws now. The pictures are made here, not by the
    commands: ``EYELAB_WRITE_GALLERY=1`` writes a stale or missing one into docs/gallery/
    (then the test passes only on a second run)."""
    from PIL import Image

    found = gallery_commands()
    assert {Path(p).name for _, p in found} >= {
        "demo.png", "etdrs_demo.png", "binocular.png", "binocular_anaglyph.png",
        "first.png", "naked.png", "dims_raster.png", "myope-retina.png"}, found
    work, home = _workdir(tmp_path), tmp_path / "home"
    home.mkdir()
    stale = []
    for cmd, picture in found:
        r = _run_shown(cmd, work, home)
        assert r.returncode == 0, f"{cmd}: {r.stderr[-800:]}"
        now = np.asarray(Image.open(work / Path(picture).name).convert("RGB"), np.int16)
        have = (np.asarray(Image.open(ROOT / picture).convert("RGB"), np.int16)
                if (ROOT / picture).exists() else None)
        if have is None or have.shape != now.shape or float(
                (np.abs(have - now).max(-1) > 2).mean()) > GALLERY_TOLERANCE:
            stale.append(f"{picture} (from {cmd})")
            if os.environ.get("EYELAB_WRITE_GALLERY"):
                shutil.copy(work / Path(picture).name, ROOT / picture)
    assert not stale, f"stale or missing: {stale}; EYELAB_WRITE_GALLERY=1 writes them"

