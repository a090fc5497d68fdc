"""Perspective cameras and their normalized device coordinates (NDC), OpenGL conventions.

A camera looks along ``forward`` from ``position``; eye-space depth w > 0 in front.
NDC: x, y in [-1, 1] across the frustum; z_ndc = (f + n)/(f - n) - 2 f n / ((f - n) w),
which is -1 at the near plane and +1 at the far plane. z_ndc is affine in 1/w, so slices
uniform in NDC z are uniform in dioptric distance from the camera's centre of projection.

The virtual camera behind a spectacle lens (Kakimoto 2007 §3.1) is the least-squares point
closest to the refracted rays leaving the lens, looking along their mean direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_range
from eyelab.core.errors import SpecError


@dataclass(frozen=True)
class Camera:
    """Perspective camera.

    position : (3,) m; forward, up : (3,) (orthonormalised); fov_y_deg : vertical field of
    view in (1, 170) deg; aspect : width / height; near, far : m, 0 < near < far;
    center : (2,) off-axis shift of the frustum centre in NDC units (0 = symmetric).
    """

    position: tuple = (0.0, 0.0, 0.0)
    forward: tuple = (0.0, 0.0, -1.0)
    up: tuple = (0.0, 1.0, 0.0)
    fov_y_deg: float = 60.0
    aspect: float = 4.0 / 3.0
    near: float = 0.05
    far: float = 100.0

    def __post_init__(self):
        check_range("camera.fov_y_deg", self.fov_y_deg, 1.0, 170.0)
        check_range("camera.aspect", self.aspect, 0.05, 20.0)
        check_range("camera.near", self.near, 1e-4, 1e6)
        if not self.far > self.near:
            raise SpecError("camera.far", f"must be > near ({self.near}), got {self.far}")

    @property
    def basis(self):
        """(right, up, forward) unit vectors, (3, 3) rows."""
        f = np.asarray(self.forward, float)
        f = f / np.linalg.norm(f)
        r = np.cross(f, np.asarray(self.up, float))
        r = r / np.linalg.norm(r)
        u = np.cross(r, f)
        return np.stack([r, u, f])

    @property
    def tan_half(self):
        t = math.tan(math.radians(self.fov_y_deg) / 2)
        return t * self.aspect, t

    def depth(self, points):
        """Eye-space depth w (m) of world points (n, 3)."""
        return (np.asarray(points, float) - self.position) @ self.basis[2]

    def world_to_ndc(self, points):
        """(n, 3) world -> (n, 3) NDC (x, y, z)."""
        rel = np.asarray(points, float) - np.asarray(self.position, float)
        b = self.basis
        xe, ye, w = rel @ b[0], rel @ b[1], rel @ b[2]
        tx, ty = self.tan_half
        n, f = self.near, self.far
        with np.errstate(divide="ignore", invalid="ignore"):
            zn = (f + n) / (f - n) - 2 * f * n / ((f - n) * w)
            return np.stack([xe / (w * tx), ye / (w * ty), zn], -1)

    def ndc_z_to_depth(self, zn):
        n, f = self.near, self.far
        return 2 * f * n / ((f + n) - (f - n) * np.asarray(zn, float))

    def depth_to_ndc_z(self, w):
        n, f = self.near, self.far
        return (f + n) / (f - n) - 2 * f * n / ((f - n) * np.asarray(w, float))

    def ray_directions(self, ndc_x, ndc_y):
        """Unit world directions from the centre of projection through NDC (x, y)."""
        tx, ty = self.tan_half
        b = self.basis
        x = np.asarray(ndc_x, float)[..., None]
        y = np.asarray(ndc_y, float)[..., None]
        d = x * tx * b[0] + y * ty * b[1] + b[2]
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def ndc_to_world(self, ndc):
        ndc = np.asarray(ndc, float)
        w = self.ndc_z_to_depth(ndc[..., 2])
        tx, ty = self.tan_half
        b = self.basis
        return (np.asarray(self.position, float) + (ndc[..., 0] * tx * w)[..., None] * b[0]
                + (ndc[..., 1] * ty * w)[..., None] * b[1] + w[..., None] * b[2])

    def projection_matrix(self):
        """4x4 OpenGL projection (eye space -> clip space)."""
        tx, ty = self.tan_half
        n, f = self.near, self.far
        return np.array([[1 / tx, 0, 0, 0], [0, 1 / ty, 0, 0],
                         [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)], [0, 0, -1, 0]])


def eye_camera(fov_y_deg=60.0, aspect=4 / 3, near=0.05, far=100.0) -> Camera:
    """The naked eye's camera: centre of projection at the pupil centre, looking along -z."""
    return Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), fov_y_deg, aspect,
                  near, far)


