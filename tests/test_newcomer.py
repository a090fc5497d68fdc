"""A newcomer's first hour, as the README gives it: a fresh clone, the install line and
the demo exactly as written, then the first spec's block as one shell script (it copies
the examples into the newcomer's folder, activates the environment and renders there),
``~`` a temporary home; the clone's ``git status`` stays what it was (slow: a new virtual
environment installs every dependency; `pytest -m slow`)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _bash_blocks():
    return [b.strip().splitlines() for b in
            re.findall(r"^```bash\n(.*?)^```", README, flags=re.S | re.M)]


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("git") is None or shutil.which("apt-get") is None
                    or os.geteuid() != 0, reason="needs git, apt-get and root (the README's "
                    "install line)")
def test_a_newcomer_installs_runs_the_demo_and_renders_their_spec(tmp_path):
    clone = tmp_path / "eyelab"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    for path in ("README.md", "examples"):              # this tree, committed or not
        src = ROOT / path
        if src.is_dir():
            shutil.rmtree(clone / path)
            shutil.copytree(src, clone / path)
        else:
            shutil.copy(src, clone / path)
    install, first = _bash_blocks()[0], _bash_blocks()[1]
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHON"))}
    env["HOME"] = str(home)
    status = ["git", "status", "--porcelain", "--untracked-files=all"]
    before = subprocess.run(status, cwd=clone, capture_output=True, text=True).stdout
    times = {}
    for line in install:
        t = time.perf_counter()
        r = subprocess.run(["bash", "-c", line], cwd=clone, env=env, capture_output=True,
                           text=True, timeout=1800)
        times[line.split()[0]] = time.perf_counter() - t       # apt-get ..., .venv/bin/...
        assert r.returncode == 0, f"{line}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
    work = home / "eyelab-work"
    assert (work / "eyelab-demo.png").stat().st_size > 0
    r = subprocess.run(["bash", "-ec", "\n".join(first)], cwd=clone, env=env,
                       capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, f"{first}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
    assert (work / "first.png").stat().st_size and (work / "naked.png").stat().st_size
    assert subprocess.run(status, cwd=clone, capture_output=True,
                          text=True).stdout == before
    size = sum(f.stat().st_size for f in (clone / ".venv").rglob("*")
               if f.is_file() and not f.is_symlink())
    record = {"units": "s for times, MB (10^6 bytes) for sizes",
              "benchmark": "newcomer", "steps_s": times,
              "venv_size_mb": size / 1e6, "summary": [
                  f"the README's install line {times[install[0].split()[0]]:.0f} s, "
                  f"eyelab demo {times[install[1].split()[0]]:.0f} s; the virtual "
                  f"environment holds {size / 1e6:.0f} MB"]}
    print(record["summary"][0])
    out = os.environ.get("EYELAB_BENCH_OUT")            # docs/bench/newcomer.json
    if out:
        Path(out).write_text(json.dumps(record, indent=1) + "\n")
