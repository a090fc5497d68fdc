"""Memory estimates checked before any work: the estimate bounds the measured peak, a
spec over the limit is refused naming its largest part, and the limit can be set."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from eyelab.apps.cli import main
from eyelab.imaging.memory import GIB, estimate_memory, memory_limit
from eyelab.spec import parse_spec

MEASURE = """
import json, os, sys
os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkOSOpenGLRenderWindow"
from eyelab.jobs.render import render_spec
from eyelab.spec import parse_spec
spec = parse_spec(json.loads(sys.argv[1]))
render_spec(spec)
# VmHWM: this program's own peak (ru_maxrss keeps the forking parent's across exec)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
print(int(hwm.split()[1]) * 1024)
"""


@pytest.mark.parametrize("render", [
    {"width": 512, "height": 384, "samples": 2, "field_shape": [64, 32, 32]},
    {"width": 256, "height": 192, "samples": 2, "field_shape": [96, 64, 64]},
    {"renderer": "reference", "width": 64, "height": 48, "samples": 16, "workers": 2},
])
def test_the_estimate_bounds_the_measured_peak(render):
    data = {"eye": {"rx": "-3.00 -1.00 x 30"}, "lens": {}, "render": render}
    rs = parse_spec(data).render
    est = estimate_memory(rs.renderer, rs.view, rs.quality)["total"]
    out = subprocess.run([sys.executable, "-P", "-c", MEASURE, json.dumps(data)],
                         capture_output=True, text=True, timeout=300, check=True)
    peak = float(out.stdout.split()[-1])
    assert peak <= est <= 2.5 * peak, (peak / GIB, est / GIB)


def test_over_the_limit_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "o.png"
    assert main(["render", "-o", str(out), "--width", "2048", "--height", "2048",
                 "--max-memory", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("eyelab: error: render.width:") and "limit is 1.0 GiB" in err
    assert not out.exists()
    spec = tmp_path / "s.toml"
    spec.write_text("[render]\nfield_shape = [512, 512, 512]\n")
    assert main(["render", str(spec), "-o", str(out)]) == 2
    assert capsys.readouterr().err.startswith("eyelab: error: render.field_shape:")
    assert not out.exists()


def test_the_flag_lasts_for_its_command_only(tmp_path, monkeypatch):
    monkeypatch.delenv("EYELAB_MAX_MEMORY_GB", raising=False)
    assert main(["render", "-o", str(tmp_path / "o.png"), "--width", "2048",
                 "--height", "2048", "--max-memory", "1"]) == 2
    assert "EYELAB_MAX_MEMORY_GB" not in os.environ
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "7")
    main(["render", "-o", str(tmp_path / "o.png"), "--width", "2048", "--height", "2048",
          "--max-memory", "1"])
    assert os.environ["EYELAB_MAX_MEMORY_GB"] == "7"


def test_the_limit_from_flag_environment_or_machine(monkeypatch):
    monkeypatch.delenv("EYELAB_MAX_MEMORY_GB", raising=False)
    assert memory_limit(3) == 3 * GIB
    half = memory_limit()
    assert half > 0
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "0.5")
    assert memory_limit() == 0.5 * GIB
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "lots")
    with pytest.raises(ValueError, match="EYELAB_MAX_MEMORY_GB"):
        memory_limit()
