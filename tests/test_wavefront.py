import numpy as np
import pytest

from eyelab.optics.rays.surfaces import Sphere, Toric
from eyelab.optics.rays.trace import PlacedSurface, Status, intersect
from eyelab.optics.rays.wavefront import Wavefront


def test_spherical_wave_transfer_is_exact():
    # a point source at 0.5 m seen after a further 0.25 m is a point source at 0.75 m
    wf = Wavefront.spherical(np.array([[0.0, 0.0, 1.0]]), 0.5).transfer(0.25)
    assert wf.k11[0] == pytest.approx(-1 / 0.75, rel=1e-15)
    assert wf.k22[0] == pytest.approx(-1 / 0.75, rel=1e-15)


def test_flat_wavefront_stays_flat():
    wf = Wavefront.spherical(np.array([[0.0, 0.6, 0.8]]), np.inf).transfer(123.0)
    assert (wf.k11[0], wf.k12[0], wf.k22[0]) == (0.0, 0.0, 0.0)


def test_astigmatic_transfer_matches_eq1_per_meridian_in_any_basis():
    wf = Wavefront.spherical(np.array([[0.0, 0.0, 1.0]]), np.inf)
    th = 0.3
    c, s = np.cos(th), np.sin(th)
    k1, k2 = 4.0, -2.5
    wf.k11 = np.array([c * c * k1 + s * s * k2])
    wf.k22 = np.array([s * s * k1 + c * c * k2])
    wf.k12 = np.array([c * s * (k1 - k2)])
    wf.transfer(0.1)
    p1, p2, e1, _ = wf.principal()
    assert p1[0] == pytest.approx(k1 / (1 - 0.1 * k1), rel=1e-13)
    assert p2[0] == pytest.approx(k2 / (1 - 0.1 * k2), rel=1e-13)
    t2 = np.cross(wf.N, wf.t1)
    assert abs(e1[0] @ (c * wf.t1[0] + s * t2[0])) == pytest.approx(1.0, abs=1e-12)


def test_focal_crossing_is_flagged_and_finite():
    wf = Wavefront.spherical(np.array([[0.0, 0.0, 1.0]] * 2), np.array([np.inf, np.inf]))
    wf.k11 = np.array([10.0, 10.0])
    wf.k22 = np.array([10.0, 3.0])
    wf.transfer(np.array([0.1, 0.1]))  # exactly at the focus of the 10 /m meridian
    assert np.isfinite(wf.k11).all() and np.isfinite(wf.k22).all()
    assert (wf.status & Status.FOCAL).tolist() == [Status.FOCAL, Status.FOCAL]
    # past the focus the wave diverges with the right curvature: k = 10 / (1 - 0.2*10)
    wf2 = Wavefront.spherical(np.array([[0.0, 0.0, 1.0]]), np.inf)
    wf2.k11 = wf2.k22 = np.array([10.0])
    wf2.transfer(0.2)
    assert wf2.k11[0] == pytest.approx(-10.0)


def test_normal_incidence_refraction_is_the_vergence_formula():
    # n2 k' = n1 k + (n2 - n1) c at a sphere (paraxial vergence equation, exact on axis)
    n1, n2, c = 1.0, 1.5, 8.0
    ps = PlacedSurface(Sphere(c), np.eye(3), np.zeros(3))
    d = np.array([[0.0, 0.0, 1.0]])
    hit = intersect(ps, np.array([[0.0, 0.0, -1.0]]), d)
    wf = Wavefront.spherical(d, 0.5).refract(hit, n1 / n2)
    assert wf.k11[0] == pytest.approx((n1 * -2.0 + (n2 - n1) * c) / n2, rel=1e-14)
    assert wf.k12[0] == pytest.approx(0.0, abs=1e-14)


def test_normal_incidence_on_toric_gives_principal_powers():
    ps = PlacedSurface(Toric(4.0, 10.0, 0.7), np.eye(3), np.zeros(3))
    d = np.array([[0.0, 0.0, 1.0]])
    hit = intersect(ps, np.array([[0.0, 0.0, -1.0]]), d)
    wf = Wavefront.spherical(d, np.inf).refract(hit, 1 / 1.5)
    k1, k2, e1, _ = wf.principal()
    assert (k1[0] * 1.5, k2[0] * 1.5) == pytest.approx((0.5 * 10, 0.5 * 4), rel=1e-13)
    # the strong meridian is the toric's y' axis: (-sin 0.7, cos 0.7)
    assert abs(e1[0, :2] @ [-np.sin(0.7), np.cos(0.7)]) == pytest.approx(1.0, abs=1e-12)


def test_umbilic_and_zero_curvature_give_no_nan():
    wf = Wavefront.spherical(np.array([[0.0, 0.0, 1.0]] * 2), np.array([np.inf, 2.0]))
    k1, k2, e1, e2 = wf.principal()
    assert np.isfinite(np.concatenate([k1, k2, e1.ravel(), e2.ravel()])).all()
