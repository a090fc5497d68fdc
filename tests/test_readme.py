"""The README and the guide stay true: the renderers' interface example runs, CI runs
exactly the README's test command, the lenslet guide's PSF figures are what its command
prints, and the long benchmarks do what the checking pages say (the README's commands and
the guide's pictures: tests/test_docs.py; its spec reference: tests/test_specdoc.py)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_docs import _parses, _run_shown, _workdir, shown_commands

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_the_interface_example_runs():
    section = (ROOT / "docs" / "guide" / "performance.md").read_text()
    section = section[section.index("## Drive a renderer yourself"):]
    code = section[section.index("```python") + len("```python"): section.index("```\n", 10)]
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    res, ref = scope["res"], scope["ref"]
    assert res.srgb.shape == ref.srgb.shape == (120, 160, 3)
    assert tuple(res.report) == tuple(ref.report)


def test_ci_runs_the_readme_test_command():
    block = README[README.index("## Tests"):]
    cmd = block[block.index("```bash\n") + 8: block.index("\n```", 10)].strip()
    ci = (ROOT / ".ci" / "run").read_text()
    assert ci.rstrip().splitlines()[-1].strip() == cmd


def _psf_figures(stem: Path) -> dict:
    """The green channel's Strehl ratio and MTF at 10 c/deg of ``eyelab psf``'s outputs
    ``stem``.json/.npy, and the share of the light within 1' of the image point (the
    grid's centre)."""
    import json

    rep = json.loads(stem.with_suffix(".json").read_text())
    green = np.load(stem.with_suffix(".npy"))[1]
    c = (green.shape[0] - 1) / 2
    y, x = np.mgrid[:green.shape[0], :green.shape[1]]
    r = np.hypot(x - c, y - c) * rep["pitch_arcmin"]
    return {"strehl": rep["channels"][1]["strehl"], "mtf10": rep["channels"][1]["mtf"]["10"],
            "within_1arcmin": float(green[r <= 1.0].sum()), "report": rep}


def test_the_lenslet_guide_quotes_its_psf_command(tmp_path):
    """docs/guide/lenslets.md's ``eyelab psf examples/dims.toml --point 1 ...``, run as
    written, and the same spec without its lenslets (the carrier alone): the page's
    Strehl ratios, light within 1', MTF at 10 c/deg, share through the lenslets, the peak
    curve's maxima (as the command prints them) and its bound beyond +1 D are theirs."""
    page = ROOT / "docs" / "guide" / "lenslets.md"
    text = " ".join(page.read_text().replace("−", "-").split())
    (cmd,) = [c for _, c in shown_commands([page]) if c.startswith("eyelab psf examples/")]
    work, home = _workdir(tmp_path), tmp_path / "home"
    home.mkdir()
    spec = (work / "examples" / "dims.toml").read_text()
    (work / "examples" / "carrier.toml").write_text(
        re.sub(r"\[lens\.lenslets\]\n.*?\n\n", "", spec, flags=re.S))
    carrier = cmd.replace("dims.toml", "carrier.toml").replace("dims-psf", "carrier-psf")
    printed = {}
    for c in (cmd, carrier):
        r = _run_shown(c, work, home)
        assert r.returncode == 0, f"{c}: {r.stderr[-800:]}"
        printed[c] = r.stdout
    lens, bare = _psf_figures(work / "dims-psf"), _psf_figures(work / "carrier-psf")
    assert bare["report"].get("lenslets") is None
    for quoted in (f"{lens['report']['lenslets']['share'] * 100:.0f} % of the light",
                   f"Strehl ratio falls from {bare['strehl']:.3f} to {lens['strehl']:.3f}",
                   f"from {bare['within_1arcmin']:.2f} to {lens['within_1arcmin']:.2f}",
                   f"10 c/deg from {bare['mtf10']:.2f} to {lens['mtf10']:.2f}"):
        assert quoted in text, quoted
    maxima = re.search(r"has maxima at (.*)", printed[cmd]).group(1)
    shown = text[text.index("prints the peak curve's maxima:"):]
    shown = shown[:shown.index(". The highest")]
    pattern = r"([-+]\d+\.\d\d) D \((\d\.\d+)\)"
    assert re.findall(pattern, shown) == re.findall(pattern, maxima), (shown, maxima)
    tf = lens["report"]["lenslets"]["through_focus"]
    beyond = max(p for v, p in zip(tf["vergence_d"], tf["peak"], strict=True) if v > 1.0)
    assert f"stays at or below {beyond:.3f}" in text


def test_the_long_benchmarks_print_a_line_per_step_off_a_terminal(capsys):
    """docs/checking/index.md: ``eyelab bench schematic`` and ``lenslets`` print a line per
    step on stderr when it is not a terminal (pytest's is not), ``--quiet`` silences them,
    and both take ``--quick``."""
    from eyelab.bench.schematic import Steps
    from eyelab.core import progress

    steps = Steps(2, "a bench")
    steps.update(1, "the first")
    steps.update(1)
    steps.close()
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and re.fullmatch(r"a bench: 1/2 \(\d+ s\) the first", err[0]), err
    assert re.fullmatch(r"a bench: 2/2 \(\d+ s\)", err[1]), err
    progress.set_enabled(False)                               # eyelab --quiet
    try:
        steps = Steps(1, "a bench")
        steps.update(1, "the first")
        steps.close()
    finally:
        progress.set_enabled(None)
    assert capsys.readouterr().err == ""
    assert _parses(["bench", "schematic", "--quick"]) and _parses(["bench", "lenslets",
                                                                   "--quick"])


@pytest.mark.slow
@pytest.mark.parametrize("what", ["schematic", "lenslets"])
def test_the_quick_long_benchmarks_show_their_steps_in_a_log(what, tmp_path):
    """``eyelab bench schematic|lenslets --quick`` with stderr a file, as in CI: a line per
    step as it finishes, the last one N/N, and a JSON that says it was quick."""
    import json

    out, log = tmp_path / "b.json", tmp_path / "err.log"
    with open(log, "w") as fh:
        r = subprocess.run([sys.executable, "-P", "-m", "eyelab.apps.cli", "bench", what,
                            "--quick", "-o", str(out)], stderr=fh, stdout=subprocess.PIPE,
                           text=True, timeout=600)
    lines = log.read_text().splitlines()
    assert r.returncode == 0, lines[-10:]
    steps = [re.fullmatch(rf"{what} bench: (\d+)/(\d+) \(\d+ s\).*", ln) for ln in lines]
    assert all(steps) and len(steps) >= 6, lines
    assert [int(m.group(1)) for m in steps] == list(range(1, len(steps) + 1))
    assert int(steps[-1].group(2)) == len(steps)
    assert json.loads(out.read_text())["quick"] is True
