"""The full lens + eye chain for object points (Kakimoto 2007, Table 1).

For each object point: chief ray (path finding) -> wavefront creation at the lens front
(spherical, Eq. 1 from the source) -> front refraction (Eq. 3-5) -> transfer in the glass
(Eq. 1) -> back refraction -> transfer to the eye (Eq. 1) -> accommodation (Eq. 13, 15)
-> thin toric eye (Eq. 7) -> Sturm-conoid section at the retina (Eq. 8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_choice
from eyelab.core.constants import RAD_TO_ARCMIN
from eyelab.core.vecmath import UP, cross, dot
from eyelab.optics.eye.thin import EYE_REFERENCE_NM, Eye
from eyelab.optics.rays.paths import ChiefRays, ObjectPoints, find_chief_rays
from eyelab.optics.rays.surfaces import sym2_eig
from eyelab.optics.rays.trace import FATAL, Status
from eyelab.optics.rays.wavefront import Wavefront

#: How the eye meets each object point: "fixed" (looking straight ahead, the points seen
#: off axis) or "rotating" (turned about its centre of rotation toward each point).
FIXATIONS = ("fixed", "rotating")
#: Where the vertex-sphere wave is taken: centred on the eye's centre of rotation (the lens
#: designer's sphere) or on the pupil.
VERTEX_SPHERES = ("rotation_centre", "pupil")


@dataclass
class PointAnalysis:
    """Per-point results, all arrays with n rows (SI units unless the name says otherwise).

    chief : ChiefRays
    pupil : (n, 3) where the chief ray meets the eye (the pupil centre)
    wave_eye : Wavefront arriving at the pupil/cornea plane (before the eye)
    wave_vertex_sphere : Wavefront at the vertex sphere (or None without a lens)
    accommodation : (n,) D
    eye_x : (n, 3) the eye-lens x axis (horizontal, §4.4.1)
    retina_matrix : (n, 2, 2) m; maps a pupil point (unit disc) to its retinal offset,
        r_p (I - z_r K') in the eye (x, y) frame (symmetric form of Eq. 8-9)
    a, b : (n,) signed semi-axes of Eq. 8 (m), a for the larger curvature k'_1
    omega : (n,) rad, direction of k'_1 from eye x (Eq. 9's omega'_1)
    status : (n,) uint8
    wave_exit : Wavefront just after the back surface, at the chief ray's exit point (None
        without a lens)
    vertex_sphere : {"centre": "rotation_centre" | "pupil", "centre_m": (3,), "radius_m",
        "points_m": (n, 3)} the sphere ``wave_vertex_sphere`` is taken on and where each
        chief ray meets it (None without a lens)
    """

    chief: ChiefRays
    pupil: np.ndarray
    wave_eye: Wavefront
    wave_vertex_sphere: Wavefront | None
    accommodation: np.ndarray
    eye_x: np.ndarray
    retina_matrix: np.ndarray
    a: np.ndarray
    b: np.ndarray
    omega: np.ndarray
    status: np.ndarray
    eye: Eye
    wave_exit: Wavefront | None = None
    vertex_sphere: dict | None = None

    @property
    def ok(self):
        return (self.status & np.uint8(FATAL)) == 0

    def blur_axes(self):
        """(major, minor) semi-axes (m, >= 0) and the major axis angle (rad in [0, pi)) from
        the eye x axis."""
        maj = np.maximum(np.abs(self.a), np.abs(self.b))
        mnr = np.minimum(np.abs(self.a), np.abs(self.b))
        ang = np.where(np.abs(self.a) >= np.abs(self.b), self.omega, self.omega + np.pi / 2)
        return maj, mnr, np.mod(ang, np.pi)

    def to_arcmin(self, length):
        """Retinal length (m) -> visual angle (arcmin): h n_2 / z_r (nodal point at the lens)."""
        return np.asarray(length) * self.eye.n_vitreous / self.eye.retina_distance \
            * RAD_TO_ARCMIN


def analyze_points(eye: Eye, lens, objects: ObjectPoints, *,
                   wavelength_nm: float = EYE_REFERENCE_NM, fixation: str = "fixed",
                   accommodation=None,
                   vertex_sphere: str = "rotation_centre") -> PointAnalysis:
    """Trace the chain for every object point.

    Parameters
    ----------
    eye : Eye
    lens : SpectacleLens or None (naked eye)
    objects : ObjectPoints
    fixation : "fixed" — the pupil stays at the origin and the eye turns about it to
        look along each chief ray (Kakimoto's model, used by the renderer); "rotating" — the
        eye turns about its centre of rotation, so the chief ray passes through it and the
        pupil lies rotation_centre before it (the lens designer's as-worn model).
    accommodation : None for the best effort per point (Eq. 13), or a fixed value in D
        (clipped to [0, accommodation_max]). The eye has one accommodation whatever the
        colour: at a wavelength other than the eye's reference (:data:`EYE_REFERENCE_NM`)
        through a dispersive lens, Eq. 13 is solved for the reference wavelength's wave
        along the same object points (as the renderers' per-channel fields take it), and
        the eye's own chromatic aberration (:meth:`Eye.power_shift`) then defocuses the
        wavelength asked for.
    vertex_sphere : where the vertex-sphere wave is taken: "rotation_centre" (the lens
        designer's sphere: centred on the eye's centre of rotation, radius vertex distance
        + rotation_centre, through the lens's back vertex) or "pupil" (centred on the pupil
        centre, radius the vertex distance).
    """
    check_choice("fixation", fixation, FIXATIONS)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    target = cor if fixation == "rotating" else np.zeros(3)
    chief = find_chief_rays(lens, target, objects, wavelength_nm)
    if (accommodation is None and lens is not None and lens.material.dispersive
            and wavelength_nm != EYE_REFERENCE_NM):
        ref = analyze_points(eye, lens, objects, fixation=fixation,
                             vertex_sphere=vertex_sphere)
        accommodation = np.where((ref.status & np.uint8(FATAL)) == 0, ref.accommodation,
                                 np.nan)
    return trace_chain(eye, lens, chief, objects, wavelength_nm=wavelength_nm,
                       fixation=fixation, accommodation=accommodation,
                       vertex_sphere=vertex_sphere)


def trace_chain(eye: Eye, lens, chief: ChiefRays, objects: ObjectPoints, *,
                wavelength_nm: float = EYE_REFERENCE_NM, fixation: str = "fixed",
                accommodation=None, vertex_sphere: str = "rotation_centre") -> PointAnalysis:
    """The wavefront part of :func:`analyze_points`, for chief rays already found
    (Table 1 from 'wavefront creation' to 'conoid sectioning')."""
    n = len(objects)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    status = chief.status.copy()
    N_out = chief.dir_out
    if fixation == "rotating":
        pupil = cor - eye.rotation_centre * N_out
    else:
        pupil = np.zeros((n, 3))
    vs_wave = exit_wave = vs_info = None
    check_choice("vertex_sphere", vertex_sphere, VERTEX_SPHERES)
    if lens is None:
        dist = np.where(objects.finite, np.linalg.norm(chief.start - pupil, axis=1), np.inf)
        wave = Wavefront.spherical(N_out, dist)
    else:
        nl = lens.material.n(wavelength_nm)
        h_front, h_back = chief.hits
        wave = Wavefront.spherical(chief.dir_in, chief.object_distance_to_entry)
        wave.refract(h_front, 1.0 / nl)
        wave.transfer(np.linalg.norm(h_back.points - h_front.points, axis=1))
        wave.refract(h_back, nl)
        exit_wave = wave.copy()
        # vertex sphere: through the back vertex, centred on the centre of rotation (radius
        # vertex distance + rotation centre) or on the pupil (radius vertex distance)
        centre = cor if vertex_sphere == "rotation_centre" else np.zeros(3)
        r_vs = lens.pose.vertex_distance + (eye.rotation_centre
                                            if vertex_sphere == "rotation_centre" else 0.0)
        vs_info = {"centre": vertex_sphere, "centre_m": centre, "radius_m": r_vs}
        rel = h_back.points - centre
        bq = dot(rel, wave.N)
        disc = bq * bq - (dot(rel, rel) - r_vs * r_vs)
        s_vs = -bq - np.sqrt(np.maximum(disc, 0.0))
        s_vs = np.where(disc >= 0, s_vs, 0.0)
        vs_info["points_m"] = h_back.points + s_vs[:, None] * wave.N
        vs_wave = wave.copy().transfer(s_vs)
        wave.transfer(dot(pupil - h_back.points, wave.N))
    status |= wave.status
    kbar = 0.5 * (wave.k11 + wave.k22)
    acc = eye.accommodation_for(kbar)                          # Eq. 13
    if accommodation is not None:                              # given (NaN: Eq. 13 there)
        given = np.broadcast_to(np.asarray(accommodation, float), (n,))
        acc = np.where(np.isnan(given), acc,
                       np.clip(given, 0.0, eye.accommodation_max))
    n2 = eye.n_vitreous
    inside = wave.toric_lens(UP, eye.power_matrix(acc, wavelength_nm), 1.0 / n2,
                             n2)                               # Eq. 7, the eye's LCA in
    acc = np.array(acc, float)
    rp = eye.pupil_diameter / 2
    zr = eye.retina_distance
    m11 = rp * (1.0 - zr * inside.k11)                        # Eq. 8 in matrix form
    m12 = -rp * zr * inside.k12
    m22 = rp * (1.0 - zr * inside.k22)
    l1, l2, c, s = sym2_eig(m11, m12, m22)
    # k'_1 (larger curvature) <-> smaller eigenvalue of M = r_p (I - z_r K')
    a = l2
    b = l1
    omega = np.arctan2(c, -s)  # direction perpendicular to the l1 eigenvector
    mat = np.stack([np.stack([m11, m12], -1), np.stack([m12, m22], -1)], -1)
    bad = (status & np.uint8(FATAL)) != 0
    for arr in (a, b, omega, acc):
        arr[bad] = 0.0
    mat[bad] = 0.0
    return PointAnalysis(chief, pupil, wave, vs_wave, acc, inside.t1, mat, a, b,
                         np.mod(omega, np.pi), status, eye, exit_wave, vs_info)


def principal_angles(wave: Wavefront, x_axis):
    """Principal curvatures k1 >= k2 (1/m = D in air) and the angle (rad, [0, pi)) of e1
    from ``x_axis`` (n, 3), measured toward N x x_axis (counter-clockwise seen from behind
    the wearer for x_axis = eye x)."""
    k1, k2, e1, _ = wave.principal()
    y_axis = cross(wave.N, x_axis)
    ang = np.arctan2(dot(e1, y_axis), dot(e1, x_axis))
    return k1, k2, np.mod(ang, np.pi)


def status_text(code) -> str:
    return Status.describe(int(code))


def power_error_matrix(res: PointAnalysis, rx, objects: ObjectPoints, add_fraction=None
                       ) -> tuple:
    """(E11, E12, E22) (n,) D: the power a lens delivers along each line of sight — the
    vertex-sphere wave's curvature matrix less the object's vergence at the chief ray's
    vertex-sphere point — minus the prescription ``rx`` for that line (its distance part
    plus ``add_fraction`` (n,) of its add; default: the object's vergence over 2.5 D, at
    most 1 — all of the add at 0.4 m), in the wave's (eye x, y) frame; NaN where a row has
    no light path."""
    k11, k12, k22 = res.wave_vertex_sphere.in_basis(res.eye_x)
    pos = objects.positions()
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.linalg.norm(pos - res.vertex_sphere["points_m"], axis=1)
        obj = np.where(objects.finite, -1.0 / d, 0.0)
    f = rx.distance().power_matrix()
    if add_fraction is None:
        add_fraction = np.clip(-obj / 2.5, 0.0, 1.0)
    add = rx.add * np.asarray(add_fraction, float)
    bad = (res.status & np.uint8(FATAL)) != 0
    return tuple(np.where(bad, np.nan, e) for e in (k11 - obj - f[0, 0] - add, k12 - f[0, 1],
                                                    k22 - obj - f[1, 1] - add))


def power_error(res: PointAnalysis, rx, objects: ObjectPoints, add_fraction=None) -> dict:
    """:func:`power_error_matrix` as minus-cylinder sphere / cylinder x axis in the wave's
    (eye x, y) frame (the as-worn power error of lens design).

    Returns arrays (n,): sphere_d, cylinder_d (<= 0), axis_wearer_deg ([0, 180), counter-
    clockwise from the wearer's right seen from behind), mean_d (sphere + cylinder/2);
    NaN where a row has no light path."""
    e11, e12, e22 = power_error_matrix(res, rx, objects, add_fraction)
    mean = 0.5 * (e11 + e22)
    half = np.sqrt((0.5 * (e11 - e22)) ** 2 + e12 ** 2)
    sphere, cyl = mean + half, -2.0 * half
    # the axis: the direction of the larger eigenvalue (where the power is the sphere)
    axis = np.degrees(0.5 * np.arctan2(2 * e12, e11 - e22)) % 180.0
    return {"sphere_d": sphere, "cylinder_d": cyl, "axis_wearer_deg": axis,
            "mean_d": sphere + cyl / 2}


def chief_prism(res: PointAnalysis) -> tuple:
    """Prism at each chief ray's passage through the lens: (prism dioptres (n,): 100 tan of
    the angle between the ray before and after the lens; deviation (n, 3): the
    component of the outgoing direction across the incoming one, the way the light is bent
    toward the base)."""
    d_in, d_out = res.chief.dir_in, res.chief.dir_out
    cosang = np.clip(dot(d_in, d_out), -1.0, 1.0)
    return 100.0 * np.tan(np.arccos(cosang)), d_out - cosang[:, None] * d_in


def lens_angle(lens, v) -> float:
    """Angle (deg, [0, 360)) of the world vector ``v`` projected on the lens plane,
    counter-clockwise from the lens's x (the wearer's right) seen from behind the wearer."""
    local = np.asarray(lens.pose.rotation, float).T @ np.asarray(v, float)
    return math.degrees(math.atan2(local[1], local[0])) % 360.0


def prism_row(delta, dev, lens) -> dict:
    """One row of :func:`~eyelab.optics.chain.analysis.chief_prism`: prism dioptres and the
    base direction (the way the light is bent) in the lens plane."""
    delta = float(delta)
    base = lens_angle(lens, dev) if np.linalg.norm(dev) > 1e-15 else 0.0
    return {"prism_d": delta, "base_deg": base,
            "base_right_d": delta * math.cos(math.radians(base)),
            "base_up_d": delta * math.sin(math.radians(base))}
