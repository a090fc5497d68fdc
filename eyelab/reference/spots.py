"""The retinal image of a point, by forward rays: a truth for the renderers' blur that does
not share their way of finding rays.

The renderers go backwards (from a line of sight's retinal point out through points of
the stop, found by Newton's method). Here rays go forwards: from the object point to a
fine square grid over a disc a little larger than the eye's entrance pupil, through the
spectacle lens (if any; a ray that misses it goes on straight), the cornea and the aqueous
to the stop's plane, where the iris keeps those inside it, then on through the
crystalline lens to the retina. Each ray carries its grid cell's light (a distant point
lights the pupil's plane evenly). Retinal points are turned into the image's pixel
coordinates by inverting the chief rays' landing map (the lines of sight's retinal
points, :func:`~eyelab.optics.chain.retinal_rays.retina_points`) about the point's own
pixel, to first order (its Jacobian by central differences of whole pixels).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import unit
from eyelab.optics.chain.retinal_rays import camera_frame, retina_points
from eyelab.optics.rays.trace import FATAL, intersect, refract


def point_spot(eye, lens, view, point, accommodation: float, wavelength_nm: float, *,
               grid: int = 160, reference_nm: float | None = None) -> dict:
    """The spot of the world ``point`` (3,) seen by the schematic ``eye`` (behind ``lens``
    or none) in ``view``'s retinal image, the eye at ``accommodation`` (D):

    px : (n, 2) the rays' landings in pixels (x right, y down, from the image's top-left
    corner; pixel i's centre at i + 0.5); weight : (n,) their light; centroid (2,) px;
    cov (2, 2) px^2 (about the centroid); chief (2,) px, the pixel of the point's naked
    line of sight (the camera's projection; through a lens the image lies elsewhere)."""
    from eyelab.optics.eye.thin import EYE_REFERENCE_NM

    ref_nm = EYE_REFERENCE_NM if reference_nm is None else reference_nm
    cam = view.camera(eye.rotation_centre)
    rot, vertex = camera_frame(cam)
    w, h = view.width, view.height
    point = np.asarray(point, float)
    ndc = cam.world_to_ndc(point[None])[0, :2]
    chief = np.array([(ndc[0] + 1) * w / 2, (1 - ndc[1]) * h / 2])

    def landing_map(at):
        """(retinal point of the line of sight at pixel ``at``, its Jacobian (3, 2) per
        pixel): lines of sight 1 px apart."""
        offs = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]], float)
        px = at + offs
        dirs = -cam.ray_directions(2 * px[:, 0] / w - 1, 1 - 2 * px[:, 1] / h)
        r_pts, _, _ = retina_points(eye, rot, vertex, dirs, accommodation, ref_nm)
        return r_pts[0], np.stack([(r_pts[1] - r_pts[2]) / 2, (r_pts[3] - r_pts[4]) / 2], -1)

    # forward rays from the point through a grid over the entrance pupil's plane
    z_ep, _ = eye.entrance_pupil(accommodation, wavelength_nm)
    r_ep = eye.pupil_diameter / 2
    axis = rot[:, 2]
    centre = vertex + axis * z_ep
    half = 1.4 * r_ep / max(abs(float(np.dot(axis, unit((centre - point)[None])[0]))), 0.2)
    u = np.linspace(-half, half, grid)
    gx, gy = np.meshgrid(u, u)
    targets = centre + gx.reshape(-1, 1) * rot[:, 0] + gy.reshape(-1, 1) * rot[:, 1]
    d = targets - point
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(point, d.shape).copy()
    ok = np.ones(len(d), bool)
    weight = np.ones(len(d))
    if lens is not None:
        r2 = lens.trace(o, d, wavelength_nm)
        through = (r2["status"] & np.uint8(FATAL)) == 0
        o = np.where(through[:, None], r2["out_points"], o)
        d = np.where(through[:, None], r2["out_dirs"], d)
        weight = np.where(through, r2["transmittance"], 1.0)
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    with np.errstate(invalid="ignore", divide="ignore"):
        for i, n1, n2 in ((0, 0, 1), (1, 1, 2)):
            hit = intersect(placed[i], o, d)
            d, _, _, _, st = refract(d, hit.normals, n[n1] / n[n2])
            o = hit.points
            ok &= ((hit.status | st) & np.uint8(FATAL)) == 0
        stop = vertex + axis * eye.stop_z(accommodation)
        s = ((stop - o) @ axis) / (d @ axis)
        q = o + s[:, None] * d - stop
        r_stop = eye.stop_radius(accommodation, ref_nm)
        ok &= np.hypot(q @ rot[:, 0], q @ rot[:, 1]) <= r_stop
        for i, n1, n2 in ((2, 2, 3), (3, 3, 4)):
            hit = intersect(placed[i], o, d)
            d, _, _, _, st = refract(d, hit.normals, n[n1] / n[n2])
            o = hit.points
            ok &= ((hit.status | st) & np.uint8(FATAL)) == 0
        hit = intersect(placed[4], o, d)
        ok &= ((hit.status & np.uint8(FATAL)) == 0) & np.all(np.isfinite(hit.points), axis=1)
    wgt = weight[ok]
    # the map linearised about the chief pixel, then again about the spot's centroid (a
    # lens's prism can move the image far from the naked line of sight)
    at = chief
    for _ in range(3):
        r0, jac = landing_map(at)
        sol, *_ = np.linalg.lstsq(jac, (hit.points[ok] - r0).T, rcond=None)   # (2, n) px
        spot = at + sol.T
        c = (spot * wgt[:, None]).sum(0) / wgt.sum()
        if np.hypot(*(c - at)) < 0.5:
            break
        at = c
    dev = spot - c
    cov = (dev[:, :, None] * dev[:, None, :] * wgt[:, None, None]).sum(0) / wgt.sum()
    return {"px": spot, "weight": wgt, "centroid": c, "cov": cov, "chief": chief,
            "rays": int(ok.sum())}
