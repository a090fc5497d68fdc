"""Bad input refused cleanly, fourth round: each case is one line naming the field and what
it takes, exit status 2, nothing written — inputs that used to hang (a FIFO), run without
end (/dev/zero), pass with an impossible value, or be blamed on the wrong field."""

from __future__ import annotations

import json
import os
import threading

import pytest

from eyelab.apps.cli import main
from eyelab.core.errors import SpecError
from eyelab.spec import parse_spec

ABERR = {"eye": {"aberrations": {"coefficients_um": [0, 0, 0, 0, 0, 0, 0, 0.1],
                                 "pupil_mm": 6.0}}}


def _parse_within(data, source, seconds=20.0):
    """parse_spec on a thread, failing (instead of hanging the suite) after ``seconds``."""
    out = {}

    def run():
        try:
            out["spec"] = parse_spec(data, source)
        except Exception as e:          # noqa: BLE001 - handed to the test below
            out["error"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), "parsing hung"
    return out


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("table", ["frame", "aberrations"])
def test_a_fifo_or_a_device_is_refused_without_reading(tmp_path, table):
    """A FIFO would block the read forever, /dev/zero never end it: both are refused before
    anything is opened, naming the key."""
    fifo = tmp_path / "job.oma"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.oma"
    zero.symlink_to("/dev/zero")
    for path in (fifo, zero):
        if table == "frame":
            data, field = {"frame": {"file": str(path)}}, "frame.file"
        else:
            data = {"eye": {"aberrations": {"file": str(path), "pupil_mm": 6.0}}}
            field = "eye.aberrations.file"
        out = _parse_within(data, str(tmp_path / "x.toml"))
        assert isinstance(out.get("error"), SpecError), out
        assert out["error"].field == field and "not a regular file" in out["error"].message


def test_zernike_coefficients_have_the_aberrometers_range(tmp_path):
    """A coefficient beyond +-100 um (what a clinical aberrometer reports) is a typing or
    unit error: refused naming the key, in the list, the table and the file alike."""
    from eyelab.spec.aberrationkeys import ABERRATION_LIMITS

    lo, hi = ABERRATION_LIMITS["eye.aberrations.coefficients_um"]
    for big in (1e6, 1e300, -101.0):
        data = json.loads(json.dumps(ABERR))
        data["eye"]["aberrations"]["coefficients_um"][7] = big
        with pytest.raises(SpecError, match=r"\[-100, 100\]") as e:
            parse_spec(data, "<dict>")
        assert e.value.field == "eye.aberrations.coefficients_um"
    data = {"eye": {"aberrations": {"coefficients_um": {"Z3_-1": 1e6}, "pupil_mm": 6.0}}}
    with pytest.raises(SpecError, match="coefficients_um"):
        parse_spec(data, "<dict>")
    f = tmp_path / "z.csv"
    f.write_text("0 0 0 0 0 0 0 5e5\n")
    data = {"eye": {"aberrations": {"file": str(f), "pupil_mm": 6.0}}}
    with pytest.raises(SpecError) as e:
        parse_spec(data, "<dict>")
    assert e.value.field == "eye.aberrations.file" and str(int(hi)) in e.value.message
    data = json.loads(json.dumps(ABERR))
    data["eye"]["aberrations"]["coefficients_um"][7] = lo   # the range's edge is accepted
    assert parse_spec(data, "<dict>").eye.aberrations is not None


def test_a_coefficient_files_path_is_named_as_such():
    with pytest.raises(SpecError, match="coefficient file's path") as e:
        parse_spec({"eye": {"aberrations": {"file": 5, "pupil_mm": 6.0}}}, "<dict>")
    assert "points" not in e.value.message


@pytest.mark.parametrize("shape, box", [("oval", [80, 80]), ("aviator", [40, 10]),
                                        ("rectangle", [10, 10])])
def test_a_shapes_box_at_its_limits_is_the_box_asked_for(shape, box):
    """frame.box_mm at the documented limits [10, 80] is the box asked for, not refused by
    the outline's rounding (80.00000000000001, 9.99991): the frame is made; what can
    still refuse it is the lens it must hold (an 80 mm oval needs a 116 mm blank)."""
    from eyelab.optics.lens.frame import Frame, shape_outline

    right = shape_outline(shape, box[0] * 1e-3, box[1] * 1e-3)
    frame = Frame({"right": right, "left": right.mirrored()}, 0.018)
    assert frame.box("right") == pytest.approx((box[0] * 1e-3, box[1] * 1e-3), abs=1e-6)
    try:
        parse_spec({"lens": {"rx": "-2.00 DS"},
                    "frame": {"shape": shape, "box_mm": box, "dbl_mm": 18,
                              "monocular_pd_mm": box[0] / 2 + 9}}, "<dict>")
    except SpecError as e:
        assert not e.field.startswith("frame.box_mm"), e


