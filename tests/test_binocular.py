"""Two eyes behind one frame (eyelab/optics/chain/binocular.py): the spec, vergence, the consensual
accommodation rule, induced prism against Prentice's rule, mirror symmetry of the two
views, anisometropic blur against the single eye and the analytic defocus disc, and the
stereo compositions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.core.errors import SpecError
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.imaging.stereo import DUBOIS_LEFT, DUBOIS_RIGHT, compose, render_binocular
from eyelab.jobs.analyze import analyze_spec
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.chain.binocular import SIDES, analyze_binocular
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import box, grid_quad
from eyelab.scene.scene import Scene
from eyelab.spec import parse_spec

NO_LCA = {"chromatic": False}


def _spec(**tables):
    return parse_spec(tables)


# ------------------------------------------------------------------------------ spec
def test_per_eye_tables_override_the_shared_ones_and_the_frame_places_the_lenses():
    s = _spec(eye={"age": 30, "rx": "-2.00 DS", "left": {"rx": "-3.50 -0.75 x 170"}},
              lens={"wrap_deg": 5.0, "material": "pc"},
              binocular={"monocular_pd_mm": [31.0, 33.0], "frame_pd_mm": 60.0})
    b = s.binocular
    assert (b.right_lens.rx.sphere, b.left_lens.rx.sphere) == (-2.0, -3.5)
    assert b.left_lens.rx.axis == 170.0 and b.left.accommodation_max == b.right.accommodation_max
    # optical centres at +-30 mm, pupils at +31 / -33 mm: both lenses 1 and 3 mm nasal
    assert b.right_lens.pose.decentration[0] == pytest.approx(-0.001)
    assert b.left_lens.pose.decentration[0] == pytest.approx(+0.003)
    # face-form wrap: each lens's temporal rim toward the face
    for side, temporal in (("right", 1.0), ("left", -1.0)):
        pose = b.lens(side).pose
        z = (pose.rotation @ np.array([temporal * 0.025, 0.0, 0.0]))[2]
        assert z > 0.0
    assert s.fixation == "rotating" and s.eye is b.right and s.lens is b.right_lens
    assert np.allclose(b.pupil("left"), [-0.033, 0.0, 0.0])


@pytest.mark.parametrize("tables, field", [
    ({"eye": {"right": {"rx": "L -1.00"}}}, "eye.right.rx"),
    ({"eye": {"left": {"accommodation_d": 1.0}}}, "eye.left.accommodation_d"),
    ({"eye": {"left": {"pupil_diameter_mm": 20}}}, "eye.left.pupil_diameter_mm"),
    ({"eye": {"rx": "-1", "right": 5}}, "eye.right"),
    ({"binocular": {"pd_mm": 64, "monocular_pd_mm": [32, 32]}}, "binocular.pd_mm"),
    ({"binocular": {"monocular_pd_mm": [32]}}, "binocular.monocular_pd_mm"),
    ({"binocular": {"fixation_distance_m": 0.01}}, "binocular.fixation_distance_m"),
    ({"binocular": {"output": "wiggle"}}, "binocular.output"),
    ({"binocular": {"pdd_mm": 64}}, "binocular.pdd_mm"),
    ({"eye": {"rx": "-1"}, "lens": {"left": {"wrap_deg": 40}}}, "lens.left.wrap_deg"),
    ({"eye": {"rx": "-1"}, "lens": {"right": {"decentration_mm": [25, 0]}}},
     "lens.right.decentration_mm[0]"),
])
def test_bad_binocular_specs_name_the_field(tables, field):
    with pytest.raises(SpecError) as e:
        parse_spec(tables)
    assert e.value.field == field


def test_a_frame_pd_that_moves_a_lens_too_far_is_refused_by_name():
    with pytest.raises(SpecError) as e:
        _spec(eye={"rx": "-1"}, lens={"right": {"decentration_mm": [-15, 0]}},
              binocular={"pd_mm": 64, "frame_pd_mm": 50})
    assert e.value.field == "binocular.frame_pd_mm"


# ------------------------------------------------------------------------- vergence
@pytest.mark.parametrize("down", [0.0, 25.0])
def test_each_eye_turns_toward_the_fixated_point(down):
    """Fixation 0.4 m from the cyclopean centre of rotation along a gaze 0 or 25 deg
    down: each eye's Fick angles from its own centre of rotation, by plane trigonometry."""
    b = _spec(binocular={"pd_mm": 64, "fixation_distance_m": 0.4}).binocular
    r = b.right.rotation_centre
    e0 = math.radians(-down)
    fix = np.array([0.0, 0.4 * math.sin(e0), r - 0.4 * math.cos(e0)])
    for side, x in (("right", 0.032), ("left", -0.032)):
        v = fix - np.array([x, 0.0, r])
        a = math.degrees(math.atan2(v[0], -v[2]))
        e = math.degrees(math.asin(v[1] / np.linalg.norm(v)))
        got = b.gaze(side, (0.0, -down))
        assert got == pytest.approx((a, e), abs=1e-9)
    assert b.gaze("right", (0.0, -down))[0] == pytest.approx(-math.degrees(math.atan2(
        0.032, 0.4 * math.cos(e0))), abs=1e-9)


