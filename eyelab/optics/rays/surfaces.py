"""Surface shapes: sag, gradient, Hessian, normal and principal curvatures.

A surface is described in its own local frame: vertex at the origin, z along the
optical axis in the direction light travels, sag ``z = f(x, y)``. Curvature is stored,
not radius, so a plane is curvature 0. A positive curvature means the centre of
curvature lies on the +z side (the usual optical sign convention for light travelling
+z): a surface of curvature c has power (n_after - n_before) * c at its vertex.

Shape only: refraction and materials live in :mod:`eyelab.optics.rays.trace`.

Every method takes ``x, y : (n,) float, metres`` and is vectorised. Points outside a
surface's domain (e.g. beyond the hemisphere of a sphere) give NaN sag and
``valid == False``; callers handle them through the status masks of the tracer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from eyelab.core.errors import SpecError

#: The axes a toric's section can be swept about (its "revolve"; a lens's "torus").
REVOLVE_AXES = ("x", "y")


@dataclass(frozen=True)
class SagDerivatives:
    """Sag and its first and second partial derivatives at points (each (n,) float)."""

    z: np.ndarray
    zx: np.ndarray
    zy: np.ndarray
    zxx: np.ndarray
    zxy: np.ndarray
    zyy: np.ndarray
    valid: np.ndarray

    def normal(self) -> np.ndarray:
        """(n, 3) unit normal (-zx, -zy, 1)/w, pointing +z."""
        w = np.sqrt(1.0 + self.zx**2 + self.zy**2)
        return np.stack([-self.zx / w, -self.zy / w, 1.0 / w], axis=-1)

    def curvature_form(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(hxx, hxy, hyy): the Hessian divided by w = sqrt(1 + |grad f|^2).

        For a unit tangent vector t = (tx, ty, tz) of the surface, the normal curvature
        along t (w.r.t. the +z normal) is (tx, ty) [[hxx, hxy], [hxy, hyy]] (tx, ty)^T:
        the second fundamental form of a graph is II_ij = f_ij / w and t's (x, y)
        components are its coordinates in the basis (r_x, r_y).
        """
        w = np.sqrt(1.0 + self.zx**2 + self.zy**2)
        return self.zxx / w, self.zxy / w, self.zyy / w


class Surface:
    """Base class: subclasses implement :meth:`derivatives`."""

    #: Curvature (1/m) of the osculating sphere used to seed ray intersection.
    seed_curvature: float = 0.0

    def derivatives(self, x, y) -> SagDerivatives:  # pragma: no cover - abstract
        raise NotImplementedError

    def sag(self, x, y) -> np.ndarray:
        return self.derivatives(x, y).z

    def normal(self, x, y) -> np.ndarray:
        return self.derivatives(x, y).normal()

    def principal_curvatures(self, x, y):
        """Principal curvatures and directions.

        Returns
        -------
        k1, k2 : (n,) float, 1/m, k1 >= k2, w.r.t. the +z normal
        d1, d2 : (n, 3) float, unit principal directions in the local frame
        """
        d = self.derivatives(np.atleast_1d(x), np.atleast_1d(y))
        nrm = d.normal()
        hxx, hxy, hyy = d.curvature_form()
        t1 = np.stack([np.ones_like(d.zx), np.zeros_like(d.zx), d.zx], axis=-1)
        t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
        t2 = np.cross(nrm, t1)
        a = _quad(t1, t1, hxx, hxy, hyy)
        b = _quad(t1, t2, hxx, hxy, hyy)
        c = _quad(t2, t2, hxx, hxy, hyy)
        k1, k2, cos_t, sin_t = sym2_eig(a, b, c)
        d1 = cos_t[:, None] * t1 + sin_t[:, None] * t2
        d2 = np.cross(nrm, d1)
        return k1, k2, d1, d2


