"""Exact traces through a spectacle lens and a schematic eye to its curved retina.

For each line of sight: the real chief ray (through the centre of the eye's stop, found by
Newton's method), where it lands on the retina, and the wave along it (generalised
Coddington equations, Kakimoto 2007 Eq. 1-5, through every surface of lens and eye). The
refraction at each retinal point is found the way an eye's far point is defined: a point
source on the retina, its wave traced out of the eye (reversibility); the vergence the eye
needs there, less the vergence the object's wave arrives with through the lens, is the
refraction error E (D), taken where the chief ray crosses the corneal vertex plane (in air,
between lens and eye). Its power vector (Thibos, Wheeler & Horner 1997): M = (E_xx + E_yy)/2,
J0 = (E_xx - E_yy)/2, J45 = E_xy in the eye's (x: wearer's right, y: up) frame; its
tangential and sagittal parts are E along and across the meridian of the field point.
Negative M is myopic: a naked myope's far-point vergence, or a lens that corrects too
little minus.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.core.vecmath import cross, dot
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays
from eyelab.optics.rays.trace import FATAL, Status, intersect, refract
from eyelab.optics.rays.wavefront import Wavefront

#: Newton's iterations for the chief ray through the stop, and its tolerance (m).
AIM_MAX_ITER = 30
AIM_TOL = 1e-13
#: Outer iterations that make a chief ray from a given object point pass the stop.
OBJECT_MAX_ITER = 40


@dataclass
class RetinalTrace:
    """Per line of sight (n rows; SI units unless the name says otherwise).

    field_deg : (n, 2) the chief ray's direction in the air before the eye, as the angles
        (x: toward the wearer's right, y: up) of the object seen from the eye
    eccentricity_deg, meridian_deg : (n,) the same as an angle from the eye's axis and the
        meridian (counter-clockwise from the wearer's right, seen from behind)
    retina : (n, 3) where the chief ray lands, in the eye's frame (m)
    object_points : ObjectPoints the lines of sight are of (through the lens)
    accommodation : (n,) the model's accommodation used (D)
    refraction : (n, 3) (E_xx, E_xy, E_yy) D, the refraction error matrix (module doc)
    m, j0, j45, tangential, sagittal : (n,) D
    image_vergence : (n, 2) the wave's tangential and sagittal vergences just behind the
        eye's last surface, n_vitreous k (D)
    focus : (n, 2) where the tangential and sagittal focal lines lie along the chief ray,
        behind the retina (m; negative: in front of it, a myopic line)
    entry, entry_dir : (n, 3) where the chief ray meets the lens's front surface (the
        corneal vertex plane without a lens) and its direction there (world)
    eye_dir : (n, 3) the chief ray's direction in the air before the eye (world, into it)
    status : (n,) uint8 (:class:`~eyelab.optics.rays.trace.Status`)
    """

    field_deg: np.ndarray
    eccentricity_deg: np.ndarray
    meridian_deg: np.ndarray
    retina: np.ndarray
    object_points: ObjectPoints
    accommodation: np.ndarray
    refraction: np.ndarray
    m: np.ndarray
    j0: np.ndarray
    j45: np.ndarray
    tangential: np.ndarray
    sagittal: np.ndarray
    image_vergence: np.ndarray
    focus: np.ndarray
    entry: np.ndarray
    entry_dir: np.ndarray
    eye_dir: np.ndarray
    status: np.ndarray

    @property
    def ok(self):
        return (self.status & np.uint8(FATAL)) == 0


def eye_in_world(eye: SchematicEye, fixation: str, gaze):
    """(rotation (3, 3), corneal vertex (3,)) of the eye: fixed — looking along the world's
    +z from the origin; rotating — turned about its centre of rotation (Listing's law: the
    smallest rotation from the primary position) so that its axis runs along ``gaze``, the
    unit direction of the light entering it."""
    if fixation == "fixed":
        return np.eye(3), np.zeros(3)
    g = np.asarray(gaze, float) / np.linalg.norm(gaze)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, g)
    s, c = np.linalg.norm(axis), float(g @ z)
    if s < 1e-15:
        rot = np.eye(3)
    else:
        k = axis / s
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        rot = np.eye(3) + s * kx + (1 - c) * kx @ kx
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    return rot, cor - eye.rotation_centre * g


def _through_cornea(placed, n, origins, dirs):
    """Rays in air through the two corneal surfaces: (points, directions, status) in the
    aqueous."""
    st = np.zeros(len(origins), np.uint8)
    o, d = origins, dirs
    for i in (0, 1):
        h = intersect(placed[i], o, d)
        d, _, _, _, s = refract(d, h.normals, n[i] / n[i + 1])
        o, st = h.points, st | h.status | s
    return o, d, st


def aim_at_stop(eye: SchematicEye, rot, vertex, dirs, accommodation,
                wavelength_nm: float = EYE_REFERENCE_NM):
    """Points (n, 3) on the eye's entrance-pupil plane (world) through which rays of the
    given world directions (n, 3) in air pass the centre of the stop (the stop moves with
    ``accommodation``, D, scalar or (n,)); and a status (n,) with NOT_CONVERGED where
    Newton's method did not reach :data:`AIM_TOL`."""
    dirs = np.atleast_2d(np.asarray(dirs, float))
    acc = np.broadcast_to(np.asarray(accommodation, float), (len(dirs),))
    points = np.zeros(dirs.shape)
    status = np.zeros(len(dirs), np.uint8)
    for a in np.unique(acc):
        rows = np.flatnonzero(acc == a)
        points[rows], status[rows] = _aim(eye, rot, vertex, dirs[rows], float(a),
                                          wavelength_nm)
    return points, status


def _aim(eye, rot, vertex, dirs, accommodation, wavelength_nm):
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    z_ep, _ = eye.entrance_pupil(accommodation, wavelength_nm)
    stop = vertex + rot @ np.array([0.0, 0.0, eye.stop_z(accommodation)])
    normal = np.broadcast_to(rot[:, 2], dirs.shape)
    ex, ey = rot[:, 0], rot[:, 1]
    centre = vertex + rot @ np.array([0.0, 0.0, z_ep])

    def miss(ab):
        p = centre + ab[:, :1] * ex + ab[:, 1:] * ey
        o, d, st = _through_cornea(placed, n, p - dirs * 0.05, dirs)
        s = dot(stop - o, normal) / dot(d, normal)
        q = o + s[:, None] * d - stop
        return np.stack([q @ ex, q @ ey], -1), st

    ab = np.zeros((len(dirs), 2))
    h = 1e-7
    for _ in range(AIM_MAX_ITER):
        r, st = miss(ab)
        if np.all(np.abs(r) < AIM_TOL):
            break
        jx = (miss(ab + [h, 0.0])[0] - miss(ab - [h, 0.0])[0]) / (2 * h)
        jy = (miss(ab + [0.0, h])[0] - miss(ab - [0.0, h])[0]) / (2 * h)
        jac = np.stack([jx, jy], -1)                      # (n, 2, 2): d r / d (a, b)
        ab = ab - np.linalg.solve(jac, r[..., None])[..., 0]
    r, st = miss(ab)
    st = st | np.where(np.any(np.abs(r) >= 1e3 * AIM_TOL, axis=1),
                       np.uint8(Status.NOT_CONVERGED), np.uint8(0))
    return centre + ab[:, :1] * ex + ab[:, 1:] * ey, st


def _object_ray(lens, points, dirs, wavelength_nm):
    """The object-side ray of eye-side rays (world points, directions travelling into the
    eye): (origin on the lens's front or the point, unit direction toward the object,
    the lens's trace dict or None)."""
    if lens is None:
        return points, -dirs, None
    res = lens.trace(points, -dirs, wavelength_nm, reverse=True)
    return res["out_points"], res["out_dirs"], res


def _object_at(q, w, distance):
    """Points on the rays q + s w (s > 0) at ``distance`` (n,) from the world origin; the
    direction w where the distance is infinite."""
    fin = np.isfinite(distance)
    b = dot(q, w)
    c = dot(q, q) - np.where(fin, distance, 0.0) ** 2
    s = -b + np.sqrt(np.maximum(b * b - c, 0.0))
    return np.where(fin[:, None], q + s[:, None] * w, w)


def trace_lines(eye: SchematicEye, lens, points, dirs, distance, *, rot, vertex,
                accommodation=None, wavelength_nm: float = EYE_REFERENCE_NM,
                status=None) -> RetinalTrace:
    """The chain for eye-side chief rays already aimed at the stop: world ``points`` (n, 3)
    on them and their directions ``dirs`` (n, 3) into the eye; objects at ``distance``
    (n,) m from the world origin along their object-side rays (inf: at infinity);
    ``accommodation`` (n,) D or None (each line its own: the accommodation whose paraxial
    refraction equals the mean vergence arriving along it); the eye placed by ``rot``,
    ``vertex``."""
    n_rows = len(points)
    status = np.zeros(n_rows, np.uint8) if status is None else status.copy()
    distance = np.broadcast_to(np.asarray(distance, float), (n_rows,))
    q, w, res = _object_ray(lens, points, dirs, wavelength_nm)
    obj = _object_at(q, w, distance)
    fin = np.isfinite(distance)
    rel = np.where(fin[:, None], obj, w)
    objects = ObjectPoints(rel / np.linalg.norm(rel, axis=1, keepdims=True),
                           np.where(fin, np.linalg.norm(obj, axis=1), np.inf))
    # the object's wave up to the eye-side ray
    if res is None:
        wave = Wavefront.spherical(dirs, np.where(fin, np.linalg.norm(obj - points, axis=1),
                                                  np.inf))
        start = points
    else:
        status |= res["status"]
        h_back, h_front = res["hit1"], res["hit2"]
        nl = lens.material.n(wavelength_nm)
        wave = Wavefront.spherical(-res["out_dirs"], np.where(
            fin, np.linalg.norm(obj - h_front.points, axis=1), np.inf))
        wave.refract(h_front, 1.0 / nl)
        wave.transfer(np.linalg.norm(h_back.points - h_front.points, axis=1))
        wave.refract(h_back, nl)
        start = h_back.points
    # the reference point: where the chief ray crosses the corneal vertex plane
    normal = np.broadcast_to(rot[:, 2], dirs.shape)
    ref = points + (dot(vertex - points, normal) / dot(dirs, normal))[:, None] * dirs
    wave.transfer(dot(ref - start, dirs))
    if accommodation is None:
        acc = np.asarray(eye.accommodation_for(0.5 * (wave.k11 + wave.k22), wavelength_nm))
        acc = np.where(np.isfinite(acc), acc, 0.0).reshape(n_rows)
    else:
        acc = np.broadcast_to(np.asarray(accommodation, float), (n_rows,))
    part = {"err": np.zeros((n_rows, 3)), "retina": np.zeros((n_rows, 3)),
            "image": np.zeros((n_rows, 2)), "focus": np.zeros((n_rows, 2))}
    for a in np.unique(acc):
        rows = np.flatnonzero(acc == a)
        got = _eye_part(eye, rot, vertex, float(a), wavelength_nm, ref[rows], dirs[rows],
                        _take(wave, rows))
        for k in part:
            part[k][rows] = got[k]
        status[rows] |= got["status"]
    entry = points if res is None else q
    return _result(rot, dirs, objects, acc, part, status, entry, -w)


def trace_field(eye: SchematicEye, lens, field_x_deg, field_y_deg, distance=np.inf, *,
                accommodation=None, wavelength_nm: float = EYE_REFERENCE_NM
                ) -> RetinalTrace:
    """Lines of sight of an eye looking straight ahead (fixed fixation) by the direction in
    which each chief ray enters the eye: the field angles (deg, broadcast; x toward the
    wearer's right, y up, as :meth:`ObjectPoints.from_angles`) of the object as the eye
    sees it, through the lens; objects at ``distance`` m. ``accommodation``: D, or None
    for the accommodation that focuses the straight-ahead object (the fixation)."""
    fx, fy, dist = np.broadcast_arrays(np.radians(np.asarray(field_x_deg, float)),
                                       np.radians(np.asarray(field_y_deg, float)),
                                       np.asarray(distance, float))
    toward = np.stack([np.tan(fx), np.tan(fy), -np.ones_like(fx)], -1).reshape(-1, 3)
    dirs = -toward / np.linalg.norm(toward, axis=1, keepdims=True)
    rot, vertex = eye_in_world(eye, "fixed", None)
    if accommodation is None:
        accommodation = float(fixation_accommodation(eye, lens, dist.ravel()[:1],
                                                     wavelength_nm)[0])
    points, st = aim_at_stop(eye, rot, vertex, dirs, float(accommodation), wavelength_nm)
    return trace_lines(eye, lens, points, dirs, dist.ravel(), rot=rot, vertex=vertex,
                       accommodation=accommodation, wavelength_nm=wavelength_nm, status=st)


def fixation_accommodation(eye: SchematicEye, lens, distance,
                           wavelength_nm: float = EYE_REFERENCE_NM, *, rot=None, vertex=None):
    """The accommodation (D, shaped like ``distance``) of an eye looking along its axis at
    an object at each ``distance`` (m from the world origin, on the axis's object-side ray
    through the lens): the one whose paraxial refraction equals the mean vergence arriving
    along the axis, which meets the stop's centre whatever the accommodation. The eye
    looks straight ahead from the origin unless ``rot``, ``vertex`` place it."""
    distance = np.atleast_1d(np.asarray(distance, float))
    if rot is None:
        rot, vertex = eye_in_world(eye, "fixed", None)
    out = np.zeros(distance.shape)
    for d in np.unique(distance):
        axis = trace_lines(eye, lens, np.asarray(vertex, float)[None], rot[:, 2][None],
                           np.array([d]), rot=rot, vertex=np.asarray(vertex, float),
                           wavelength_nm=wavelength_nm)
        out[distance == d] = axis.accommodation[0]
    return out


def _take(wave: Wavefront, rows) -> Wavefront:
    return Wavefront(wave.N[rows], wave.t1[rows], wave.k11[rows], wave.k12[rows],
                     wave.k22[rows], wave.status[rows])


def _eye_part(eye, rot, vertex, accommodation, wavelength_nm, ref, dirs, wave):
    """Through the eye and back out from the retina: {"err": the refraction error matrix
    (n, 3) as (E_uu, E_uv, E_vv) with u the eye's x across the ray, "retina": the retinal
    points in the eye's frame (n, 3), "image": the tangential and sagittal vergences
    (n, 2, D) behind the eye's last surface, "focus": their focal lines' distances behind
    the retina (n, 2, m), "status" (n,)}. ``wave`` arrives at ``ref`` along ``dirs``."""
    placed, n, _ = eye.placed(rot, vertex, accommodation, wavelength_nm)
    u = _across(rot[:, 0], dirs)
    arriving = np.stack(wave.in_basis(u), -1)
    o, d = ref, dirs
    hits, steps = [], []
    st = wave.status.copy()
    for i, ps in enumerate(placed):
        h = intersect(ps, o, d)
        step = dot(h.points - o, d)
        st |= h.status
        if i < len(placed) - 1:
            wave.transfer(step)
            wave.refract(h, n[i] / n[i + 1])
            d = wave.N
        if i == len(placed) - 2:                    # behind the eye's last surface
            ktt, _, kss = wave.in_basis(_meridional(rot, d))
            image = n[-1] * np.stack([ktt, kss], -1)
        hits.append(h)
        steps.append(step)
        o = h.points
    # the far point's wave: a point source on the retina, traced out (reversibility)
    back = Wavefront.spherical(-d, steps[-1])
    for i in range(len(placed) - 2, -1, -1):
        back.refract(hits[i], n[i + 1] / n[i])
        back.transfer(steps[i])                    # to the surface before, or to ref
    st |= wave.status | back.status
    kuu, kuv, kvv = back.in_basis(u)
    # the wave the eye needs: the outgoing one travelling the other way (curvatures change
    # sign; with v = N x u reversed too, the cross term keeps its sign)
    need = np.stack([-kuu, kuv, -kvv], -1)
    # the focal lines' distances behind the retina along the ray: 1/k - the vitreous path
    with np.errstate(divide="ignore"):
        focus = n[-1] / image - steps[-1][:, None]
    return {"err": need - arriving, "retina": (hits[-1].points - vertex) @ rot,
            "image": image, "focus": focus, "status": st}


def _across(x, dirs):
    """The unit vector (n, 3) across each ray nearest the eye's ``x`` (3,)."""
    u = x - dot(np.broadcast_to(x, dirs.shape), dirs)[:, None] * dirs
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _meridional(rot, dirs):
    """Unit vectors (n, 3) across each ray in the plane of the eye's axis and the ray (the
    tangential direction); along the eye's x on the axis."""
    axis = np.broadcast_to(rot[:, 2], dirs.shape)
    t = axis - dot(axis, dirs)[:, None] * dirs
    tn = np.linalg.norm(t, axis=1)
    on_axis = tn < 1e-12
    return np.where(on_axis[:, None], _across(rot[:, 0], dirs),
                    t / np.where(on_axis, 1.0, tn)[:, None])


def _result(rot, dirs, objects, acc, part, status, entry, entry_dir) -> RetinalTrace:
    local = dirs @ rot                              # directions in the eye's frame
    fx = np.degrees(np.arctan2(-local[:, 0], local[:, 2]))
    fy = np.degrees(np.arctan2(-local[:, 1], local[:, 2]))
    ecc = np.degrees(np.arccos(np.clip(local[:, 2], -1.0, 1.0)))
    mer = np.degrees(np.arctan2(-local[:, 1], -local[:, 0])) % 360.0
    mer = np.where(ecc < 1e-12, 0.0, mer)
    err = part["err"]
    euu, euv, evv = err[:, 0], err[:, 1], err[:, 2]
    # tangential and sagittal parts: E along and across the meridian
    u = _across(rot[:, 0], dirs)
    t = _meridional(rot, dirs)
    c, s = dot(t, u), dot(t, cross(dirs, u))
    tan = c * c * euu + 2 * c * s * euv + s * s * evv
    sag = s * s * euu - 2 * c * s * euv + c * c * evv
    bad = (status & np.uint8(FATAL)) != 0
    nan = lambda v: np.where(bad if np.ndim(v) == 1 else bad[:, None], np.nan, v)  # noqa: E731
    return RetinalTrace(
        field_deg=np.stack([fx, fy], -1), eccentricity_deg=ecc, meridian_deg=mer,
        retina=part["retina"], object_points=objects, accommodation=np.array(acc, float),
        refraction=nan(err), m=nan(0.5 * (euu + evv)), j0=nan(0.5 * (euu - evv)),
        j45=nan(euv), tangential=nan(tan), sagittal=nan(sag),
        image_vergence=nan(part["image"]), focus=nan(part["focus"]), entry=entry,
        entry_dir=entry_dir, eye_dir=np.array(dirs, float), status=status)


def trace_objects(eye: SchematicEye, lens, objects: ObjectPoints, *, fixation: str = "fixed",
                  accommodation=None, wavelength_nm: float = EYE_REFERENCE_NM
                  ) -> RetinalTrace:
    """The chain for object points (relative to the world origin, the corneal vertex of the
    eye looking straight ahead): the real chief ray from each object through ``lens`` (or
    none) and the centre of the eye's stop. ``fixation``: "fixed" — the eye looks along +z
    and sees the points off its axis; "rotating" — it turns about its centre of rotation
    toward each point (the chief ray then runs along its axis). ``accommodation``: D
    (scalar or (n,)), or None: the eye focuses the object on its axis at each point's
    distance (:func:`fixation_accommodation`; rotating, the point itself)."""
    if fixation == "rotating":
        cor = np.array([0.0, 0.0, eye.rotation_centre])
        chief = find_chief_rays(lens, cor, objects, wavelength_nm)
        acc = None if accommodation is None else np.broadcast_to(
            np.asarray(accommodation, float), (len(objects),))
        rows = []
        for i in range(len(objects)):
            rot, vertex = eye_in_world(eye, "rotating", chief.dir_out[i])
            rows.append(trace_lines(eye, lens, cor[None], chief.dir_out[i:i + 1],
                                    objects.distance[i:i + 1], rot=rot, vertex=vertex,
                                    accommodation=None if acc is None else acc[i:i + 1],
                                    wavelength_nm=wavelength_nm,
                                    status=chief.status[i:i + 1]))
        return _concat(rows)
    rot, vertex = eye_in_world(eye, "fixed", None)
    n = len(objects)
    acc = fixation_accommodation(eye, lens, objects.distance, wavelength_nm) \
        if accommodation is None else np.broadcast_to(np.asarray(accommodation, float),
                                                      (n,)).astype(float)
    z_ep, _ = eye.entrance_pupil(float(acc[0]), wavelength_nm)
    target = np.tile([0.0, 0.0, z_ep], (n, 1))
    for _ in range(OBJECT_MAX_ITER):
        chief = find_chief_rays(lens, target, objects, wavelength_nm)
        points, st = aim_at_stop(eye, rot, vertex, chief.dir_out, acc, wavelength_nm)
        moved = np.linalg.norm(points - target, axis=1)
        target = points
        if not np.any(moved > AIM_TOL):
            break
    st = st | chief.status
    st[moved > 1e3 * AIM_TOL] |= np.uint8(Status.NOT_CONVERGED)
    return trace_lines(eye, lens, points, chief.dir_out, objects.distance, rot=rot,
                       vertex=vertex, accommodation=acc, wavelength_nm=wavelength_nm,
                       status=st)


def _concat(rows: list) -> RetinalTrace:
    """One :class:`RetinalTrace` of several, row after row."""
    out = {}
    for name in RetinalTrace.__dataclass_fields__:
        vals = [getattr(r, name) for r in rows]
        if name == "object_points":
            out[name] = ObjectPoints(np.concatenate([v.direction for v in vals]),
                                     np.concatenate([v.distance for v in vals]))
        else:
            out[name] = np.concatenate(vals)
    return RetinalTrace(**out)