def test_a_fixation_too_close_to_turn_to_is_refused():
    b = _spec(binocular={"fixation_distance_m": 0.1}).binocular
    with pytest.raises(SpecError) as e:
        b.gaze("left", (55.0, 0.0))      # the left eye would turn 63 deg, the right 41
    assert abs(b.gaze("right", (55.0, 0.0))[0]) < 45
    assert e.value.field == "binocular.fixation_distance_m"


# ------------------------------------------------------------- linked accommodation
def test_the_least_ametropic_eye_drives_accommodation():
    """Hyperopic anisometropia +1 / +4 at infinity: both eyes could focus, the lower
    response (the right eye's) wins and the left eye lags by the difference; myopic
    anisometropia -1 / -4 at 0.4 m: only the right eye can be focused (the left's far
    point is nearer than the page), so the right eye drives."""
    for rx_r, rx_l, dist, acc_max in (("+1.00", "+4.00", math.inf, 8.0),
                                      ("-1.00", "-4.00", 0.4, 8.0)):
        s = _spec(eye={"accommodation_max_d": acc_max, **NO_LCA, "right": {"rx": rx_r},
                       "left": {"rx": rx_l}}, binocular={})
        pts = ObjectPoints.from_angles(dist, 0.0, 0.0)
        an = analyze_binocular(s.binocular, pts, fixation="rotating")
        solo = analyze_points(s.binocular.right, None, an["points"]["right"],
                              fixation="rotating")
        assert an["driving_eye"][0] == "right"
        assert an["accommodation_d"][0] == pytest.approx(solo.accommodation[0], abs=1e-12)
        assert an["right"].a[0] == pytest.approx(0.0, abs=1e-9)       # sharp
        assert abs(an["left"].a[0]) > 1e-5                            # blurred: lags
    # swapped sides: the left eye drives
    s = _spec(eye={"accommodation_max_d": 8.0, "right": {"rx": "+4.00"},
                   "left": {"rx": "+1.00"}}, binocular={})
    an = analyze_binocular(s.binocular, ObjectPoints.from_angles(math.inf, 0.0, 0.0))
    assert an["driving_eye"][0] == "left"


# ----------------------------------------------------------------------------- prism
def test_prentice_prism_in_analyze():
    """-4.00 D lenses with optical centres 5 mm nasal of each pupil (frame PD 54 mm, PD
    64 mm): Prentice's rule c F = 0.5 cm x 4 D = 2 prism dioptres base out per eye at the
    fixated point, 4 base out in all, no vertical imbalance (within 5 %)."""
    s = _spec(eye={"rx": "-4.00 DS", **NO_LCA}, lens={},
              binocular={"pd_mm": 64, "frame_pd_mm": 54})
    rep = analyze_spec(s)
    p = rep["points"][0]["prism"]
    assert p["right"]["prism_d"] == pytest.approx(2.0, rel=0.05)
    assert p["left"]["prism_d"] == pytest.approx(2.0, rel=0.05)
    assert p["right"]["base_right_d"] > 0 > p["left"]["base_right_d"]      # base out
    assert p["binocular"]["horizontal_base_out_d"] == pytest.approx(4.0, rel=0.05)
    assert p["binocular"]["vertical_right_base_up_d"] == pytest.approx(0.0, abs=1e-9)
    assert set(rep["eyes"]) == set(SIDES)


