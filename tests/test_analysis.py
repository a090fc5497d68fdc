import math

import numpy as np
import pytest

from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import LensPose, SpectacleLens
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.trace import Status
from eyelab.reference.bruteforce import bundle_vergence, retinal_spot_axes

EYES = {
    "myope-astig": Eye.from_rx(Prescription(-3.0, -2.0, 20), accommodation_max=1.0),
    "hyperope-oblique": Eye.from_rx(Prescription(2.0, -1.5, 135), accommodation_max=0.5,
                                    pupil_diameter=6e-3),
    "presbyope": Eye(accommodation_max=0.0, astigmatism=0.75, astigmatism_axis_deg=100,
                     pupil_diameter=3e-3),
}


@pytest.mark.parametrize("eye_name", EYES)
@pytest.mark.parametrize("with_lens", [False, True])
def test_blur_ellipse_matches_brute_force_retinal_spot(eye_name, with_lens):
    """Acceptance (c): 4096 rim rays through the thin toric eye land on an ellipse whose
    semi-axes agree with Eq. 8 to 0.1 um, and whose major axis has the same direction."""
    eye = EYES[eye_name]
    lens = SpectacleLens.from_rx(Prescription(-1.0, -1.0, 60)) if with_lens else None
    obj = ObjectPoints.from_angles([np.inf, 0.4, 1.5], [0, 12, -20], [0, -8, 15])
    res = analyze_points(eye, lens, obj)
    maj, mnr, ang = res.blur_axes()
    k_in = res.wave_eye.in_basis(res.eye_x)
    for i in range(len(obj)):
        bmaj, bmin, bang = retinal_spot_axes(eye, [k[i] for k in k_in], res.accommodation[i])
        assert maj[i] == pytest.approx(bmaj, abs=1e-7)
        assert mnr[i] == pytest.approx(bmin, abs=1e-7)
        if maj[i] - mnr[i] > 1e-6:   # orientation is defined only for a non-circular spot
            assert math.cos(2 * (ang[i] - bang)) == pytest.approx(1.0, abs=1e-6)


def test_corrected_myope_sees_infinity_sharp():
    """Acceptance (d): a 3 D myope with the matching lens at 12 mm: (near-)zero blur."""
    rx = Prescription(-3.0)
    eye = Eye.from_rx(rx, vertex_distance=0.012, accommodation_max=0.0)
    lens = SpectacleLens.from_rx(rx, pose=LensPose(vertex_distance=0.012))
    res = analyze_points(eye, lens, ObjectPoints.from_angles(np.inf, 0.0, 0.0))
    maj, _, _ = res.blur_axes()
    assert maj[0] < 1e-9  # metres: below a nanometre
    naked = analyze_points(eye, None, ObjectPoints.from_angles(np.inf, 0.0, 0.0))
    # uncorrected: blur disc diameter p * dD (docs/SCIENCE.md §11): 4 mm * 2.896 D
    assert naked.to_arcmin(naked.blur_axes()[0][0]) * 2 == pytest.approx(
        4e-3 * 3.0 / (1 + 0.036) * 180 * 60 / math.pi, rel=1e-12)


