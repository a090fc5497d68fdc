"""The forward wave of a line of sight through a spectacle lens and a schematic eye, and its
image through focus: what a lens with two images (a lenslet lens's carrier and lenslets)
puts on the retina.

Rays leave the object for a square grid of points on the lens's front surface (without a
lens, on the plane across the eye's axis at the corneal vertex) about the chief ray's
entry, each carrying the light of its grid cell (a distant object lights the lens
evenly), and are traced exactly through the lens and the eye; those that cross the stop
inside it reach the retina. Their optical paths, summed from the object (at infinity, from
a plane across its direction), are taken to the exit pupil's reference sphere — about the
chief ray's retinal point R, through the exit pupil's centre on the chief ray — and the
chief ray's path less each is the wave aberration W (ANSI Z80.28's sign: positive where the
wave leads). Over the exit pupil a ray's amplitude is sqrt(J), J the exit pupil's area per
unit of sampled area (central differences over the grid within each ray's own zone — the
carrier, or one lenslet — so that none straddles a lenslet's rim).

Through focus (Fraunhofer): the field at R with the retina moved to where a wave ``v``
dioptres more converging at the entrance pupil focuses is sum(sqrt(J) exp(i k (W - v
|xi|^2 m^2 / 2))) over the exit pupil's points xi, m = r_EP / r_XP (a wave's second-order
coefficient is the same over the entrance and the exit pupil once scaled by their radii);
its intensity over the aberration-free one, (sum sqrt(J))^2, is ``axial``. A lenslet's
image focuses in front of the retina: its peak lies near v = the lenslet's add at the
eye. This is the forward wave, which a lenslet's pencil needs: the reversed one
(:mod:`eyelab.optics.chain.retinal_wave`) understates its vergence by several per cent.
"""

from __future__ import annotations

import numpy as np

from eyelab.core.vecmath import any_tangent, cross, dot
from eyelab.optics.chain.retinal_rays import _trace_path, retina_points
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays
from eyelab.optics.rays.trace import FATAL, intersect

#: The auxiliary chief ray's angle (rad) that finds the exit pupil (where a chief ray in
#: the vitreous crosses the eye's axis).
XP_PROBE = 0.01


def exit_pupil_z(eye: SchematicEye, accommodation: float, wavelength_nm: float) -> float:
    """The exit pupil's distance (m) behind the corneal vertex along the eye's axis: where a
    chief ray at :data:`XP_PROBE` rad, in the vitreous, meets the axis."""
    rot, vertex = np.eye(3), np.zeros(3)
    d = np.array([[np.sin(XP_PROBE), 0.0, np.cos(XP_PROBE)]])
    r, v, _ = retina_points(eye, rot, vertex, d, accommodation, wavelength_nm)
    return float(r[0, 2] - r[0, 0] * v[0, 2] / v[0, 0])


#: Samples across a beam's footprint, and the footprint's sampled square in pupil radii.
BEAM_GRID = 160
BEAM_MARGIN = 1.5


