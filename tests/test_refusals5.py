"""Bad input refused cleanly, fifth round: inputs that used to hang (lenslet layouts of
tens of thousands, a zero converged-reference spp), tracebacks from the bench's flags,
errors naming an internal field instead of the flag or argument typed, API arguments
checked only deep inside, and reports with float noise or NaN. Each command case: exit
status 2, one line naming what the user typed, nothing written, within 10 s."""

from __future__ import annotations

import json
import math
import os
import time

import pytest

from eyelab.apps.cli import main
from eyelab.core.errors import SpecError


def _toml(lenslets: str) -> str:
    return f'[lens]\nrx = "-3.00 DS"\n[lens.lenslets]\nadd_d = 3.5\n{lenslets}\n'


RINGS_140 = ('layout = "rings"\ndiameter_mm = 0.2\nring_diameters_mm = ['
             + ", ".join(f"{10 + 0.4 * k:.1f}" for k in range(140)) + "]")
ZEROS = ('layout = "list"\ndiameter_mm = 0.2\ncentres_mm = ['
         + ", ".join("[0, 0]" for _ in range(200_000)) + "]")
LISTED = ('layout = "list"\ndiameter_mm = 0.2\ncentres_mm = ['
          + ", ".join(f"[{-40 + 0.25 * (k % 320):.2f}, {-20 + 0.25 * (k // 320):.2f}]"
                      for k in range(41_689)) + "]")

#: (name, spec text or None, argv after the command's own, what the line must name)
CASES = [
    ("70,000 lenslets", _toml('layout = "honeycomb"\npitch_mm = 0.2\ndiameter_mm = 0.2'),
     ["analyze"], "lens.lenslets.pitch_mm"),
    ("65,000 lenslets on 140 rings", _toml(RINGS_140), ["analyze"],
     "lens.lenslets.ring_diameters_mm"),
    ("41,689 listed centres", _toml(LISTED), ["analyze"], "lens.lenslets.centres_mm"),
    ("200,000 centres at the origin", _toml(ZEROS), ["render"], "lens.lenslets.centres_mm"),
    ("psf through +10 D lenslets 5 mm across before an 8 mm pupil",
     '[eye]\npupil_diameter_mm = 8\n' + _toml('layout = "list"\ndiameter_mm = 5\n'
                                           'centres_mm = [[0, 0]]').replace("add_d = 3.5",
                                                                             "add_d = 10"),
     ["psf"], "lens.lenslets.add_d"),
    ("maps --points 0", '[eye]\nmodel = "navarro"\n',
     ["maps", "--kind", "peripheral", "--points", "0"], "--points"),
    ("maps --half-angle 90", '[eye]\nmodel = "navarro"\n',
     ["maps", "--kind", "peripheral", "--half-angle", "90"], "--half-angle"),
    ("psf --size 128", None, ["psf", "--size", "128"], "--size"),
    ("psf --pitch-arcmin 0", None, ["psf", "--pitch-arcmin", "0"], "--pitch-arcmin"),
    ("psf --point 9", None, ["psf", "--point", "9"], "--point"),
    ("bench quality --truth-spp 0", None, ["bench", "quality", "--truth-spp", "0"],
     "--truth-spp"),
    ("bench quality --truth-spp -1", None, ["bench", "quality", "--truth-spp", "-1"],
     "--truth-spp"),
    ("bench quality --reference-spp -4", None,
     ["bench", "quality", "--reference-spp", "-4"], "--reference-spp"),
    ("bench quality --size ²x²", None, ["bench", "quality", "--size", "²x²"], "--size"),
    ("bench quality --plot out.txt", None, ["bench", "quality", "--plot", "out.txt"],
     "--plot"),
    ("bench quality --plot ''", None, ["bench", "quality", "--plot", ""], "--plot"),
    ("bench lenslets -o ''", None, ["bench", "lenslets", "-o", ""], "--output"),
    ("bench schematic -o ''", None, ["bench", "schematic", "-o", ""], "--output"),
    ("bench memory --only bogus", None, ["bench", "memory", "--only", "bogus"], "--only"),
]


def _run(argv, tmp_path, capsys):
    t0 = time.perf_counter()
    try:
        rc = main(argv)
    except SystemExit as e:                    # argparse's own errors
        rc = e.code
    return rc, capsys.readouterr().err.strip(), time.perf_counter() - t0