def test_anisometropic_vertical_imbalance_follows_prentice():
    """R -1.00 / L -4.00, both optical centres 5 mm above the pupils: the lines of sight
    pass 5 mm below, base down 0.5 (right) and 2 (left): 1.5 prism dioptres right base up
    (within 5 %)."""
    s = _spec(eye={**NO_LCA, "right": {"rx": "-1.00 DS"}, "left": {"rx": "-4.00 DS"}},
              lens={"decentration_mm": [0.0, 5.0]}, binocular={})
    p = analyze_spec(s)["points"][0]["prism"]
    assert p["binocular"]["vertical_right_base_up_d"] == pytest.approx(1.5, rel=0.05)
    assert p["right"]["base_up_d"] == pytest.approx(-0.5, rel=0.05)


def _centroid_x(img):
    w = img[..., 1].astype(float)
    return float((w.sum(0) * np.arange(w.shape[1])).sum() / w.sum())


def test_prentice_prism_is_the_image_shift_in_the_render():
    """The same -4.00 D wearer rendered with centred lenses and with optical centres 5 mm
    nasal: a far dot straight ahead moves nasally in each eye by Prentice's 2 prism
    dioptres (within 5 %)."""
    scene = Scene([grid_quad("dot", (0, 0, -50.0), (1, 0, 0), (0, 1, 0), 0.2, 0.2, nu=1,
                             nv=1, colors=np.array([255, 255, 255], np.uint8))],
                  background=(0, 0, 0))
    w, fov = 160, 8.0
    view = View(width=w, height=w, fov_y_deg=fov, near=1.0, far=100.0)
    px_per_rad = w / (2 * math.tan(math.radians(fov / 2)))
    pos = {}
    with RasterRenderer(RasterQuality(samples=4)) as r:
        for fpd in (64, 54):
            b = _spec(eye={"rx": "-4.00 DS", **NO_LCA}, lens={},
                      binocular={"pd_mm": 64, "frame_pd_mm": fpd}).binocular
            res = render_binocular(r, scene, b, view)
            pos[fpd] = {s: _centroid_x(getattr(res, s).linear) for s in SIDES}
    for side, nasal in (("right", -1.0), ("left", 1.0)):
        shift = (pos[54][side] - pos[64][side]) / px_per_rad      # radians, tan-plane
        assert nasal * shift == pytest.approx(0.02, rel=0.05), side


# --------------------------------------------------------------------------- renders
def _symmetric_scene() -> Scene:
    rng = np.random.default_rng(3)
    half = rng.integers(0, 256, (48, 24, 3), dtype=np.uint8)
    tex = np.concatenate([half, half[:, ::-1]], axis=1)        # mirror-symmetric in x
    wall = grid_quad("wall", (0.0, 0.0, -1.0), (1, 0, 0), (0, 1, 0), 1.2, 1.2, nu=8, nv=8,
                     texture=tex)
    boxes = [box(f"box{i}", (sx * 0.12, -0.08, -0.5), (0.06, 0.06, 0.06), (200, 60, 40))
             for i, sx in enumerate((-1, 1))]
    return Scene([wall, *boxes], background=(20, 20, 20))


