"""Surfaces from points files and out to them (eyelab/optics/lens/pointsfile.py): ``eyelab
surface`` writes a spec lens's surfaces as a Vision Council DCS file (or .csv, .npy), and a
spec with ``type = "points"`` surfaces read from those files is the same lens — in analyze
(25 gazes within 30 deg: within 0.005 D) and in the as-worn maps and surface powers
(everywhere on the lens: within 0.01 D) — for a sphere, an oblique toric, an asphere and
the progressive design. Hand-written files in both public DCS readings are read
(tests/fixtures/paraboloid_writer.sdf, tests/fixtures/paraboloid_analyzer.sdf); every
malformed file is refused in one line naming the spec field and the problem."""

from __future__ import annotations

import dataclasses
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points, power_error
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.lens.asworn import as_worn_maps
from eyelab.optics.lens.dcs import number, parse_records
from eyelab.optics.lens.pointsfile import SAG_DECIMALS, read_points, sample_surface
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.spec import load_spec

FIXTURES = Path(__file__).resolve().parent / "fixtures"
LENSES = {
    "sphere": '[eye]\nrx = "+2.00 DS"\n[lens]\nrx = "+2.00 DS"\n',
    "toric": '[eye]\nrx = "-3.00 / -1.50 x 30"\n[lens]\nrx = "-3.00 / -1.50 x 30"\n',
    "asphere": ('[lens]\ncenter_thickness_mm = 4.0\n[lens.front]\ntype = "asphere"\n'
                'radius_mm = 90.0\nconic = -0.6\ncoefficients = [200.0]\n[lens.back]\n'
                'type = "sphere"\nradius_mm = 110.0\n'),
    "progressive": ('[eye]\nrx = "-1.00 DS"\nage = 60\n[lens]\n'
                    'rx = "-1.00 / -0.50 x 120 add +2.00"\ndesign = "progressive"\n'),
}


def _cli(argv, capsys):
    rc = main([str(a) for a in argv])
    out = capsys.readouterr()
    return rc, out.out, out.err.strip()


def _points_spec(lens, files: dict, extra: str = "", spacing=None) -> str:
    """A spec of ``lens`` (its thickness as ``eyelab surface`` prints it, rounded up to
    0.1 um) with its surfaces read from ``files``."""
    ct = math.ceil(round(lens.center_thickness * 1e7, 3)) / 1e4
    text = (f'[lens]\ncenter_thickness_mm = {ct!r}\ndiameter_mm = {lens.diameter * 1e3!r}\n'
            f'material = "{lens.material.name}"\n')
    if lens.rx is not None:
        text += f'rx = "{lens.rx.format()}"\n'
    for side, name in files.items():
        text += f'[lens.{side}]\ntype = "points"\nfile = "{name}"\n'
        text += f"spacing_mm = {spacing}\n" if spacing else ""
    return text + extra


def _round_trip(tmp: Path, name: str, ext: str, capsys):
    """(analytic spec, points spec) after writing both surfaces with ``eyelab surface``."""
    (tmp / "a.toml").write_text(LENSES[name])
    files = {}
    for side in ("front", "back"):
        rc, out, err = _cli(["surface", tmp / "a.toml", "--side", side, "-o",
                             tmp / f"{side}{ext}"], capsys)
        assert rc == 0 and not err and f"read it back as [lens.{side}]" in out, err
        files[side] = f"{side}{ext}"
    spec = load_spec(tmp / "a.toml")
    eye = LENSES[name].split("[lens]")[0]
    (tmp / "b.toml").write_text(_points_spec(spec.lens, files, eye,
                                             None if ext == ".sdf" else 0.5))
    return spec, load_spec(tmp / "b.toml")


def _with_rx(a, b):
    """Both lenses with the analytic lens's Rx (its traced powers where it has none)."""
    rx = a.rx
    if rx is None:
        f1, f2, ax = a.back_vertex_powers()
        rx = Prescription(round(f1, 6), round(f2 - f1, 6), round(math.degrees(ax)) % 180)
    return dataclasses.replace(a, rx=rx), dataclasses.replace(b, rx=rx)