def forward_wave(eye: SchematicEye, lens, rot, vertex, objects: ObjectPoints, i: int,
                 accommodation: float, *, wavelength_nm: float,
                 grid: int = BEAM_GRID) -> dict:
    """Line of sight ``i``'s forward wave (module doc). Rays leave the object for a square
    grid of points (``grid`` across :data:`BEAM_MARGIN` entrance-pupil radii about the chief
    ray) on the lens's front surface, or without a lens on the plane across the eye's axis
    at the corneal vertex; each carries its cell's light; those that cross the stop inside
    it reach the retina. Returns {"grid_xy" (m, 2) the sampled points (their plane's x, y,
    m), "xi" (m, 2) their exit-pupil points (m, across the chief ray, along "basis" (2,
    3)), "opd" (m,) m, "amplitude" (m,) sqrt(J), "ok" (m,) through the stop to the retina,
    "zone" (m,) the lenslet each ray passes (-1: the carrier), "m" (r_EP / r_XP),
    "wavelength_nm", "radius" (m) the reference sphere's, "n_vitreous"}."""
    one = ObjectPoints(objects.direction[i:i + 1], objects.distance[i:i + 1])
    z_ep, _ = eye.entrance_pupil(accommodation, wavelength_nm)
    pupil = vertex + rot @ np.array([0.0, 0.0, z_ep])
    chief = find_chief_rays(lens, pupil, one, wavelength_nm)
    if lens is None:
        frame_r, frame_t = rot, np.asarray(vertex, float)
        start0 = pupil - chief.dir_out[0] * z_ep
        sag = lambda x, y: np.zeros_like(x)  # noqa: E731
    else:
        front, _ = lens.placed_surfaces()
        frame_r, frame_t = np.asarray(front.rotation), np.asarray(front.translation)
        start0 = chief.entry[0]
        sag = front.surface.sag
    centre = (start0 - frame_t) @ frame_r
    r_ep = eye.pupil_diameter / 2
    c = (np.arange(grid) + 0.5) / grid * 2 - 1
    gx, gy = np.meshgrid(centre[0] + BEAM_MARGIN * r_ep * c,
                         centre[1] + BEAM_MARGIN * r_ep * c)
    gxy = np.stack([gx.ravel(), gy.ravel()], -1)
    local = np.stack([gxy[:, 0], gxy[:, 1], sag(gxy[:, 0], gxy[:, 1])], -1)
    f = _trace_forward(eye, lens, rot, vertex, one, local @ frame_r.T + frame_t,
                       accommodation, wavelength_nm)
    c0 = _trace_forward(eye, lens, rot, vertex, one, start0[None], accommodation,
                        wavelength_nm)
    if not c0["ok"][0]:
        raise ValueError("the chief ray of this line of sight does not reach the retina")
    r0, d0 = c0["retina"][0], c0["dirs"][0]
    z_xp = exit_pupil_z(eye, accommodation, wavelength_nm)
    ax = rot[:, 2]
    rho = abs(((vertex + z_xp * ax - r0) @ ax) / (d0 @ ax))
    x, dd = f["retina"], f["dirs"]
    b = dot(dd, x - r0)
    cc = np.sum((x - r0) ** 2, axis=1) - rho * rho
    t = -b - np.sqrt(np.maximum(b * b - cc, 0.0))               # back to the sphere
    opd = f["path"] + f["n_vitreous"] * t
    ref = c0["path"][0] - f["n_vitreous"] * rho
    on = x + t[:, None] * dd
    on0 = r0 - rho * d0
    e1 = any_tangent(d0[None])[0]
    e2 = cross(d0[None], e1[None])[0]
    xi = np.stack([(on - on0) @ e1, (on - on0) @ e2], -1)
    zone = (np.full(len(gxy), -1) if lens is None or not lens.has_lenslets
            else lens.front.which(gxy[:, 0], gxy[:, 1]))
    ok = f["ok"]
    amp = np.sqrt(_area_ratio(gxy, xi, zone, ok))
    rs = eye.stop_radius(accommodation, wavelength_nm)
    edge = ok & (zone < 0) & (f["stop_r"] > 0.5 * rs)
    m_xp = float(np.median(np.hypot(*xi[edge].T) / f["stop_r"][edge])) if edge.any() else 1.0
    return {"grid_xy": gxy, "xi": xi, "opd": np.where(ok, ref - opd, np.nan),
            "amplitude": amp, "ok": ok, "zone": zone, "m": r_ep / (m_xp * rs),
            "wavelength_nm": wavelength_nm, "basis": np.stack([e1, e2]), "radius": rho,
            "n_vitreous": float(f["n_vitreous"])}