def _quad(a, b, hxx, hxy, hyy):
    return hxx * a[..., 0] * b[..., 0] + hxy * (a[..., 0] * b[..., 1] + a[..., 1] * b[..., 0]) \
        + hyy * a[..., 1] * b[..., 1]


def sym2_eig(a, b, c):
    """Eigen-decomposition of symmetric 2x2 matrices [[a, b], [b, c]], closed form.

    Returns ``(l1, l2, cos, sin)`` with l1 >= l2 and (cos, sin) the unit eigenvector of l1.
    Stable at a == c, b == 0 (any direction is principal; (1, 0) is returned), no NaN.
    """
    m = 0.5 * (a + c)
    h = 0.5 * (a - c)
    r = np.hypot(h, b)
    theta = 0.5 * np.arctan2(b, h)
    return m + r, m - r, np.cos(theta), np.sin(theta)


@dataclass(frozen=True)
class Asphere(Surface):
    """Even asphere: z = c r^2 / (1 + sqrt(1 - (1+k) c^2 r^2)) + sum_i A_{2i} r^{2i}.

    Parameters
    ----------
    curvature : float
        Vertex curvature c (1/m). 0 gives a plane (plus polynomial terms).
    conic : float
        Conic constant k (0 sphere, -1 paraboloid, < -1 hyperboloid, > 0 oblate).
    coefficients : tuple of float
        A4, A6, A8, ... in m^(1-2i) (polynomial in metres).
    """

    curvature: float = 0.0
    conic: float = 0.0
    coefficients: tuple = field(default_factory=tuple)

    @property
    def seed_curvature(self) -> float:
        return float(self.curvature)

    def derivatives(self, x, y) -> SagDerivatives:
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        c, k = self.curvature, self.conic
        r2 = x * x + y * y
        with np.errstate(invalid="ignore"):
            q = np.sqrt(1.0 - (1.0 + k) * c * c * r2)
            z = c * r2 / (1.0 + q)
            fr_over_r = c / q            # f'(r)/r, finite at r = 0
            frr = c / q**3               # f''(r)
        valid = q > 0.0
        for i, a in enumerate(self.coefficients, start=2):
            p = 2 * i
            z = z + a * r2**i
            fr_over_r = fr_over_r + p * a * r2 ** (i - 1)
            frr = frr + p * (p - 1) * a * r2 ** (i - 1)
        # Hessian of a radial function: f'' rr^T + (f'/r)(I - rr^T); written without 1/r.
        diff = frr - fr_over_r
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # x x / r^2 etc. stay within [0, 1] even where r^2 is subnormal and 1 / r^2
            # overflows (the products then are 0 x inf; diff is ~0 there anyway)
            inv_r2 = np.where(r2 > 1e-200, 1.0 / np.where(r2 > 1e-200, r2, 1.0), 0.0)
        zxx = fr_over_r + diff * x * x * inv_r2
        zyy = fr_over_r + diff * y * y * inv_r2
        zxy = diff * x * y * inv_r2
        return SagDerivatives(z, fr_over_r * x, fr_over_r * y, zxx, zxy, zyy, valid)


def Sphere(curvature: float) -> Asphere:
    """A sphere of curvature ``curvature`` (1/m)."""
    return Asphere(float(curvature))


def Plane() -> Asphere:
    return Asphere(0.0)


