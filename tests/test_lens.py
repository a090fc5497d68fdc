import math

import numpy as np
import pytest
import trimesh

from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import MIN_EDGE_THICKNESS, LensPose, SpectacleLens
from eyelab.optics.rays.materials import CATALOGUE
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.surfaces import Sphere, Toric
from eyelab.optics.rays.trace import Status
from eyelab.reference.bruteforce import bundle_vergence


@pytest.mark.parametrize("text", ["-6.00 DS", "+4.00 -2.00 x 30", "-2.25 -1.00 x 180",
                                  "+10.00 DS", "-10.00 -4.00 x 135", "+6.00 -3.00 x 77"])
@pytest.mark.parametrize("material", ["cr39", "polycarbonate", "1.74"])
def test_designed_lens_back_vertex_power_equals_rx_by_tracing(text, material):
    rx = Prescription.parse(text)
    lens = SpectacleLens.from_rx(rx, material=material)
    f1, f2, ang = lens.back_vertex_powers()
    (pa, dir_a), (pb, _) = rx.principal_meridians()
    assert sorted([f1, f2]) == pytest.approx(sorted([pa, pb]), abs=1e-10)
    if rx.cylinder:
        # the meridian of power f1 is the axis direction when S > S + C
        want = dir_a if pa > pb else dir_a + math.pi / 2
        assert math.cos(2 * (ang - want)) == pytest.approx(1.0, abs=1e-9)


def test_thick_lens_back_vertex_formula_on_axis():
    # F_v = F1 / (1 - t F1 / n) + F2 (docs/SCIENCE.md §7), for explicit surfaces
    n = CATALOGUE["crown"].n_d
    c1, c2, t = 9.0, 18.0, 0.004
    lens = SpectacleLens(Sphere(c1), Sphere(c2), t, CATALOGUE["crown"])
    f1, f2 = (n - 1) * c1, (1 - n) * c2
    fv = f1 / (1 - t * f1 / n) + f2
    assert lens.back_vertex_powers()[0] == pytest.approx(fv, rel=1e-12)


def test_effective_power_at_cornea_minus_six_at_12mm():
    lens = SpectacleLens.from_rx(Prescription(-6.0), pose=LensPose(vertex_distance=0.012))
    res = analyze_points(Eye(), lens, ObjectPoints.from_angles(np.inf, 0.0, 0.0))
    # docs/SCIENCE.md §2: -6.00 D at 12 mm -> -5.597 D at the cornea
    assert res.wave_eye.k11[0] == pytest.approx(-6.0 / (1 + 0.012 * 6.0), abs=1e-9)


def test_plus_lens_edge_thickness_and_minus_centre_thickness():
    plus = SpectacleLens.from_rx(Prescription(4.0, -1.0, 60))
    r = plus.diameter / 2
    ang = np.linspace(0, np.pi, 361)
    edge = plus.center_thickness - plus.front.sag(r * np.cos(ang), r * np.sin(ang)) \
        + plus.back.sag(r * np.cos(ang), r * np.sin(ang))
    assert edge.min() == pytest.approx(MIN_EDGE_THICKNESS, abs=1e-6)
    minus = SpectacleLens.from_rx(Prescription(-4.0), material="polycarbonate")
    assert minus.center_thickness == pytest.approx(1.5e-3)


def test_too_steep_explicit_diameter_is_a_clear_error():
    with pytest.raises(SpecError, match="diameter|steep"):
        SpectacleLens.from_rx(Prescription(-20.0), diameter=0.08)


def test_mesh_is_closed_and_matches_surfaces():
    lens = SpectacleLens.from_rx(Prescription(-3.0, -1.5, 20),
                                 pose=LensPose(pantoscopic_tilt_deg=10.0))
    v, f, part = lens.mesh(rings=12, segments=48)
    m = trimesh.Trimesh(v, f, process=True)
    assert m.is_watertight
    assert m.volume > 0
    # front vertices lie on the placed front surface
    fs, _ = lens.placed_surfaces()
    local = (v[part == 0] - fs.translation) @ fs.rotation
    np.testing.assert_allclose(local[:, 2], fs.surface.sag(local[:, 0], local[:, 1]), atol=1e-15)


LENSES = {
    "sphere-10": SpectacleLens.from_rx(Prescription(-10.0)),
    "sphere+10": SpectacleLens.from_rx(Prescription(10.0)),
    "toric": SpectacleLens.from_rx(Prescription(3.0, -4.0, 30), material="polycarbonate"),
    "toric-tilted": SpectacleLens.from_rx(
        Prescription(-6.0, -2.0, 100), material="1.67",
        pose=LensPose(pantoscopic_tilt_deg=10.0, wrap_deg=5.0, decentration=(0.002, -0.001))),
    "explicit-toric-front": SpectacleLens(Toric(9.0, 5.0, 0.3, "x"), Sphere(14.0), 0.003,
                                          CATALOGUE["trivex"]),
}