def _gazes() -> np.ndarray:
    """25 gaze directions within 30 deg of straight ahead (a 5 x 5 polar pattern)."""
    u = np.linspace(-1.0, 1.0, 5)
    gx, gy = np.meshgrid(u, u)
    th = np.radians(30.0) * np.hypot(gx, gy) / math.sqrt(2)
    ph = np.arctan2(gy, gx)
    return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)],
                    -1).reshape(-1, 3)


def _compare(spec, pts) -> dict:
    """Max |difference| (D) of the analysis at 25 gazes, of the as-worn maps, and of both
    surfaces' powers over the lens."""
    a, b = _with_rx(spec.lens, pts.lens)
    eye = spec.eye
    obj = ObjectPoints.along_gazes(_gazes(), np.inf, eye.rotation_centre)
    ra, rb = (analyze_points(eye, x, obj, fixation="rotating") for x in (a, b))
    assert (ra.status == 0).all() and (rb.status == 0).all()
    ka = np.array(ra.wave_vertex_sphere.in_basis(ra.eye_x))
    kb = np.array(rb.wave_vertex_sphere.in_basis(rb.eye_x))
    ea, eb = power_error(ra, a.rx, obj), power_error(rb, a.rx, obj)
    analyze = max(np.abs(ka - kb).max(),
                  *(np.abs(ea[k] - eb[k]).max() for k in ("sphere_d", "cylinder_d", "mean_d")))
    ma, mb = (as_worn_maps(eye, x, n=11) for x in (a, b))
    assert (np.isnan(ma.mean_error_d) == np.isnan(mb.mean_error_d)).all()
    assert np.isfinite(ma.mean_error_d).all()          # every gaze through the lens
    maps = max(np.nanmax(np.abs(getattr(ma, k) - getattr(mb, k)))
               for k in ("mean_error_d", "cylinder_d", "sphere_error_d"))
    rng = np.random.default_rng(1)
    r = a.diameter / 2 * np.sqrt(rng.uniform(0, 1, 3000))
    t = rng.uniform(0, 2 * np.pi, 3000)
    x, y = r * np.cos(t), r * np.sin(t)
    n1 = a.n() - 1.0
    surface = max(n1 * np.abs(np.array(sa.principal_curvatures(x, y)[:2])
                              - np.array(sb.principal_curvatures(x, y)[:2])).max()
                  for sa, sb in ((a.front, b.front), (a.back, b.back)))
    return {"analyze": analyze, "maps": maps, "surface": surface}


@pytest.mark.parametrize("name", list(LENSES))
def test_a_lens_written_as_dcs_points_reads_back_as_the_same_lens(name, tmp_path, capsys):
    spec, pts = _round_trip(tmp_path, name, ".sdf", capsys)
    d = _compare(spec, pts)
    assert d["analyze"] < 0.005 and d["maps"] < 0.01 and d["surface"] < 0.01, d
    # the sags re-read are the numbers written, exactly
    for side in ("front", "back"):
        text = (tmp_path / f"{side}.sdf").read_text()
        rows = [r.values for r in parse_records(text, "f") if r.label == "ZZ"]
        grid = read_points(tmp_path / f"{side}.sdf", "f")
        assert [[f"{v:.{SAG_DECIMALS}f}" for v in row] for row in grid.z] == \
            [list(r) for r in rows]
        head = next(r for r in parse_records(text, "f") if r.label == "SURFMT")
        assert head.values[:3] == ("1", "R", side[0].upper())