def test_mirror_symmetric_wearer_sees_mirror_image_views():
    """Identical Rx (axis 90, itself mirror-symmetric), a symmetric frame (tilt, face-form
    wrap, frame PD under the PD), converging on a point 0.6 m ahead: the right eye's view
    flipped left-right is the left eye's view (and, unflipped, it is not)."""
    s = _spec(eye={"rx": "-2.00 -1.00 x 90", "age": 40, **NO_LCA},
              lens={"pantoscopic_tilt_deg": 8.0, "wrap_deg": 6.0},
              binocular={"pd_mm": 64, "frame_pd_mm": 60, "fixation_distance_m": 0.6})
    view = View(width=96, height=72, fov_y_deg=40.0, near=0.2, far=5.0)
    with RasterRenderer(RasterQuality(samples=32)) as r:
        res = render_binocular(r, _symmetric_scene(), s.binocular, view)
    right, left = res.right.linear, res.left.linear
    mirrored = np.abs(right[:, ::-1] - left)
    assert res.report["binocular"]["eyes"]["right"]["gaze_deg"][0] == pytest.approx(
        -res.report["binocular"]["eyes"]["left"]["gaze_deg"][0], abs=1e-12)
    assert mirrored.mean() < 0.01 and np.percentile(mirrored, 99) < 0.06
    assert np.abs(right - left).mean() > 5 * mirrored.mean()


def _edge_scene() -> Scene:
    dark = grid_quad("dark", (-1.0, 0.0, -6.0), (1, 0, 0), (0, 1, 0), 2.0, 2.0, nu=2, nv=2,
                     colors=np.array([0, 0, 0], np.uint8))
    light = grid_quad("light", (1.0, 0.0, -6.0), (1, 0, 0), (0, 1, 0), 2.0, 2.0, nu=2,
                      nv=2, colors=np.array([255, 255, 255], np.uint8))
    return Scene([dark, light], background=(128, 128, 128))