@pytest.mark.parametrize("name", LENSES)
@pytest.mark.parametrize("fixation", ["fixed", "rotating"])
def test_wavefront_tracer_matches_brute_force_ray_bundles(name, fixation):
    """Acceptance (b): vergences from thousands of real rays agree to 1e-4 D, for powers up
    to +-10 D and field angles up to 35 deg."""
    lens = LENSES[name]
    obj = ObjectPoints.from_angles([np.inf, 0.33, 2.0, 0.5, 6.0],
                                   [0.0, 15.0, 25.0, -35.0, 0.0], [0.0, 10.0, -20.0, 0.0, 30.0])
    res = analyze_points(Eye(), lens, obj, fixation=fixation)
    expect_visible = np.ones(len(obj), bool)
    if name == "sphere+10" and fixation == "rotating":
        # a ray from the centre of rotation through the rim of this +10 D lens leaves at
        # ~32 deg (prism 30 D at the rim), so the 35 deg point cannot be seen through it
        expect_visible[3] = False
        assert res.status[3] & Status.MISSED
    np.testing.assert_array_equal(res.status == 0, expect_visible)
    kxx, kxy, kyy = res.wave_eye.in_basis(res.eye_x)
    for i in np.flatnonzero(expect_visible):
        bf = bundle_vergence(lens, res.chief.start[i], res.chief.dir_in[i],
                             bool(np.isfinite(obj.distance[i])), res.pupil[i],
                             res.wave_eye.N[i], res.eye_x[i], radius=1e-5)
        np.testing.assert_allclose([kxx[i], kxy[i], kyy[i]], bf[:3], atol=1e-4)


def test_trace_wavelengths_equals_one_trace_per_wavelength():
    """The shared first-surface intersection changes nothing: bit-identical to separate
    traces, misses and TIR included (rays out to 70 deg from a decentred, tilted lens)."""
    lens = SpectacleLens.from_rx(Prescription(-6.0, -2.0, 30), material="polycarbonate",
                                 pose=LensPose(pantoscopic_tilt_deg=10.0,
                                                 decentration=(0.003, 0)))
    rng = np.random.default_rng(5)
    d = np.column_stack([rng.uniform(-3, 3, 4000), rng.uniform(-3, 3, 4000), -np.ones(4000)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros_like(d)
    wls = (656.27, 587.56, 486.13)
    many = lens.trace_wavelengths(o, d, wls, reverse=True)
    for wl, res in zip(wls, many, strict=True):
        one = lens.trace(o, d, wl, reverse=True)
        for key in ("out_points", "out_dirs", "inside", "status"):
            np.testing.assert_array_equal(res[key], one[key])
    assert 0 < (many[0]["status"] != 0).sum() < len(d)


def test_an_add_is_never_ignored():
    """A single-vision lens from an Rx with an add needs lens.design; "near" puts the add
    on the sphere: a point at the add's focus (1/2.25 m before the lens, 0.456 m from the
    pupil) is sharp through it for an eye without accommodation and blurred through the
    distance design, and the library refuses an add outright."""
    from eyelab.spec import parse_spec

    base = {"eye": {"rx": "+0.50 DS", "accommodation_max_d": 0.0},
            "points": [{"distance_m": 1 / 2.25 + 0.012}, {"distance_m": "inf"}]}
    with pytest.raises(SpecError) as e:
        parse_spec(dict(base, lens={"rx": "+0.50 DS add +2.25"}))
    assert e.value.field == "lens.design" and "+2.75" in e.value.message
    blur = {}
    for design in ("single-vision", "near"):
        spec = parse_spec(dict(base, lens={"rx": "+0.50 DS add +2.25", "design": design}))
        res = analyze_points(spec.eye, spec.lens, spec.points)
        blur[design] = res.to_arcmin(res.blur_axes()[0])
    assert blur["near"][0] < 1 < 10 < blur["single-vision"][0]     # arcmin, near point
    assert blur["single-vision"][1] < 1 < 10 < blur["near"][1]     # and at infinity
    with pytest.raises(SpecError, match="add"):
        SpectacleLens.from_rx(Prescription(0.5, add=2.25))
    SpectacleLens.from_rx(Prescription(0.5, add=2.25).near())


def test_tilt_and_wrap_turn_the_documented_rims_toward_the_face():
    """Pantoscopic tilt: the lower rim toward the cheeks; wrap: the +x rim (a right lens's
    temporal rim) toward the face — the eye is at z = 0, the lens at z < 0."""
    rim = 0.025
    for pose, point in ((LensPose(pantoscopic_tilt_deg=10.0), (0.0, -rim, 0.0)),
                        (LensPose(wrap_deg=10.0), (rim, 0.0, 0.0))):
        z = (pose.rotation @ np.array(point) + pose.translation)[2]
        assert z == pytest.approx(-0.012 + rim * math.sin(math.radians(10.0)), abs=1e-12)