def _trace_forward(eye, lens, rot, vertex, one: ObjectPoints, points, accommodation,
                   wavelength_nm) -> dict:
    """Rays from the object ``one`` to world ``points`` (on the lens's front, or before the
    eye) traced through the lens and the eye: optical paths to the retina, retinal points
    and directions, how far from the stop's centre they cross its plane (m), and which
    pass the stop to the retina."""
    points = np.atleast_2d(np.asarray(points, float))
    if one.finite[0]:
        obj = one.positions()[0]
        d = points - obj
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        path = np.linalg.norm(points - obj, axis=1)
    else:
        d = np.broadcast_to(-one.direction[0], points.shape).copy()
        path = -(points @ one.direction[0])
    st = np.zeros(len(points), np.uint8)
    start = points
    if lens is not None:
        res = lens.trace(points - 1e-6 * d, d, wavelength_nm)
        nl = lens.material.n(wavelength_nm)
        path = path + nl * np.linalg.norm(res["out_points"] - res["hit1"].points, axis=1)
        start, d, st = res["out_points"], res["out_dirs"], res["status"]
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    o, dd, s2, inner = _trace_path(placed, n, ((0, 0, 1), (1, 1, 2)), start, d)
    stop = vertex + rot @ np.array([0.0, 0.0, eye.stop_z(accommodation)])
    ax = np.broadcast_to(rot[:, 2], dd.shape)
    q = o + (dot(stop - o, ax) / dot(dd, ax))[:, None] * dd - stop
    stop_r = np.hypot(q @ rot[:, 0], q @ rot[:, 1])
    o, dd, s3, rest = _trace_path(placed, n, ((2, 2, 3), (3, 3, 4)), o, dd)
    h = intersect(placed[4], o, dd)
    path = path + inner + rest + n[4] * np.linalg.norm(h.points - o, axis=1)
    ok = (((st | s2 | s3 | h.status) & np.uint8(FATAL)) == 0) & (
        stop_r <= eye.stop_radius(accommodation, wavelength_nm))
    return {"path": path, "retina": h.points, "dirs": dd, "stop_r": stop_r, "ok": ok,
            "n_vitreous": n[4]}


def _area_ratio(xy, xi, zone, ok) -> np.ndarray:
    """J (m,): the exit pupil's area per unit of sampled area at each lattice point ``xy``,
    by central (else one-sided) differences along the lattice within the point's own zone
    (no difference across a lenslet's rim)."""
    step = np.min(np.diff(np.unique(np.round(xy[:, 0], 12))))
    ix = np.round((xy - xy.min(0)) / step).astype(int)
    size = int(ix.max()) + 1
    g = np.full((size + 2, size + 2, 2), np.nan)
    z = np.full((size + 2, size + 2), -3)
    g[ix[:, 1] + 1, ix[:, 0] + 1] = np.where(ok[:, None], xi, np.nan)
    z[ix[:, 1] + 1, ix[:, 0] + 1] = np.where(ok, zone, -2)

    def deriv(axis):
        gp, gm = np.roll(g, -1, axis), np.roll(g, 1, axis)
        zp, zm = np.roll(z, -1, axis), np.roll(z, 1, axis)
        sp, sm = (zp == z)[..., None], (zm == z)[..., None]
        return np.where(sp & sm, (gp - gm) / 2, np.where(sp, gp - g, np.where(sm, g - gm,
                                                                             np.nan))) / step

    dx, dy = deriv(1), deriv(0)
    jac = np.abs(dx[..., 0] * dy[..., 1] - dx[..., 1] * dy[..., 0])
    out = jac[ix[:, 1] + 1, ix[:, 0] + 1]
    return np.where(np.isfinite(out), out, 1.0)


def through_focus(wave: dict, vergences_d) -> dict:
    """``axial`` (list): the intensity at R over the aberration-free one at each of
    ``vergences_d`` (module doc)."""
    ok = wave["ok"]
    k = 2.0 * np.pi / (wave["wavelength_nm"] * 1e-9)
    a = wave["amplitude"][ok]
    w = wave["opd"][ok]
    r2 = np.sum(wave["xi"][ok] ** 2, axis=1) * wave["m"] ** 2
    norm = a.sum() ** 2
    axial = [float(np.abs(np.sum(a * np.exp(1j * k * (w - 0.5 * v * r2)))) ** 2 / norm)
             for v in vergences_d]
    return {"vergence_d": [float(v) for v in vergences_d], "axial": axial}


def focus_peaks(tf: dict, floor: float = 0.2) -> list:
    """The through-focus curve's local maxima above ``floor`` of its highest, as
    [vergence (D), axial intensity] in order of vergence (the carrier's image, the
    lenslets')."""
    v, a = np.asarray(tf["vergence_d"]), np.asarray(tf["axial"])
    top = a.max()
    peaks = [[float(v[j]), float(a[j])] for j in range(len(a))
             if a[j] >= floor * top and (j == 0 or a[j] >= a[j - 1])
             and (j == len(a) - 1 or a[j] >= a[j + 1])]
    return peaks
