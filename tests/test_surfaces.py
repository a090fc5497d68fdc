import numpy as np
import pytest

from eyelab.optics.rays.surfaces import Asphere, Plane, Sphere, Toric

SURFACES = [
    Sphere(8.0), Sphere(-12.0), Plane(), Asphere(6.0, -0.7, (3.0, -50.0)),
    Toric(5.0, 9.0, 0.4, "y"), Toric(-5.0, 9.0, 1.2, "x"), Toric(0.0, 7.0, 0.3),
    Toric(11.0, 4.0, 2.0, "x"),
]


@pytest.mark.parametrize("s", SURFACES, ids=repr)
def test_derivatives_match_finite_differences(s):
    # central differences, h = 1e-5 m: truncation ~h^2 f''' ~ 1e-8, round-off ~1e-16/h^2 z
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-0.025, 0.025, (2, 200))
    h = 1e-5
    d = s.derivatives(x, y)
    fx = (s.sag(x + h, y) - s.sag(x - h, y)) / (2 * h)
    fy = (s.sag(x, y + h) - s.sag(x, y - h)) / (2 * h)
    np.testing.assert_allclose(d.zx, fx, atol=1e-8)
    np.testing.assert_allclose(d.zy, fy, atol=1e-8)
    dxp, dxm = s.derivatives(x + h, y), s.derivatives(x - h, y)
    dyp, dym = s.derivatives(x, y + h), s.derivatives(x, y - h)
    np.testing.assert_allclose(d.zxx, (dxp.zx - dxm.zx) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(d.zyy, (dyp.zy - dym.zy) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(d.zxy, (dyp.zx - dym.zx) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(d.zxy, (dxp.zy - dxm.zy) / (2 * h), atol=1e-6)


def test_sphere_sag_and_curvature_everywhere():
    c = 10.0
    r = 1 / c
    x = np.linspace(-0.04, 0.04, 41)
    y = 0.3 * x
    np.testing.assert_allclose(Sphere(c).sag(x, y), r - np.sqrt(r * r - x * x - y * y),
                               atol=1e-15)
    k1, k2, _, _ = Sphere(c).principal_curvatures(x, y)
    np.testing.assert_allclose(k1, c, rtol=1e-12)
    np.testing.assert_allclose(k2, c, rtol=1e-12)


def test_torus_orientations_share_vertex_curvatures_but_differ_off_axis():
    a, b = Toric(6.0, 10.0, 0.0, "y"), Toric(6.0, 10.0, 0.0, "x")
    for s in (a, b):
        k1, k2, d1, _ = s.principal_curvatures(np.array([0.0]), np.array([0.0]))
        assert (k1[0], k2[0]) == pytest.approx((10.0, 6.0))
        assert abs(d1[0, 1]) == pytest.approx(1.0)  # the 10 /m curvature lies along y
    # revolve "y": sections y = const are circles about the same axis, so the x curvature
    # at height y is c_x / (1 - c_x z_p(y)) (exact torus geometry)
    y0 = 0.02
    zp = Sphere(10.0).sag(0.0, y0)
    d = a.derivatives(np.array([0.0]), np.array([y0]))
    assert d.zxx[0] == pytest.approx(6.0 / (1 - 6.0 * zp), rel=1e-12)
    assert b.derivatives(np.array([0.0]), np.array([y0])).zxx[0] != pytest.approx(d.zxx[0])


def test_outside_domain_is_flagged_not_nan_silently():
    d = Sphere(50.0).derivatives(np.array([0.0, 0.03]), np.array([0.0, 0.0]))
    assert d.valid.tolist() == [True, False]