@dataclass(frozen=True)
class Toric(Surface):
    """Toric (torus) surface with vertex curvatures along two perpendicular directions.

    In the surface's own axes (x', y'), rotated by ``axis`` from the local x axis
    (counter-clockwise seen from +z looking back, i.e. in the x-y plane with x right and
    y up), the curvature along x' is ``curvature_x`` and along y' is ``curvature_y``.

    ``revolve`` chooses which of the two tori with these vertex curvatures:

    * ``"y"``: the circle of curvature ``curvature_y`` in the y'-z plane is revolved about an
      axis parallel to y' at z = 1/curvature_x ("tyre" or "barrel" depending on signs).
      Sections y' = const are circles; the x' curvature varies with y'.
    * ``"x"``: the same with the roles of x' and y' exchanged.

    Sag (revolve ``"y"``): with the profile z_p(y') = c_y y'^2 / (1 + sqrt(1 - c_y^2 y'^2)) and
    the local sweep curvature c'(y') = c_x / (1 - c_x z_p), z = z_p + c' x'^2 /
    (1 + sqrt(1 - c'^2 x'^2)); cancellation-free, finite for c_x = 0 (a cylinder).
    """

    curvature_x: float = 0.0
    curvature_y: float = 0.0
    axis: float = 0.0  # radians
    revolve: str = "y"

    def __post_init__(self):
        if self.revolve not in REVOLVE_AXES:
            raise SpecError("toric.revolve", f"must be 'x' or 'y', got {self.revolve!r}")

    @property
    def seed_curvature(self) -> float:
        return 0.5 * (self.curvature_x + self.curvature_y)

    def derivatives(self, x, y) -> SagDerivatives:
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        ca, sa = np.cos(self.axis), np.sin(self.axis)
        xp = ca * x + sa * y
        yp = -sa * x + ca * y
        if self.revolve == "y":
            d = _torus_derivs(xp, yp, self.curvature_x, self.curvature_y)
            gx, gy, hxx, hxy, hyy = d[1], d[2], d[3], d[4], d[5]
        else:  # swap roles: revolve about an axis parallel to x'
            d = _torus_derivs(yp, xp, self.curvature_y, self.curvature_x)
            gx, gy, hxx, hxy, hyy = d[2], d[1], d[5], d[4], d[3]
        # back to local axes: grad = R^T grad', H = R^T H' R with R = [[ca, sa], [-sa, ca]]
        zx = ca * gx - sa * gy
        zy = sa * gx + ca * gy
        zxx = ca * ca * hxx - 2 * ca * sa * hxy + sa * sa * hyy
        zyy = sa * sa * hxx + 2 * ca * sa * hxy + ca * ca * hyy
        zxy = ca * sa * (hxx - hyy) + (ca * ca - sa * sa) * hxy
        return SagDerivatives(d[0], zx, zy, zxx, zxy, zyy, d[6])