def gaze_camera(gaze_deg=(0.0, 0.0), rotation_centre: float = 0.0135, fov_y_deg=60.0,
                aspect=4 / 3, near=0.05, far=100.0) -> Camera:
    """The eye camera of an eye turned by ``gaze_deg`` = (right, up) degrees about its
    centre of rotation, ``rotation_centre`` (m) behind the pupil in primary gaze (the
    pupil at the origin, looking along -z): the line of sight (Fick angles: azimuth, then
    elevation; no torsion about it) is f = (cos e sin a, sin e, -cos e cos a), the pupil
    moves to C + r f with C = (0, 0, r), and the camera looks along f from there. (0, 0) is
    :func:`eye_camera` exactly.

    >>> gaze_camera((0.0, -30.0)).position[1] < 0     # looking down: the pupil moves down
    True
    """
    a, e = (math.radians(float(v)) for v in gaze_deg)
    f = np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])
    centre = np.array([0.0, 0.0, rotation_centre])
    pos = centre + rotation_centre * f
    pos = np.where(np.abs(pos) < 1e-15, 0.0, pos)
    up = np.array([0.0, 1.0, 0.0]) if abs(e) < 1e-12 else \
        np.array([-math.sin(e) * math.sin(a), math.cos(e), math.sin(e) * math.cos(a)])
    return Camera(tuple(float(v) for v in pos), tuple(float(v) for v in f),
                  tuple(float(v) for v in up), fov_y_deg, aspect, near, far)


def least_squares_point(origins, directions, dtype=np.float64):
    """Point minimising the sum of squared distances to the lines (origins, directions).

    Solves sum_i (I - d_i d_i^T) c = sum_i (I - d_i d_i^T) o_i (Kakimoto 2007 §3.1) in
    ``dtype`` (float32 only to study the normal equations' conditioning).
    Returns (c (3,), rms distance (m)).
    """
    origins = np.asarray(origins, dtype)
    directions = np.asarray(directions, dtype)
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    proj = np.eye(3, dtype=dtype)[None] - d[:, :, None] * d[:, None, :]
    a = proj.sum(0)
    b = np.einsum("nij,nj->i", proj, origins)
    c = np.linalg.solve(a, b)
    res = np.einsum("nij,nj->ni", proj, c - origins)
    return c, float(np.sqrt(np.mean(np.sum(res**2, axis=1))))


@dataclass(frozen=True)
class VirtualCamera:
    """A camera fitted to the rays leaving a lens, with its fit quality."""

    camera: Camera
    rms_line_distance: float
    lens_points: np.ndarray      # (m, 3) back-surface points the fit used
    out_points: np.ndarray       # (m, 3) where those rays leave the front surface
    out_dirs: np.ndarray         # (m, 3)


def fit_virtual_camera(lens, eye_cam: Camera, *, wavelength_nm=587.56, samples=33,
                       margin=1.02) -> VirtualCamera:
    """Fit the virtual camera that sees, from behind the lens, what ``eye_cam`` sees through it.

    Rays from the eye camera's centre of projection on a ``samples`` x ``samples`` NDC grid
    are reverse-traced through the lens; those that pass it are kept. The centre of
    projection is their least-squares point, the forward direction their mean direction,
    and the frustum the smallest one centred on it that contains every outgoing ray (times
    ``margin``). Near/far planes are the eye camera's.
    """
    g = np.linspace(-1.0, 1.0, samples)
    gx, gy = np.meshgrid(g, g)
    dirs = eye_cam.ray_directions(gx.ravel(), gy.ravel())
    o = np.broadcast_to(np.asarray(eye_cam.position, float), dirs.shape)
    res = lens.trace(o, dirs, wavelength_nm, reverse=True)
    ok = res["status"] == 0
    if ok.sum() < 3:
        raise SpecError("lens", "the lens is not in the eye camera's view")
    q, d = res["out_points"][ok], res["out_dirs"][ok]
    c, rms = least_squares_point(q, d)
    fwd = d.mean(0)
    fwd /= np.linalg.norm(fwd)
    cam0 = Camera(tuple(c), tuple(fwd), eye_cam.up, 60.0, 1.0, eye_cam.near, eye_cam.far)
    b = cam0.basis
    rel = (q + d * 10.0) - c  # far along each ray: its direction from the COP
    tx = np.max(np.abs(rel @ b[0]) / (rel @ b[2])) * margin
    ty = np.max(np.abs(rel @ b[1]) / (rel @ b[2])) * margin
    fov = math.degrees(2 * math.atan(ty))
    cam = Camera(tuple(c), tuple(fwd), eye_cam.up, fov, tx / ty, eye_cam.near, eye_cam.far)
    return VirtualCamera(cam, rms, res["hit1"].points[ok], q, d)