def test_emmetrope_within_accommodation_range_has_zero_blur():
    eye = Eye(accommodation_max=4.0)
    obj = ObjectPoints.from_angles([np.inf, 2.0, 0.5, 0.26], 0.0, 0.0)
    res = analyze_points(eye, None, obj)
    np.testing.assert_allclose(res.blur_axes()[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(res.accommodation, [0.0, 0.5, 2.0, 1 / 0.26], atol=1e-12)


def test_naked_eye_blur_grows_like_eq8_outside_the_range():
    eye = Eye(accommodation_max=2.0, pupil_diameter=5e-3)
    d = np.array([0.2, 0.1, 0.05])  # closer than the 0.5 m near point
    res = analyze_points(eye, None, ObjectPoints.from_angles(d, 0.0, 0.0))
    dv = 1 / d - 2.0
    want = 2.5e-3 * eye.retina_distance * dv / eye.n_vitreous   # r_p z_r dV / n_2
    np.testing.assert_allclose(res.blur_axes()[0], want, rtol=1e-12)


@pytest.mark.parametrize("rot", [10.0, 47.0, 90.0, 133.0])
def test_rotating_cylinder_axis_rotates_the_ellipse(rot):
    base = Eye(astigmatism=2.0, astigmatism_axis_deg=15.0, accommodation_max=0.0)
    turned = Eye(astigmatism=2.0, astigmatism_axis_deg=15.0 + rot, accommodation_max=0.0)
    # (at infinity this eye's spot is its circle of least confusion: no orientation)
    obj = ObjectPoints.from_angles([2.0, 0.7], 0.0, 0.0)
    a = analyze_points(base, None, obj)
    b = analyze_points(turned, None, obj)
    np.testing.assert_allclose(b.blur_axes()[0], a.blur_axes()[0], rtol=1e-12)
    np.testing.assert_allclose(b.blur_axes()[1], a.blur_axes()[1], rtol=1e-12)
    assert (a.blur_axes()[0] - a.blur_axes()[1] > 1e-6).all()
    np.testing.assert_allclose(np.cos(2 * (b.blur_axes()[2] - a.blur_axes()[2])),
                               np.cos(2 * np.radians(rot)), atol=1e-12)
    np.testing.assert_allclose(np.sin(2 * (b.blur_axes()[2] - a.blur_axes()[2])),
                               np.sin(2 * np.radians(rot)), atol=1e-12)


def test_doubling_pupil_doubles_the_matrix():
    lens = SpectacleLens.from_rx(Prescription(-2.0, -1.0, 45))
    obj = ObjectPoints.from_angles([np.inf, 0.3], [5.0, -10.0], [0.0, 20.0])
    m1 = analyze_points(Eye(pupil_diameter=2e-3), lens, obj).retina_matrix
    m2 = analyze_points(Eye(pupil_diameter=4e-3), lens, obj).retina_matrix
    np.testing.assert_allclose(m2, 2 * m1, rtol=1e-13, atol=1e-18)


def test_mirror_symmetric_points_give_mirror_symmetric_answers():
    lens = SpectacleLens.from_rx(Prescription(-4.0, -2.0, 90))  # symmetric about x = 0
    res = analyze_points(Eye(), lens, ObjectPoints.from_angles(1.0, [-20.0, 20.0], 5.0))
    maj, mnr, ang = res.blur_axes()
    assert maj[0] == pytest.approx(maj[1], rel=1e-10)
    assert mnr[0] == pytest.approx(mnr[1], rel=1e-10)
    assert math.cos(2 * (ang[0] + ang[1])) == pytest.approx(1.0, abs=1e-9)
    assert res.chief.entry[0, 0] == pytest.approx(-res.chief.entry[1, 0], rel=1e-10)


def test_chief_ray_really_reaches_the_pupil_centre():
    lens = SpectacleLens.from_rx(Prescription(5.0, -2.0, 10),
                                 pose=LensPose(pantoscopic_tilt_deg=9.0, wrap_deg=4.0))
    obj = ObjectPoints.from_angles([0.25, 3.0, 1e3], [20.0, -25.0, 10.0], [-15.0, 5.0, 20.0])
    res = analyze_points(Eye(), lens, obj)
    fwd = lens.trace(res.chief.start, res.chief.dir_in)
    o, d = fwd["out_points"], fwd["out_dirs"]
    # distance from the pupil centre (origin) to the forward-traced outgoing line
    miss = np.linalg.norm(np.cross(-o, d), axis=1)
    assert miss.max() < 1e-10


def test_unreachable_points_are_reported_not_guessed():
    lens = SpectacleLens.from_rx(Prescription(-2.0), diameter=0.03)
    obj = ObjectPoints(np.array([[0.0, 0.0, -1.0], [0.9, 0.0, -0.3], [0.0, 0.0, 1.0]]),
                       np.array([1.0, 1.0, 1.0]))
    obj.direction[1] /= np.linalg.norm(obj.direction[1])
    res = analyze_points(Eye(), lens, obj)
    assert res.status[0] == 0
    assert res.status[1] & Status.MISSED       # 72 deg: far outside a 30 mm lens
    assert res.status[2] & Status.BEHIND       # behind the eye
    assert np.isfinite(res.retina_matrix).all()


def test_fixed_accommodation_mode():
    eye = Eye(accommodation_max=5.0, pupil_diameter=4e-3)
    obj = ObjectPoints.from_angles([np.inf, 0.5], 0.0, 0.0)
    res = analyze_points(eye, None, obj, accommodation=2.0)
    np.testing.assert_allclose(res.accommodation, 2.0)
    maj = res.blur_axes()[0]
    assert maj[1] == pytest.approx(0.0, abs=1e-12)
    assert maj[0] == pytest.approx(2e-3 * eye.retina_distance * 2.0 / eye.n_vitreous, rel=1e-12)


def test_vertex_sphere_vergence_follows_martins_formula():
    # pantoscopic tilt theta about the optical centre: S' = S(1 + sin^2 / 2n), C = S' tan^2
    # (docs/SCIENCE.md §2); the chief ray through the optical centre at the rotation centre.
    s, tilt = -8.0, 12.0
    lens = SpectacleLens.from_rx(Prescription(s), material="crown",
                                 pose=LensPose(pantoscopic_tilt_deg=tilt))
    # straight ahead through the back vertex, about which the lens is tilted
    res = analyze_points(Eye(), lens, ObjectPoints.from_angles(np.inf, 0.0, 0.0),
                         fixation="fixed")
    w = res.wave_vertex_sphere
    k1, k2, _, _ = w.principal()
    n = lens.material.n_d
    th = math.radians(tilt)
    sp = s * (1 + math.sin(th) ** 2 / (2 * n))
    # Martin's formula is approximate (thin lens, small angles): agreement to ~2 %
    assert k1[0] == pytest.approx(sp, rel=0.02)
    assert k2[0] - k1[0] == pytest.approx(sp * math.tan(th) ** 2, rel=0.1)


def test_bundle_helper_sees_a_plain_spherical_wave():
    # sanity of the brute-force helper itself: no lens, a point at 0.5 m -> K = -2 I
    kxx, kxy, kyy, _ = bundle_vergence(None, np.array([0.0, 0.0, -0.5]),
                                       np.array([0.0, 0.0, 1.0]), True, np.zeros(3),
                                       np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]),
                                       radius=1e-5)
    assert (kxx, kxy, kyy) == pytest.approx((-2.0, 0.0, -2.0), abs=1e-8)


