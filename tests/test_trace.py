import numpy as np
import pytest

from eyelab.optics.rays.surfaces import Plane, Sphere, Toric
from eyelab.optics.rays.trace import PlacedSurface, Status, intersect, refract

I3 = np.eye(3)


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_sphere_intersection_matches_closed_form():
    c = 20.0  # centre at z = 0.05
    ps = PlacedSurface(Sphere(c), I3, np.zeros(3))
    rng = np.random.default_rng(2)
    o = np.column_stack([rng.uniform(-0.01, 0.01, (100, 2)), np.full(100, -0.02)])
    d = unit(np.column_stack([rng.uniform(-0.2, 0.2, (100, 2)), np.ones(100)]))
    hit = intersect(ps, o, d)
    centre = np.array([0, 0, 1 / c])
    np.testing.assert_allclose(np.linalg.norm(hit.points - centre, axis=1), 1 / c, atol=1e-15)
    np.testing.assert_allclose(hit.normals, unit(centre - hit.points), atol=1e-12)
    assert (hit.status == 0).all()


def test_toric_newton_intersection_lies_on_surface():
    s = Toric(7.0, 12.0, 0.5, "x")
    ps = PlacedSurface(s, I3, np.array([0.001, 0.0, 0.0]))
    rng = np.random.default_rng(3)
    o = np.column_stack([rng.uniform(-0.02, 0.02, (200, 2)), np.full(200, -0.03)])
    d = unit(np.column_stack([rng.uniform(-0.3, 0.3, (200, 2)), np.ones(200)]))
    hit = intersect(ps, o, d)
    local = hit.points - ps.translation
    np.testing.assert_allclose(local[:, 2], s.sag(local[:, 0], local[:, 1]), atol=1e-13)
    # the hit lies on the ray
    t = np.einsum("ij,ij->i", hit.points - o, d)
    np.testing.assert_allclose(hit.points, o + t[:, None] * d, atol=1e-13)


def test_aperture_and_miss_status():
    ps = PlacedSurface(Sphere(30.0), I3, np.zeros(3), aperture_radius=0.01)
    o = np.array([[0.0, 0.0, -0.01], [0.015, 0.0, -0.01], [0.0, 0.0, -0.01]])
    d = unit([[0, 0, 1], [0, 0, 1], [1, 0, 0.01]])  # third ray nearly parallel: misses
    st = intersect(ps, o, d).status
    assert st.tolist() == [0, Status.MISSED, Status.MISSED]


def test_snell_law_and_tir():
    n = np.array([[0.0, 0.0, 1.0]] * 3)
    ang = np.radians([0.0, 30.0, 60.0])
    d = np.column_stack([np.sin(ang), np.zeros(3), np.cos(ang)])
    out, _, _, _, st = refract(d, n, 1.0 / 1.5)
    sin_out = np.hypot(out[:, 0], out[:, 1])
    np.testing.assert_allclose(1.0 * np.sin(ang), 1.5 * sin_out, atol=1e-15)
    # glass -> air beyond the critical angle (41.8 deg)
    out, _, _, _, st = refract(d, n, 1.5)
    assert st.tolist() == [0, 0, Status.TIR]
    assert np.isfinite(out).all()


def test_plane_parallel_plate_lateral_shift():
    # textbook: shift = t sin(i - r) / cos r
    t, nl = 0.004, 1.6
    front = PlacedSurface(Plane(), I3, np.array([0, 0, -t]))
    back = PlacedSurface(Plane(), I3, np.zeros(3))
    i = np.radians(25.0)
    d = np.array([[np.sin(i), 0.0, np.cos(i)]])
    h1 = intersect(front, np.array([[0.0, 0.0, -0.01]]), d)
    d1, *_ = refract(d, h1.normals, 1 / nl)
    h2 = intersect(back, h1.points, d1)
    d2, *_ = refract(d1, h2.normals, nl)
    np.testing.assert_allclose(d2, d, atol=1e-15)
    r = np.arcsin(np.sin(i) / nl)
    straight = h1.points + (t / np.cos(i)) * d
    shift = np.linalg.norm(np.cross(h2.points - straight, d))
    assert shift == pytest.approx(t * np.sin(i - r) / np.cos(r), rel=1e-12)


def test_grazing_refraction_at_the_critical_angle_is_flagged_and_finite():
    nl = 1.5
    crit = np.arcsin(1 / nl)
    ang = np.array([crit - 1e-9, crit, crit + 1e-9])
    d = np.column_stack([np.sin(ang), np.zeros(3), np.cos(ang)])
    out, _, _, cos_t, st = refract(d, np.array([[0.0, 0.0, 1.0]] * 3), nl)
    assert np.isfinite(out).all() and np.isfinite(cos_t).all()
    assert st[0] in (0, Status.GRAZING)          # 1e-9 rad inside: cos_t ~ 5e-5
    assert st[1] in (Status.GRAZING, Status.TIR)  # exactly critical (rounding decides)
    assert st[2] == Status.TIR
    # the wavefront refraction divides by cos_t: the clamp keeps it finite
    from eyelab.optics.rays.wavefront import Wavefront

    ps = PlacedSurface(Sphere(10.0), I3, np.zeros(3))
    hit = intersect(ps, np.zeros((3, 3)) - [0, 0, 0.001], d)
    wf = Wavefront.spherical(d, 0.3).refract(hit, nl)
    assert np.isfinite(np.concatenate([wf.k11, wf.k12, wf.k22])).all()


def test_steep_surface_hit_from_any_start_and_never_behind():
    """A steep concave front (base curve -20 D): a ray from 1 m away traces exactly as the
    same ray started 2 cm or 100 m before the lens (the root of the sphere's far side was
    taken from far away, and the ray MISSED); a lens behind a ray's origin is missed."""
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.lens.spectacle import SpectacleLens
    from eyelab.optics.rays.trace import FATAL

    lens = SpectacleLens.from_rx(Prescription(-3.0), base_curve=-20.0)
    xy = np.array([[0.0, 0.0], [0.01, 0.005], [-0.008, 0.006]])
    d = np.tile([0.0, 0.0, 1.0], (3, 1))
    outs = []
    for z0 in (-0.02, -1.014, -100.0):
        r = lens.trace(np.column_stack([xy, np.full(3, z0)]), d, 587.56)
        assert not np.any(r["status"] & np.uint8(FATAL))
        outs.append((r["out_points"], r["out_dirs"]))
    for p, q in outs[1:]:
        np.testing.assert_allclose(p, outs[0][0], atol=1e-12)
        np.testing.assert_allclose(q, outs[0][1], atol=1e-12)
    behind = lens.trace(np.column_stack([xy, np.full(3, 0.05)]), d, 587.56)
    assert np.all(behind["status"] & np.uint8(FATAL))
