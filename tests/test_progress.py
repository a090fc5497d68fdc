"""Progress bars: on stderr for long work when enabled (a terminal, or forced), silent when
stderr is not a terminal or under --quiet."""

from __future__ import annotations

import pytest

from eyelab.blur import compute_blur_field
from eyelab.core import progress
from eyelab.optics.eye.thin import Eye


@pytest.fixture
def shown(monkeypatch):
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    progress.set_enabled(True)
    yield
    progress.set_enabled(None)


def test_a_blur_field_and_a_stability_run_show_bars(shown, capsys):
    compute_blur_field(Eye(), None, shape=(8, 4, 4))
    err = capsys.readouterr().err
    assert "blur field 8x4x4" in err and "column" in err
    from eyelab.bench.stability import run_stability_bench

    run_stability_bench(cases=100, field_configs=1, reference_configs=0)
    assert "stability" in capsys.readouterr().err


def test_silent_when_not_a_terminal_or_quiet(capsys, monkeypatch, tmp_path):
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    progress.set_enabled(None)               # pytest's stderr is not a terminal
    compute_blur_field(Eye(), None, shape=(8, 4, 4))
    assert capsys.readouterr().err == ""
    from eyelab.apps.cli import main

    argv = ["render", "--width", "64", "--height", "48", "--samples", "1", "--no-cache",
            "-o", str(tmp_path / "r.png")]
    try:
        progress.set_enabled(True)           # as on a terminal: the bench shows its bars
        assert main(argv) == 0
        assert "blur field" in capsys.readouterr().err
        assert main([*argv, "--quiet"]) == 0
        assert capsys.readouterr().err == ""
        assert progress.enabled()            # --quiet lasts for its command only
    finally:
        progress.set_enabled(None)