def _thibos_defocus(wavelength_nm, reference_nm=587.56):
    """The chromatic eye's refractive error difference (D) between two wavelengths, from
    the published formula itself: R(lambda) = p - q / (lambda - c), lambda in um,
    p = 1.68524, q = 0.63346, c = 0.21410 (Thibos et al. 1992, Appl. Opt. 31:3594)."""
    p, q, c = 1.68524, 0.63346, 0.21410
    r = lambda wl: p - q / (wl / 1000.0 - c)  # noqa: E731
    return r(wavelength_nm) - r(reference_nm)


@pytest.mark.parametrize("wl, arcmin", [(486.13, 6.52), (656.27, 2.72)])
def test_analysis_shows_the_eyes_own_chromatic_blur(wl, arcmin):
    """A relaxed emmetrope (no accommodation), 6 mm pupil, looking at infinity: at the F
    and C lines the retinal blur is the chromatic defocus times the pupil radius,
    |Delta R| r_p (6.52' and 2.72'), within 1 %; at the d line it vanishes."""
    eye = Eye(accommodation_max=0.0, pupil_diameter=6e-3)
    obj = ObjectPoints.from_angles([np.inf], [0.0], [0.0])
    want = abs(_thibos_defocus(wl)) * 3e-3 * 180 / math.pi * 60
    assert want == pytest.approx(arcmin, abs=0.005)
    for lens in (None, SpectacleLens.from_rx(Prescription(0.0))):
        res = analyze_points(eye, lens, obj, wavelength_nm=wl, accommodation=0.0)
        maj, mnr, _ = res.blur_axes()
        assert res.to_arcmin(maj)[0] == pytest.approx(want, rel=0.01)
        assert res.to_arcmin(mnr)[0] == pytest.approx(want, rel=0.01)
    res = analyze_points(eye, None, obj, wavelength_nm=587.56)
    assert res.blur_axes()[0][0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("wl", [486.13, 656.27])
def test_analysis_and_the_rendered_channel_field_agree(wl):
    """Through a dispersive (polycarbonate) lens, the render's per-channel blur field
    (accommodation taken from the reference wavelength's field, the eye's LCA applied) and
    the analysis at that wavelength agree voxel by voxel. Not to 1e-9 as at one wavelength:
    a voxel takes the accommodation of the reference field's source in that voxel, a
    world point the lens's dispersion moves slightly from this channel's source."""
    from eyelab.blur import VoxelStatus, compute_blur_field

    eye = Eye.from_rx(Prescription(-2.5, -0.75, 20), accommodation_max=2.0,
                      pupil_diameter=5e-3)
    lens = SpectacleLens.from_rx(Prescription(-2.5, -0.75, 20), material="polycarbonate")
    shape = (12, 4, 5)
    ref = compute_blur_field(eye, lens, shape=shape)
    acc = np.where(ref.status == VoxelStatus.OK, ref.accommodation, np.nan)
    f = compute_blur_field(eye, lens, camera=ref.camera, shape=shape, wavelength_nm=wl,
                           accommodation=acc)
    ok = (f.status == VoxelStatus.OK) & (ref.status == VoxelStatus.OK)
    assert ok.mean() > 0.95
    res = analyze_points(eye, lens, ObjectPoints.from_positions(f.sources[ok]),
                         wavelength_nm=wl)
    assert (res.status == 0).all()
    maj, _, _ = res.blur_axes()
    got = res.to_arcmin(maj)
    assert got.max() > 1.0                               # the LCA blur is there
    np.testing.assert_allclose(f.accommodation[ok], res.accommodation, atol=1e-4)
    np.testing.assert_allclose(f.major_arcmin[ok], got, rtol=2e-4, atol=1e-4)


def test_two_eyes_accommodate_once_whatever_the_wavelength():
    """Through dispersive (polycarbonate) lenses the two eyes' shared accommodation is the
    reference wavelength's at any analysis wavelength, as for one eye; the blur differs."""
    import eyelab

    spec = {"eye": {"rx": "-6.00 DS", "age": 20}, "lens": {"material": "polycarbonate"},
            "binocular": {"pd_mm": 64},
            "points": [{"distance_m": 0.5, "field_deg": [0, 0]}]}
    acc = {}
    for wl in (587.56, 450.0):
        rep = eyelab.analyze({**spec, "analysis": {"wavelength_nm": wl}})
        acc[wl] = rep["points"][0]["accommodation_d"]
    assert acc[450.0] == pytest.approx(acc[587.56], abs=1e-9)
    one = eyelab.analyze({k: v for k, v in spec.items() if k != "binocular"}
                         | {"analysis": {"wavelength_nm": 450.0}})
    assert one["points"][0]["accommodation_d"] == pytest.approx(acc[450.0], abs=0.01)