@pytest.mark.parametrize("ext", [".csv", ".npy"])
def test_csv_and_npy_grids_read_back_as_the_same_lens(ext, tmp_path, capsys):
    spec, pts = _round_trip(tmp_path, "toric", ext, capsys)
    d = _compare(spec, pts)
    assert d["analyze"] < 0.005 and d["maps"] < 0.01 and d["surface"] < 0.01, d
    if ext == ".npy":                     # float64: the sags themselves
        assert d["analyze"] < 1e-6 and d["surface"] < 1e-6, d
    grid = sample_surface(spec.lens.back, 0.5, 64.0)
    z = read_points(tmp_path / f"back{ext}", "f", spacing_mm=0.5).z
    want = grid.z if ext == ".npy" else np.vectorize(
        lambda v: float(f"{v:.{SAG_DECIMALS}f}"))(grid.z)
    assert np.array_equal(z, want)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["sphere", "asphere", "progressive"])
@pytest.mark.parametrize("ext", [".csv", ".npy"])
def test_every_lens_in_every_format(name, ext, tmp_path, capsys):
    d = _compare(*_round_trip(tmp_path, name, ext, capsys))
    assert d["analyze"] < 0.005 and d["maps"] < 0.01 and d["surface"] < 0.01, d


def test_the_hand_written_files_in_both_readings(tmp_path, capsys):
    """The paraboloid of vertex radius 100 mm tilted 0.01 along y, written by hand in the
    writer's layout (bottom row first, extents) and in the reader's (top row first, field 1
    the spacing): the same surface, vertex curvature 10 /m, read from the spec's folder."""
    w = read_points(FIXTURES / "paraboloid_writer.sdf", "f")
    a = read_points(FIXTURES / "paraboloid_analyzer.sdf", "f", first_row="top")
    gx, gy = np.meshgrid(w.x, w.y)
    assert np.array_equal(w.x, np.arange(-6.0, 7.0, 2.0)) and np.array_equal(w.y, w.x)
    np.testing.assert_allclose(w.z, (gx ** 2 + gy ** 2) / 200 + gy / 100, atol=1e-15)
    assert np.array_equal(a.z, w.z) and np.array_equal(a.x, w.x)
    f = w.freeform()
    d = f.derivatives(np.zeros(1), np.zeros(1))
    assert d.z[0] == pytest.approx(0, abs=1e-15) and d.zy[0] == pytest.approx(0.01)
    assert d.zxx[0] == pytest.approx(10.0, rel=1e-9) and d.zyy[0] == pytest.approx(10.0)
    flipped = read_points(FIXTURES / "paraboloid_analyzer.sdf", "f").freeform()
    assert flipped.derivatives(np.zeros(1), np.zeros(1)).zy[0] == pytest.approx(-0.01)
    # in a spec: a 12 mm lens, the file beside the spec, analyze run from elsewhere
    sub = tmp_path / "job"
    sub.mkdir()
    shutil.copy(FIXTURES / "paraboloid_analyzer.sdf", sub / "front.sdf")
    (sub / "s.toml").write_text('[lens]\ncenter_thickness_mm = 2.0\ndiameter_mm = 12.0\n'
                                'rx = "+5.00 DS"\n[lens.front]\nfile = "front.sdf"\n'
                                'first_row = "top"\n[lens.back]\ntype = "plane"\n')
    lens = load_spec(sub / "s.toml").lens
    f1, f2, _ = lens.back_vertex_powers()
    n = lens.n()
    assert abs(f1 - f2) < 1e-3            # the tilt's oblique refraction at the vertex
    assert (f1 + f2) / 2 == pytest.approx((n - 1) * 10.0 / (1 - 0.002 * (n - 1) * 10.0 / n),
                                          abs=1e-3)
    rc, out, err = _cli(["analyze", sub / "s.toml"], capsys)
    assert rc == 0 and "power error vs the Rx" in out, err