@pytest.mark.parametrize("name, spec, argv, named", CASES, ids=[c[0] for c in CASES])
def test_each_case_is_one_line_naming_what_was_typed(tmp_path, capsys, monkeypatch, name,
                                                     spec, argv, named):
    monkeypatch.chdir(tmp_path)
    extra = []
    if spec is not None:
        (tmp_path / "s.toml").write_text(spec)
        extra = ["s.toml"]
    if argv[0] in ("maps", "render"):
        extra += ["-o", "out.png"]
    elif argv[0] in ("analyze",):
        extra += ["-o", "out.json"]
    elif argv[0] == "psf":
        extra += ["-o", "out.npy"]
    before = set(os.listdir(tmp_path))
    rc, err, seconds = _run([argv[0], *extra, *argv[1:]] if argv[0] != "bench"
                            else argv, tmp_path, capsys)
    assert rc == 2 and len(err.splitlines()) == 1, (rc, err)
    assert f"error: {named}" in err or f"argument {named}" in err, err
    assert set(os.listdir(tmp_path)) == before
    assert seconds < 10, f"{name}: {seconds:.1f} s"


@pytest.mark.parametrize("content, says", [
    ([1, 2], "a JSON list"), ({}, "benchmark is None"),
    ({"benchmark": "psf", "summary": []}, "'psf'"),
    ({"benchmark": "quality", "preset": "quick", "size": [160, 120], "reference_spp": [1],
      "cases": 5}, "cases must be a list"),
    ({"benchmark": "quality", "preset": "quick", "size": [160, 120], "reference_spp": [1],
      "cases": [{"a": 1}]}, "not a quality benchmark's row"),
])
def test_a_merge_of_what_is_not_a_quality_run_is_one_line(tmp_path, capsys, monkeypatch,
                                                          content, says):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "part.json").write_text(json.dumps(content))
    rc, err, _ = _run(["bench", "quality", "--merge", "part.json", "-o", "m.json"], tmp_path,
                      capsys)
    assert rc == 2 and len(err.splitlines()) == 1 and "--merge" in err and says in err, err
    assert not (tmp_path / "m.json").exists()


def test_the_lenslet_bound_is_the_layouts_count():
    """A layout at the bound is laid; one lenslet more is refused, naming the count."""
    from eyelab.optics.lens.lenslets import MAX_LENSLETS, check_count

    check_count(MAX_LENSLETS, "k", "")
    with pytest.raises(SpecError, match=f"{MAX_LENSLETS + 1:,} lenslets"):
        check_count(MAX_LENSLETS + 1, "k", "")


def test_a_reference_spp_beyond_the_work_bound_is_refused_up_front():
    from eyelab.bench.quality import MAX_IMAGE_RAYS, _preset

    assert _preset(False, None, 4096, None)[4] == 4096            # the full preset: allowed
    with pytest.raises(SpecError, match="--truth-spp") as e:
        _preset(False, None, 8192, None)
    assert f"{MAX_IMAGE_RAYS:.3g}" in e.value.message


@pytest.mark.parametrize("call, kind, named", [
    (lambda e: e.render(None, renderer="nosuch"), SpecError, "render.renderer"),
    (lambda e: e.Session(max_renderers="2"), TypeError, "max_renderers"),
    (lambda e: e.Session(max_renderers=None), TypeError, "max_renderers"),
    (lambda e: e.Session(max_renderers=1.5), TypeError, "max_renderers"),
    (lambda e: e.Session(max_renderers=0), SpecError, "max_renderers"),
    (lambda e: e.Eye.from_rx(5), TypeError, "rx"),
    (lambda e: e.builtin_scene("chart", distance_m=-1), SpecError, "distance_m"),
    (lambda e: e.builtin_scene("page", distance_m="1"), TypeError, "distance_m"),
    (lambda e: e.psf(None, point="0"), TypeError, "point"),
    (lambda e: e.psf(None, point=1.5), TypeError, "point"),
    (lambda e: e.psf(None, size="129"), TypeError, "size"),
    (lambda e: e.psf(None, size=128), SpecError, "size"),
    (lambda e: e.psf(None, pitch_arcmin="0.25"), TypeError, "pitch_arcmin"),
])
def test_api_arguments_are_checked_where_they_are_given(call, kind, named):
    import eyelab

    with pytest.raises(kind) as e:
        call(eyelab)
    assert type(e.value) is kind and str(e.value).startswith(named), str(e.value)


def test_dir_shows_the_public_api_only():
    import eyelab

    names = [n for n in dir(eyelab) if not n.startswith("__")]
    assert set(names) == set(eyelab.__all__) - {"__version__"}
    for n in ("annotations", "functools", "importlib", "sys", "types"):
        assert n not in dir(eyelab)