def _torus_derivs(x, y, cs, cp):
    """Sag and derivatives of a torus: profile curvature cp along y, revolved about an axis
    parallel to y at z = 1/cs (curvature cs along x at y = 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        qp = np.sqrt(1.0 - cp * cp * y * y)
        zp = cp * y * y / (1.0 + qp)
        zp1 = cp * y / qp
        zp2 = cp / qp**3
        c = cs / (1.0 - cs * zp)
        c_y = c * c * zp1
        c_yy = 2.0 * c * c_y * zp1 + c * c * zp2
        x2 = x * x
        q = np.sqrt(1.0 - c * c * x2)
        g = c * x2 / (1.0 + q)
        g_x = c * x / q
        g_xx = c / q**3
        g_c = x2 / (q * (1.0 + q))
        g_xc = x / q**3
        g_cc = c * x2 * x2 * (1.0 + 2.0 * q) / (q**3 * (1.0 + q) ** 2)
    valid = (qp > 0) & (q > 0) & np.isfinite(c)
    z = zp + g
    return (z, g_x, zp1 + g_c * c_y, g_xx, g_xc * c_y, zp2 + g_cc * c_y**2 + g_c * c_yy, valid)


class FreeForm(Surface):
    """A free-form surface from a sag grid: the interpolating tensor-product B-spline
    (scipy's ``RectBivariateSpline``, no smoothing; quintic by default, ``degree = 3`` for
    bicubic) through z[j, i] at (x[i], y[j]), with its exact first and second derivatives
    (sampled from a sphere or torus on a 41 x 41 grid over 64 mm, the quintic's
    curvatures are within 4e-7 of the surface's; the bicubic's 2e-4), so normals and
    principal
    curvatures are defined everywhere on the grid's rectangle and every part of the engine
    (exact ray tracing, wavefront tracing, blur fields, lens meshes) can use it. Outside
    the rectangle the sag is NaN and ``valid`` False (a miss, as beyond a sphere's
    hemisphere).

    x : (nx,) increasing, metres; y : (ny,) increasing, metres (at least degree + 1
    each); z : (ny, nx) sag in metres, the vertex at (0, 0) normally (z(0, 0) = 0).
    """

    def __init__(self, x, y, z, degree: int = 5):
        from scipy.interpolate import RectBivariateSpline

        x = np.asarray(x, float)
        y = np.asarray(y, float)
        z = np.asarray(z, float)
        if degree not in (3, 5):
            raise SpecError("surface.degree", f"must be 3 or 5, got {degree!r}")
        if x.ndim != 1 or y.ndim != 1 or len(x) <= degree or len(y) <= degree:
            raise SpecError("surface.grid", f"a degree-{degree} free-form grid needs at least "
                                            f"{degree + 1} x {degree + 1} points")
        if z.shape != (len(y), len(x)):
            raise SpecError("surface.sag", f"must be (ny, nx) = ({len(y)}, {len(x)}), got "
                                           f"{z.shape}")
        if not (np.all(np.diff(x) > 0) and np.all(np.diff(y) > 0)):
            raise SpecError("surface.grid", "grid coordinates must increase")
        if not np.all(np.isfinite(z)):
            raise SpecError("surface.sag", "sag values must be finite")
        self.x, self.y, self.z = x, y, z
        for a in (self.x, self.y, self.z):
            a.flags.writeable = False
        # RectBivariateSpline takes z[i, j] at (x[i], y[j])
        self.degree = degree
        self._spline = RectBivariateSpline(x, y, z.T, kx=degree, ky=degree, s=0)

    def __repr__(self):
        from eyelab.core.cache import array_digest

        mm = [round(float(v) * 1e3, 3) for v in (self.x[0], self.x[-1], self.y[0], self.y[-1])]
        return (f"FreeForm({len(self.x)}x{len(self.y)} grid, x [{mm[0]:g}, {mm[1]:g}], "
                f"y [{mm[2]:g}, {mm[3]:g}] mm, sag {array_digest(self.z)[:12]})")

    @property
    def content_key(self) -> str:
        from eyelab.core.cache import array_digest

        return array_digest(np.concatenate([self.x, self.y, self.z.ravel(), [self.degree]]))

    @property
    def seed_curvature(self) -> float:
        d = self.derivatives(np.zeros(1), np.zeros(1))
        return float(0.5 * (d.zxx[0] + d.zyy[0])) if d.valid[0] else 0.0

    def derivatives(self, x, y) -> SagDerivatives:
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        shape = np.broadcast(x, y).shape
        x, y = (np.broadcast_to(a, shape).ravel() for a in (x, y))
        valid = ((x >= self.x[0]) & (x <= self.x[-1]) & (y >= self.y[0]) & (y <= self.y[-1])
                 & np.isfinite(x) & np.isfinite(y))
        xs, ys = np.where(valid, x, 0.0), np.where(valid, y, 0.0)
        ev = self._spline.ev
        out = [ev(xs, ys, dx=dx, dy=dy) for dx, dy in ((0, 0), (1, 0), (0, 1), (2, 0),
                                                         (1, 1), (0, 2))]
        out = [np.where(valid, o, np.nan).reshape(shape) for o in out]
        return SagDerivatives(*out, valid.reshape(shape))

    @classmethod
    def from_surface(cls, surface: Surface, half_width: float, n: int = 41,
                     degree: int = 5) -> FreeForm:
        """The free-form sampling of another surface on an n x n grid over the square of
        side 2 ``half_width`` (m) — a tool to test the free-form path against exact
        shapes."""
        g = np.linspace(-half_width, half_width, n)
        gx, gy = np.meshgrid(g, g)
        return cls(g, g, surface.sag(gx, gy), degree)