def fit_window(cam: Camera, width: int) -> tuple:
    """(camera, (w, h)): an integer window ``width`` pixels wide for ``cam``, with the
    camera's aspect set to exactly w / h so that VTK and eyelab project alike."""
    import dataclasses

    h = max(16, int(round(width / cam.aspect)))
    return dataclasses.replace(cam, aspect=width / h), (width, h)


def lens_view_density(lens, eye_cam: Camera, vcam: Camera, eye_width_px: int, *,
                      wavelength_nm=587.56, samples=33, distance_m=10.0) -> float | None:
    """How densely a virtual camera ``vcam`` must sample to resolve what ``eye_cam`` (an image
    ``eye_width_px`` wide) sees through the lens: the smallest, over the lens as seen in
    the view, of the smallest singular value of d(vcam pixel) / d(eye pixel) for a vcam
    image 1 pixel wide — so that a vcam image ``k / density`` pixels wide has at least k
    of its pixels per eye pixel in every direction everywhere on the lens. Eye rays on a
    ``samples`` x ``samples`` NDC grid are reverse-traced through the lens (as
    :func:`fit_virtual_camera` does) to points ``distance_m`` along the leaving rays,
    projected into ``vcam``; each grid cell whose four corners pass gives the local
    Jacobian by finite differences. The lens's magnification and distortion both show in
    it (a plus lens magnifies: denser). None when fewer than one cell passes."""
    g = np.linspace(-1.0, 1.0, samples)
    gx, gy = np.meshgrid(g, g)
    dirs = eye_cam.ray_directions(gx.ravel(), gy.ravel())
    o = np.broadcast_to(np.asarray(eye_cam.position, float), dirs.shape)
    res = lens.trace(o, dirs, wavelength_nm, reverse=True)
    ok = (res["status"] == 0).reshape(samples, samples)
    ndc = np.full((samples * samples, 2), np.nan)
    good = ok.ravel()
    p = res["out_points"][good] + distance_m * res["out_dirs"][good]
    ndc[good] = vcam.world_to_ndc(p)[:, :2]
    ndc = ndc.reshape(samples, samples, 2)
    cell = ok[:-1, :-1] & ok[1:, :-1] & ok[:-1, 1:] & ok[1:, 1:]
    if not cell.any():
        return None
    step = g[1] - g[0]
    # d(vcam ndc) / d(eye ndc), averaged over each cell's two edges per axis
    dx = 0.5 * (ndc[:-1, 1:] - ndc[:-1, :-1] + ndc[1:, 1:] - ndc[1:, :-1]) / step
    dy = 0.5 * (ndc[1:, :-1] - ndc[:-1, :-1] + ndc[1:, 1:] - ndc[:-1, 1:]) / step
    jac = np.stack([dx[cell], dy[cell]], -1)           # (m, 2 vcam axes, 2 eye axes)
    # to pixels: vcam 1 px wide (height 1 / aspect), eye W x H px (NDC spans 2 units)
    scale_v = np.array([0.5, 0.5 / vcam.aspect])[:, None]
    scale_e = np.array([2.0, 2.0 * eye_cam.aspect])[None, :] / eye_width_px
    from eyelab.core.vecmath import svd2x2

    s = svd2x2(jac * scale_v * scale_e)[1][..., 1]
    return float(s.min())