def test_a_bad_spec_is_named_before_a_missing_display(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    spec = tmp_path / "bad.toml"
    spec.write_text("[eye]\npupil_diameter_mm = 99\n")
    rc, err, _ = _run(["inspect", str(spec)], tmp_path, capsys)
    assert rc == 2 and "eye.pupil_diameter_mm" in err and "display" not in err, err


def test_a_lenslet_surface_is_sampled_finely_enough(tmp_path, capsys):
    """eyelab surface of a lenslet lens: by default 8 samples across each lenslet, and a
    coarser --spacing-mm refused naming it."""
    from eyelab.spec.lensletkeys import DIMS_LIKE

    spec = tmp_path / "dims.toml"
    spec.write_text('[lens]\nrx = "-3.00 DS"\n[lens.lenslets]\n' + "\n".join(
        f"{k} = {json.dumps(v)}" for k, v in DIMS_LIKE.items()) + "\n")
    out = tmp_path / "f.npy"
    assert main(["surface", str(spec), "--side", "front", "-o", str(out),
                 "--spacing-mm", "0.5"]) == 2
    assert "--spacing-mm" in capsys.readouterr().err and not out.exists()
    assert main(["surface", str(spec), "--side", "front", "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "396 lenslets of 1.03 mm, 8.0 samples across each" in said and "0.128 mm" in said


def test_a_power_row_has_no_float_noise_and_no_axis_without_a_cylinder():
    """examples/first.toml's lens corrects the eye: its power error is 0, not 8.9e-16 D
    with an axis of 45 deg; a field given in polar angles echoes 30, not
    29.999999999999996."""
    import eyelab
    from eyelab.optics.eye.prescription import power_row

    assert power_row(8.881784197001252e-16, -3.7e-32, 45.0, 8.9e-16) == {
        "sphere_d": 0.0, "cylinder_d": 0.0, "axis_tabo_deg": None, "mean_d": 0.0}
    row = power_row(-0.12345, -0.5004, 179.96, -0.3737)
    assert row == {"sphere_d": -0.123, "cylinder_d": -0.5, "axis_tabo_deg": 180.0,
                   "mean_d": -0.374}
    rep = eyelab.analyze({"eye": {"rx": "-2.50 -0.75 x 90"}, "lens": {},
                          "points": [{"field_polar_deg": [30.0, 90.0]}]})
    p = rep["points"][0]
    assert p["object"]["field_deg"][1] == 30.0 and p["object"]["field_polar_deg"][0] == 30.0
    assert p["power_error"]["axis_tabo_deg"] is None or p["power_error"]["cylinder_d"] != 0


def _strict(text):
    def refuse(name):
        raise ValueError(f"not JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def test_json_text_is_strict():
    import numpy as np

    from eyelab.core.fileio import json_text
    obj = {"a": math.nan, "b": [math.inf, -math.inf, 1.0], "c": np.array([np.nan, 2.0]),
           "d": np.float32("nan"), "e": (1, math.nan)}
    assert _strict(json_text(obj)) == {"a": None, "b": [None, None, 1.0], "c": [None, 2.0],
                                       "d": None, "e": [1, None]}


def test_every_json_eyelab_writes_reads_with_a_strict_parser(tmp_path, capsys, monkeypatch):
    """analyze, as-worn maps (NaN beyond the lens's edge), peripheral maps, psf, render and
    demo reports: no NaN or Infinity where a strict reader stops."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "n.toml").write_text('[eye]\nmodel = "navarro"\nrx = "-2.00"\n'
                                     '[lens]\nrx = "-2.00"\n')
    (tmp_path / "p.toml").write_text('[lens]\nrx = "-6.00 DS add +2.00"\n'
                                     'design = "progressive"\ndiameter_mm = 40\n')
    runs = [["analyze", "-o", "a.json"],
            ["maps", "p.toml", "-o", "m.png", "--json", "m.json", "--points", "9",
             "--half-angle", "45"],
            ["maps", "n.toml", "-o", "pm.png", "--json", "pm.json", "--points", "5"],
            ["psf", "-o", "p.npy", "--json", "p.json", "--size", "33"],
            ["render", "-o", "r.png", "--report", "r.json", "--width", "32", "--height", "24",
             "--samples", "1", "--quiet"]]
    for argv in runs:
        assert main(argv) == 0, (argv, capsys.readouterr().err)
    written = sorted(tmp_path.glob("*.json"))
    assert {p.name for p in written} >= {"a.json", "m.json", "pm.json", "p.json", "r.json"}
    for p in written:
        _strict(p.read_text())


def test_an_unreachable_display_is_one_line(tmp_path, capsys, monkeypatch):
    """DISPLAY set with no X server behind it: eyelab's line, exit 2, before VTK opens
    anything (it would print its own warnings and exit 0)."""
    from eyelab.render import display_error

    monkeypatch.setenv("DISPLAY", ":55")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert display_error() == "cannot open display :55"
    rc, err, _ = _run(["inspect"], tmp_path, capsys)
    assert rc == 2 and err.splitlines() == [
        "eyelab: error: inspect: cannot open display :55; use --screenshot FILE or "
        "--offscreen, or run under xvfb-run"], err