def _edge_sigma_rad(img, px_per_rad):
    """Second moment (rad) of the line spread: the derivative of the row-averaged edge."""
    prof = img[img.shape[0] // 4: 3 * img.shape[0] // 4, :, 1].mean(0)
    lsf = np.diff(prof)
    x = np.arange(len(lsf))
    c = (lsf * x).sum() / lsf.sum()
    return math.sqrt((lsf * (x - c) ** 2).sum() / lsf.sum()) / px_per_rad


def test_anisometropic_blur_per_eye_equals_the_single_eye_and_the_defocus_disc():
    """R -1.00 / L -4.00 uncorrected, a black/white edge at 6 m: each eye's view in the
    binocular render is the single-eye render of the scene seen from that eye (pixel for
    pixel); its blur equals the single eye's at the origin (2 %: the edge falls on another
    pixel phase) and the analytic defocus disc: a disc of angular radius R = pupil radius
    x |object vergence - far point| has a line spread of second moment R / 2 (2 %)."""
    s = _spec(eye={**NO_LCA, "age": 30, "right": {"rx": "-1.00 DS"},
                   "left": {"rx": "-4.00 DS"}}, binocular={})
    w, h, fov = 240, 64, 4.0
    view = View(width=w, height=h, fov_y_deg=fov * h / w, near=1.0, far=20.0)
    px_per_rad = h / (2 * math.tan(math.radians(fov * h / w / 2)))
    scene = _edge_scene()
    with RasterRenderer(RasterQuality(samples=256, reconstruct=False)) as r:
        bino = render_binocular(r, scene, s.binocular, view)
        assert bino.report["binocular"]["accommodation_d"] == 0.0
        for side in SIDES:
            eye = s.binocular.eye(side)
            got = getattr(bino, side).linear
            there = r.render(s.binocular.scene_for(side, scene), eye, None,
                             view.replace(focus_d=0.0))
            assert np.array_equal(got, there.linear), side
            solo = r.render(scene, eye, None, view)
            sigma = _edge_sigma_rad(got, px_per_rad)
            assert sigma == pytest.approx(_edge_sigma_rad(solo.linear, px_per_rad),
                                          rel=0.02), side
            far_point = eye.refraction()[0]
            radius = eye.pupil_diameter / 2 * abs(-1.0 / 6.0 - far_point)
            assert sigma == pytest.approx(radius / 2, rel=0.02), side


def test_compositions():
    """Side by side: the left eye's image on the left (parallel viewing), crossed the
    other way; Dubois's matrices keep white white (each output row sums to 1 within their
    published three decimals) and send a left-only image to red."""
    right = np.full((4, 6, 3), 0.25, np.float32)
    left = np.full((4, 6, 3), 0.75, np.float32)
    sbs = compose(right, left, "side-by-side")
    assert sbs.shape == (4, 12, 3) and sbs[0, 0, 0] == 0.75 and sbs[0, -1, 0] == 0.25
    assert compose(right, left, "crossed")[0, 0, 0] == 0.25
    assert np.allclose((DUBOIS_LEFT + DUBOIS_RIGHT).sum(1), 1.0, atol=2e-3)
    white = compose(np.ones((2, 2, 3)), np.ones((2, 2, 3)), "anaglyph")
    assert np.allclose(white, 1.0, atol=2e-3)
    red = compose(np.zeros((2, 2, 3)), np.ones((2, 2, 3)), "anaglyph")
    assert red[0, 0, 0] > 0.9 and red[0, 0, 1] == 0.0 and red[0, 0, 2] == 0.0


# ------------------------------------------------------------------------------- CLI
SPEC = """[eye]
age = 45
[eye.right]
rx = "-1.00 DS"
[eye.left]
rx = "-2.50 -0.50 x 10"
[lens]
material = "cr39"
[binocular]
pd_mm = 63
frame_pd_mm = 60
fixation_distance_m = 2.0
[render]
scene = "room"
width = 64
height = 48
samples = 2
"""


@pytest.mark.parametrize("output, width", [("anaglyph", 64), ("side-by-side", 128),
                                           ("left", 64)])
def test_cli_render_binocular(tmp_path, capsys, output, width):
    import matplotlib.image as mpimg

    from eyelab.apps.cli import main

    spec = tmp_path / "b.toml"
    spec.write_text(SPEC)
    png, rep = tmp_path / "b.png", tmp_path / "b.json"
    assert main(["render", str(spec), "-o", str(png), "--report", str(rep), "--binocular",
                 output, "--quiet"]) == 0
    assert mpimg.imread(png).shape[:2] == (48, width)
    import json

    report = json.loads(rep.read_text())
    assert list(report) == ["units", "binocular", "right", "left"]     # the units first
    assert report["binocular"]["output"] == output
    assert report["binocular"]["prism_at_fixation"]["binocular"]["horizontal"]
    out = capsys.readouterr().out
    assert "induced prism at fixation" in out and "right eye: gaze" in out


def test_cli_binocular_analyze_and_a_bad_output(tmp_path, capsys):
    import json

    from eyelab.apps.cli import main

    spec = tmp_path / "b.toml"
    spec.write_text(SPEC)
    assert main(["analyze", str(spec), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert set(rep["eyes"]) == {"right", "left"} and rep["binocular"]["fixation"] == "rotating"
    assert main(["analyze", str(spec)]) == 0
    assert "induced prism" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main(["render", str(spec), "--binocular", "wiggle", "-o", str(tmp_path / "x.png")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--binocular" in err[0]
    assert not (tmp_path / "x.png").exists()


def test_progressive_lenses_are_made_for_their_sides():
    """One Rx with an add for both eyes: each progressive lens's inset goes nasally, so
    the left lens's front surface is the right's mirror image (to rounding)."""
    s = _spec(eye={"rx": "-1.00 add 2.00", "age": 60}, lens={"design": "progressive"},
              binocular={})
    b = s.binocular
    assert (b.right_lens.design.eye, b.left_lens.design.eye) == ("R", "L")
    x, y = np.meshgrid(np.linspace(-0.02, 0.02, 9), np.linspace(-0.02, 0.015, 9))
    assert np.allclose(b.right_lens.front.sag(x, y), b.left_lens.front.sag(-x, y),
                       rtol=0, atol=1e-12)
    assert not np.allclose(b.right_lens.front.sag(x, y), b.right_lens.front.sag(-x, y),
                           rtol=0, atol=1e-7)


def test_one_eye_tools_refuse_a_binocular_spec(tmp_path, capsys):
    """maps, the inspector and batch show one eye: a binocular spec is one line, exit 2,
    nothing written (never the right eye alone, silently)."""
    from eyelab.apps.cli import main
    from eyelab.spec import one_eye

    spec = tmp_path / "b.toml"
    spec.write_text(SPEC)
    out = tmp_path / "m.png"
    assert main(["maps", str(spec), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("eyelab: error: binocular:")
    assert not out.exists()
    with pytest.raises(SpecError) as e:
        one_eye(_spec(binocular={}), "the inspector")
    assert e.value.field == "binocular"


# --------------------------------------------------------------- two schematic eyes
@pytest.mark.parametrize("rx_r, rx_l, dist, driver", [
    ("+1.00", "+3.00", math.inf, "right"),      # hyperopes: the lower response
    ("-1.00", "-4.00", 0.4, "right"),           # the left's far point is nearer than 0.4 m
    ("-3.00", "-1.50", 0.5, "left"),            # the right's too
])
def test_two_schematic_eyes_share_the_less_blurred_eyes_response(rx_r, rx_l, dist, driver):
    """Two Navarro eyes (axial anisometropia, naked) fixating a point: the driving eye is
    the thin pair's for the same prescriptions, and the exact trace to its retina finds it
    focused (refraction along its line of sight within 0.02 D of the object's vergence
    there, i.e. M = 0) while the other lags or leads by about the anisometropia."""
    tables = {"eye": {"model": "navarro", "right": {"rx": rx_r}, "left": {"rx": rx_l}},
              "binocular": {}}
    pts = ObjectPoints.from_angles(dist, 0.0, 0.0)
    an = analyze_binocular(_spec(**tables).binocular, pts, fixation="rotating")
    thin = {"eye": {"right": {"rx": rx_r}, "left": {"rx": rx_l}, "accommodation_max_d": 8.0},
            "binocular": {}}
    assert an["driving_eye"][0] == driver
    assert analyze_binocular(_spec(**thin).binocular, pts)["driving_eye"][0] == driver
    other = "left" if driver == "right" else "right"
    assert abs(an[driver].m[0]) < 0.02, an[driver].m
    assert abs(an[other].m[0]) > 0.5, an[other].m


def test_two_schematic_eyes_render_analyze_and_refuse_a_pair_of_models(tmp_path, capsys):
    """eyelab render --binocular of examples/myope.toml (the Navarro myope, both eyes from
    [eye] and [lens]) runs and turns each eye as a thin pair with the same centres of
    rotation does (the vergence is geometry); analyze prints both eyes' exact rows; a
    thin eye beside a schematic one is refused in one line naming the side's key."""
    import json

    from eyelab.apps.cli import main

    out = tmp_path / "b.png"
    assert main(["render", "examples/myope.toml", "--binocular", "--width", "48", "--height",
                 "36", "--samples", "2", "-o", str(out), "--report",
                 str(tmp_path / "b.json")]) == 0
    rep = json.loads((tmp_path / "b.json").read_text())["binocular"]
    assert rep["eyes"]["right"]["accommodation_d"] == rep["accommodation_d"]
    near = {"eye": {"model": "navarro", "rx": "-2.00"}, "lens": {"rx": "-2.00"},
            "binocular": {"fixation_distance_m": 0.4}}
    thin = {"eye": {"rx": "-2.00"}, "lens": {"rx": "-2.00"},
            "binocular": {"fixation_distance_m": 0.4}}
    for side in SIDES:
        assert _spec(**near).binocular.gaze(side) == _spec(**thin).binocular.gaze(side)
    both = analyze_spec(_spec(**near))
    assert set(both["eyes"]) == {"right", "left"}
    assert both["eyes"]["left"]["eye"]["model"] == "navarro"
    assert "prism" in both["points"][0]
    capsys.readouterr()
    mixed = tmp_path / "mixed.toml"
    mixed.write_text('[eye.right]\nrx = "-2.00"\n[eye.left]\nmodel = "navarro"\n'
                     'rx = "-2.00"\n')
    assert main(["analyze", str(mixed)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "eye.left.model" in err[0], err