def test_dcs_records_and_numbers():
    recs = parse_records("\x1cREQ=FSG\r\n\r\nSURFMT=1;R;B\r\nZZ=1;-2.5;.5;1e-3\x1e", "f")
    assert [(r.label, r.values, r.line) for r in recs] == [
        ("REQ", ("FSG",), 1), ("SURFMT", ("1", "R", "B"), 3),
        ("ZZ", ("1", "-2.5", ".5", "1e-3"), 4)]
    assert [number(v, "f", "w") for v in recs[2].values] == [1.0, -2.5, 0.5, 0.001]
    for bad, why in (("nan", "finite"), ("?", "unknown"), ("", "empty"), ("1_000", "not a "
                     "number"), ("0x10", "not a number"), ("1e999", "too large")):
        with pytest.raises(SpecError, match=why):
            number(bad, "f", "w")
    with pytest.raises(SpecError, match="line 2.*not a DCS record"):
        parse_records("JOB=1\nhello\n", "f", "x.sdf")


GOOD = (FIXTURES / "paraboloid_writer.sdf").read_bytes().decode()
SPEC = ('[lens]\ncenter_thickness_mm = 2.0\ndiameter_mm = 12.0\n[lens.front]\n'
        'type = "points"\nfile = "{file}"\n{extra}[lens.back]\ntype = "plane"\n')
ROW = "ZZ=0.18;0.08;0.02;0;0.02;0.08;0.18"
#: (name, file name, content, extra spec lines, field, what the message says)
MALFORMED = [
    ("ragged row", "s.sdf", GOOD.replace(ROW, "ZZ=0.18;0.08;0.02;0;0.02;0.08", 1), "",
     "lens.front.file", "6 values in a ZZ row"),
    ("non-numeric value", "s.sdf", GOOD.replace("0.14;0.12", "0.14;abc", 1), "",
     "lens.front.file", "'abc', not a number"),
    ("unknown value", "s.sdf", GOOD.replace("0.14;0.12", "0.14;?", 1), "",
     "lens.front.file", "unknown value"),
    ("NaN", "s.sdf", GOOD.replace("0.14;0.12", "0.14;NaN", 1), "", "lens.front.file",
     "not a finite number"),
    ("no SURFMT", "s.sdf", GOOD.replace("SURFMT=1;R;F;7;7;12;12;0\r\n", ""), "",
     "lens.front.file", "no SURFMT record"),
    ("two SURFMT", "s.sdf", GOOD + "SURFMT=1;L;F;7;7;12;12\r\n", "", "lens.front.file",
     "2 SURFMT records"),
    ("no ZZ", "s.sdf", "SURFMT=1;R;F;7;7;12;12\r\n", "", "lens.front.file",
     "no ZZ records"),
    ("ZZ before SURFMT", "s.sdf", ROW + "\r\n" + GOOD, "", "lens.front.file",
     "ZZ record before SURFMT"),
    ("wrong row count", "s.sdf", GOOD.replace(ROW + "\r\n", "", 1), "", "lens.front.file",
     "6 ZZ records of 42 values; SURFMT gives 7 x 7"),
    ("wrong counts", "s.sdf", GOOD.replace(";7;7;12;12", ";9;9;12;12"), "",
     "lens.front.file", "SURFMT gives 9 x 9"),
    ("too few fields", "s.sdf", GOOD.replace("SURFMT=1;R;F;7;7;12;12;0", "SURFMT=1;R;F"),
     "", "lens.front.file", "3 fields"),
    ("bad eye", "s.sdf", GOOD.replace("SURFMT=1;R;", "SURFMT=1;X;"), "", "lens.front.file",
     "not R or L"),
    ("back surface as the front", "s.sdf", GOOD.replace("SURFMT=1;R;F", "SURFMT=1;R;B"), "",
     "lens.front.file", "the back surface"),
    ("field 1 neither format nor spacing", "s.sdf", GOOD.replace("SURFMT=1;", "SURFMT=3;"),
     "", "lens.front.file", "neither the format type 1"),
    ("ambiguous extents", "s.sdf", GOOD.replace(";12;12;0", ";12;14;0"), "",
     "lens.front.file", "cannot be told"),
    ("grid smaller than the lens", "s.sdf", GOOD, "", "lens.front.file",
     "the 20 mm lens (diameter_mm) needs 10 mm"),
    ("fewer than 6 points", "s.csv", "0,0,0,0,0\n" * 5, "spacing_mm = 2.0\n",
     "lens.front.file", "5 values per row"),
    ("not text", "s.sdf", None, "", "lens.front.file", "not a text file"),
    ("not a record", "s.sdf", "SURFMT 1 R F\r\n", "", "lens.front.file",
     "not a DCS record"),
    ("ragged csv", "s.csv", "0,0,0,0,0,0\n" * 6 + "0,0,0\n", "spacing_mm = 2.0\n",
     "lens.front.file", "line 7: 3 values, the first row 6"),
    ("csv text", "s.csv", "0,0,0,0,0,0\n" * 5 + "0,x,0,0,0,0\n", "spacing_mm = 2.0\n",
     "lens.front.file", "line 6, value 2"),
    ("csv without spacing", "s.csv", "0,0,0,0,0,0\n" * 6, "", "lens.front.spacing_mm",
     "needs its spacing"),
    ("sdf with spacing", "s.sdf", GOOD, "spacing_mm = 2.0\n", "lens.front.spacing_mm",
     "gives its own spacing"),
    ("spacing out of range", "s.csv", "0,0,0,0,0,0\n" * 6, "spacing_mm = 20.0\n",
     "lens.front.spacing_mm", "0.05"),
    ("first_row misspelt", "s.sdf", GOOD, 'first_row = "up"\n', "lens.front.first_row",
     "'bottom', 'top'"),
    ("no file", "s.sdf", GOOD, "", "lens.front.file", "not an existing file"),
    ("wrong extension", "s.txt", GOOD, "", "lens.front.file", "a points file is .sdf"),
    ("npy NaN", "s.npy", np.full((7, 7), np.nan), "spacing_mm = 2.0\n", "lens.front.file",
     "row 1, value 1 is nan"),
    ("npy 3-D", "s.npy", np.zeros((7, 7, 2)), "spacing_mm = 2.0\n", "lens.front.file",
     "a 3-D float64 array"),
    ("npy of objects", "s.npy", np.array([None, 1], dtype=object), "spacing_mm = 2.0\n",
     "lens.front.file", "not a NumPy array file"),
]