def test_psf_of_two_eyes_names_the_binocular_table(tmp_path, capsys):
    spec = tmp_path / "two.toml"
    spec.write_text('[eye.right]\nrx = "-2.00 DS"\n[eye.left]\nrx = "-2.50 DS"\n')
    assert main(["psf", str(spec), "-o", str(tmp_path / "p.npy")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "binocular" in err and "--eye right|left" in err
    assert main(["psf", str(spec), "--eye", "left", "-o", str(tmp_path / "p.npy")]) == 0


def test_empty_output_paths_are_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["analyze", "-o", ""]) == 2
    assert "--output" in capsys.readouterr().err
    assert main(["maps", "--json", "", "-o", str(tmp_path / "m.png")]) == 2
    assert "--json" in capsys.readouterr().err
    assert not (tmp_path / "m.png").exists()


def test_a_sides_lens_without_its_back_names_the_side():
    data = {"eye": {"right": {"rx": "-2.00 DS"}, "left": {"rx": "-2.00 DS"}},
            "lens": {"left": {"front": {"type": "sphere", "radius_mm": 500.0},
                              "center_thickness_mm": 2.0}}}
    with pytest.raises(SpecError) as e:
        parse_spec(data, "<dict>")
    assert e.value.field == "lens.left.back"


@pytest.mark.parametrize("key", ["eye.middle.rx", "eye.Right.rx", "lens.centre.material"])
def test_a_sweep_over_a_table_that_does_not_exist_is_the_sweeps(tmp_path, capsys, key):
    job = tmp_path / "job.toml"
    job.write_text(f'[output]\ndir = "out"\n[sweep]\n"{key}" = ["-1.00 DS", "-2.00 DS"]\n')
    assert main(["batch", str(job)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f'jobspec.sweep."{key}"' in err, err
    assert not (tmp_path / "out").exists()


def test_mesh_flags_are_checked_before_the_display(tmp_path, capsys, monkeypatch):
    """Without a display, a bad --mesh-* value is named before "no display" is said."""
    import trimesh

    stl = tmp_path / "box.stl"
    trimesh.creation.box(extents=(0.25, 0.25, 0.25)).export(stl)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["inspect", "--mesh", str(stl), "--mesh-scale", "-2"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--mesh-scale" in err and "display" not in err


def test_a_large_npy_is_named_once(tmp_path):
    """A points .npy over the size limit: one message, the key named once."""
    from eyelab.optics.lens.dcs import MAX_BYTES
    from eyelab.optics.lens.pointsfile import read_points

    big = tmp_path / "big.npy"
    with open(big, "wb") as f:
        f.truncate(MAX_BYTES + 1)
    with pytest.raises(SpecError) as e:
        read_points(big, "lens.front.file", spacing_mm=1.0)
    assert e.value.field == "lens.front.file"
    assert "lens.front.file" not in e.value.message and "bytes" in e.value.message


def test_negative_numbers_in_scientific_notation_are_numbers():
    from eyelab.apps.cli import _build_parser

    args = _build_parser().parse_args(["inspect", "--mesh", "m.stl", "--mesh-position", "0",
                                       "0", "-1e0"])
    assert args.mesh_position == [0.0, 0.0, -1.0]
    assert _build_parser().parse_args(["render", "--gaze", "-1.5E1", "-2"]).gaze == [-15.0,
                                                                                    -2.0]


def test_a_benchmark_whose_checks_fail_exits_1(tmp_path, capsys, monkeypatch):
    """The measurement is written and printed; its failed checks are named on one line of
    stderr and the exit status is 1 (2 stays bad input)."""
    import eyelab.apps.bench as bench

    monkeypatch.setitem(bench._BENCH_RUNS, "design", lambda args: {
        "benchmark": "design", "summary": ["soft: checks FAIL: peak_cylinder"],
        "failed_checks": ["soft: peak_cylinder"]})
    out = tmp_path / "d.json"
    assert main(["bench", "design", "-o", str(out)]) == 1
    assert json.loads(out.read_text())["failed_checks"] == ["soft: peak_cylinder"]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["eyelab: bench design: checks failed: soft: peak_cylinder"]


def test_the_naked_wave_modes_sharp_passes_are_not_reported_as_a_zero_blur():
    """An aberrated naked eye is drawn sharp and spread by the wave PSF after: its report
    says so instead of "blur field all zero" (which read as if its blur were lost)."""
    import eyelab
    from eyelab.imaging.eyepsf import WAVE_SHARP_NOTE

    res = eyelab.render({"eye": {"rx": "-0.50 DS", **ABERR["eye"]}}, no_lens=True,
                        scene="chart", width=64, height=48, samples=2)
    assert WAVE_SHARP_NOTE in res.report["skipped"]
    assert not any("blur field all zero" in s for s in res.report["skipped"])


def test_an_aberrometers_refraction_is_the_eyes_rx():
    """With [eye.aberrations] giving the refraction (its second order), eye.vertex_distance_mm
    moves that Rx to the spectacle plane (no longer refused), and a [lens] without rx is
    made for it, as for eye.rx (one eye and each of two)."""
    ab = {"coefficients_um": [0, 0, 0, 0, -1.2, 0, 0, 0.1], "pupil_mm": 6.0}
    near = parse_spec({"eye": {"aberrations": ab, "vertex_distance_mm": 10.0}}, "<dict>")
    far = parse_spec({"eye": {"aberrations": ab, "vertex_distance_mm": 20.0}}, "<dict>")
    assert near.eye.power_min == pytest.approx(far.eye.power_min, abs=1e-9)  # one eye
    s = parse_spec({"eye": {"aberrations": ab}, "lens": {"material": "cr39"}}, "<dict>")
    written = parse_spec({"eye": {"rx": s.lens.rx.format()}}, "<dict>")
    assert s.lens.rx.sphere > 0 and s.eye.power_min == pytest.approx(
        written.eye.power_min, abs=0.01)
    two = parse_spec({"eye": {"right": {"aberrations": ab}, "left": {"rx": "-1.00 DS"}},
                      "lens": {"material": "cr39"}}, "<dict>")
    assert two.binocular.lens("right").rx.format() == s.lens.rx.format()


@pytest.mark.parametrize("surface,field", [
    ({"type": "points", "file": "plano.csv", "spacing_mm": 2.0, "radius_mm": 90.0},
     "lens.front.radius_mm"),
    ({"type": "sphere", "radius_mm": 100.0, "file": "plano.csv"}, "lens.front.file"),
    ({"type": "sphere", "radius_mm": 100.0, "spacing_mm": 2.0}, "lens.front.spacing_mm"),
    ({"type": "plane", "curvature": 5.0}, "lens.front.curvature"),
    ({"type": "plane", "conic": -1.0}, "lens.front.conic"),
    ({"type": "toric", "radius_x_mm": 80.0, "radius_y_mm": 70.0, "conic": 0.5},
     "lens.front.conic"),
    ({"type": "asphere", "radius_mm": 100.0, "axis_deg": 30.0}, "lens.front.axis_deg"),
])
def test_a_surface_refuses_the_keys_of_another_type(surface, field, tmp_path):
    """Nothing is ignored silently: a key that the surface's type does not read is
    refused by name, with the keys that type reads."""
    from eyelab.spec.surfacefile import SAMPLE

    surface = {k: (SAMPLE if v == "plano.csv" else v) for k, v in surface.items()}
    data = {"lens": {"front": surface, "back": {"type": "plane"}, "center_thickness_mm": 2.0}}
    with pytest.raises(SpecError) as e:
        parse_spec(data)
    assert e.value.field == field and "not read by a type =" in str(e.value), str(e.value)


def test_an_outputs_missing_folders_are_created_only_when_it_is_written(tmp_path, capsys):
    """The documented rule: -o under folders that do not exist makes them, with the output;
    a refused spec makes none of them (the check before any work creates nothing)."""
    out = tmp_path / "new" / "deeper" / "view.png"
    assert main(["render", "-o", str(out), "--width", "32", "--height", "24",
                 "--samples", "1", "--quiet"]) == 0
    assert out.stat().st_size > 0
    bad = tmp_path / "other" / "view.png"
    assert main(["render", "-o", str(bad), "--width", "0"]) == 2
    assert not (tmp_path / "other").exists()
    assert "render.width" in capsys.readouterr().err