@pytest.mark.parametrize("name, fname, content, extra, field, says", MALFORMED,
                         ids=[m[0] for m in MALFORMED])
def test_a_malformed_points_file_is_one_named_line(name, fname, content, extra, field, says,
                                                    tmp_path, capsys):
    path = tmp_path / fname
    if name == "no file":
        pass
    elif isinstance(content, np.ndarray):
        np.save(path, content, allow_pickle=True)
        path = path.with_suffix(".npy")
    elif content is None:
        path.write_bytes(b"SURFMT=1;R;F\xff\xfe\x00")
    else:
        path.write_text(content)
    diameter = "20.0" if name == "grid smaller than the lens" else "12.0"
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.format(file=fname, extra=extra).replace("= 12.0", f"= {diameter}"))
    rc, out, err = _cli(["analyze", spec, "-o", tmp_path / "out.json"], capsys)
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"eyelab: error: {field}: ") and says in err, err
    assert not (tmp_path / "out.json").exists()


def test_surface_flags_are_checked_first(tmp_path, capsys):
    (tmp_path / "a.toml").write_text(LENSES["toric"])
    (tmp_path / "p.toml").write_text(LENSES["progressive"])
    (tmp_path / "naked.toml").write_text('[eye]\nrx = "-1.00 DS"\n')
    (tmp_path / "cam.toml").write_text('[render]\nrenderer = "reference"\ncamera = "doublet"\n')
    cases = [
        (["a.toml", "--side", "back", "-o", "x.sdf", "--spacing-mm", "0"], "--spacing-mm"),
        (["a.toml", "--side", "back", "-o", "x.sdf", "--spacing-mm", "nan"], "--spacing-mm"),
        (["a.toml", "--side", "back", "-o", "x.sdf", "--spacing-mm", "0.05", "--size-mm",
          "150"], "--spacing-mm"),
        (["a.toml", "--side", "back", "-o", "x.sdf", "--size-mm", "200"], "--size-mm"),
        (["a.toml", "--side", "back", "-o", "x.sdf", "--size-mm", "40"], "--size-mm"),
        (["p.toml", "--side", "front", "-o", "x.sdf", "--size-mm", "70"], "--size-mm"),
        (["a.toml", "--side", "back", "-o", "x.txt"], "--output"),
        (["a.toml", "--side", "back", "-o", "."], "--output"),
        (["naked.toml", "--side", "back", "-o", "x.sdf"], "lens"),
        (["cam.toml", "--side", "back", "-o", "x.sdf"], "render.camera"),
        (["a.toml", "--side", "middle", "-o", "x.sdf"], "argument --side"),
        (["a.toml", "--side", "back", "-o", "x.sdf", "--size-mm", "abc"], "argument --size-mm"),
    ]
    for argv, field in cases:
        args = [tmp_path / a if a.endswith(".toml") else
                tmp_path / a if a.startswith(("x.", ".")) else a for a in argv]
        with pytest.raises(SystemExit) if field.startswith("argument") else _noop() as e:
            rc, _, err = _cli(["surface", *args], capsys)
        if field.startswith("argument"):
            assert e.value.code == 2 and field in capsys.readouterr().err
            continue
        assert rc == 2 and len(err.splitlines()) == 1 and \
            err.startswith(f"eyelab: error: {field}"), (argv, err)
        assert not list(tmp_path.glob("x.*")), argv


class _noop:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_a_points_lens_in_the_maps_command(tmp_path, capsys):
    """``eyelab maps`` of a lens from points files (compared with its lens.rx)."""
    _round_trip(tmp_path, "toric", ".sdf", capsys)
    rc, out, err = _cli(["maps", tmp_path / "b.toml", "-o", tmp_path / "m.png",
                         "--points", "5"], capsys)
    assert rc == 0 and "mean power error" in out and (tmp_path / "m.png").stat().st_size, err


def test_a_spec_table_parsed_away_from_its_file_keeps_its_points_files(tmp_path):
    """A spec's table parsed without its folder (as a batch job's) reads its relative
    points files from that folder once :func:`absolute_files` has made them absolute."""
    from eyelab.spec import parse_spec, read_spec_data
    from eyelab.spec.surfacefile import absolute_files

    sub = tmp_path / "spec"
    sub.mkdir()
    shutil.copy(FIXTURES / "paraboloid_writer.sdf", sub / "f.sdf")
    (sub / "s.toml").write_text(SPEC.format(file="f.sdf", extra=""))
    data = read_spec_data(sub / "s.toml")[0]
    with pytest.raises(SpecError, match="lens.front.file.*not an existing file"):
        parse_spec(data)
    lens = parse_spec(absolute_files(data, sub)).lens
    assert data["lens"]["front"]["file"] == str(sub / "f.sdf")
    assert lens.front.derivatives(np.zeros(1), np.zeros(1)).zxx[0] == pytest.approx(10.0)


def test_a_surface_for_the_other_eye_is_refused(tmp_path, capsys):
    """SURFMT's field 2 names the eye: a right lens's surface given for a left lens (by the
    lens Rx's side) is refused naming the file, not mirrored silently."""
    shutil.copy(FIXTURES / "paraboloid_writer.sdf", tmp_path / "front.sdf")   # R
    (tmp_path / "s.toml").write_text('[lens]\ncenter_thickness_mm = 2.0\ndiameter_mm = 12.0\n'
                                     'rx = "L +5.00 DS"\n[lens.front]\nfile = "front.sdf"\n'
                                     '[lens.back]\ntype = "plane"\n')
    rc, out, err = _cli(["analyze", tmp_path / "s.toml"], capsys)
    assert rc == 2 and err.startswith("eyelab: error: lens.front.file: front.sdf is a right "
                                      "lens's surface"), err
