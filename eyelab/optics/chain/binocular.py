"""Two eyes behind one frame: vergence, linked accommodation, induced prism, and the
per-eye, side-by-side and anaglyph images (Kakimoto et al. 2007 render both eyes for their
stereo display).

Head frame: the single eye's world frame with the *cyclopean* pupil — midway between the
two pupil centres in primary gaze — at the origin: x to the wearer's right, y up, the
wearer looking along -z. The right eye's pupil is at (+pd_right, 0, 0), the left eye's at
(-pd_left, 0, 0) (monocular pupillary distances from the midline). Each eye is simulated
by the single-eye machinery in its own frame (its pupil at the origin): the scene and the
object points are moved by minus its pupil position, and its lens is posed relative to
its pupil (:func:`eyelab.spec.sides.parse_binocular` puts each lens's optical centre where the
frame PD says).

Vergence: both eyes fixate one point, ``fixation_distance`` from the cyclopean centre of
rotation (the midpoint of the two eyes' centres of rotation) along the view's gaze; each
eye turns about its own centre of rotation toward it (Fick angles, as
:func:`eyelab.optics.rays.camera.gaze_camera`). At infinity the lines of sight are parallel.

Accommodation is consensual: both eyes receive the same accommodative response (clipped
by each eye's own amplitude). With a fixed ``eye.accommodation_d`` it is that value; with
"auto" it is the response for the fixated point by the *less-blurred-eye* rule: of the two
eyes' own best responses (Kakimoto Eq. 13) the one that leaves the smaller blur in the
sharper eye, the lower one when both focus an eye fully (least effort). In anisometropia
the least ametropic eye thus determines the accommodation and the other eye lags (Toor,
Horwood & Riddell 2018, Br J Ophthalmol 102:772, and the studies of symmetric
accommodation they cite; they also measured that some hyperopic anisometropic amblyopes
accommodate asymmetrically — not modelled).

Stereo images are composed in linear light: side by side for parallel (left eye's image on
the left) or crossed (right eye's on the left) free viewing, and red/cyan anaglyphs by
Dubois's least-squares projection (E. Dubois, "A projection method to generate anaglyph
stereo images", ICASSP 2001; the red/cyan matrices of his 2009 note "Conversion of a
stereo pair to anaglyph with the least-squares projection method"), applied to linear RGB
and clipped to [0, 1].

Pure numpy: no VTK here (the renderer passed in does the drawing).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.checks import check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import FIXATIONS, trace_chain
from eyelab.optics.eye.thin import EYE_REFERENCE_NM, Eye
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays

SIDES = ("right", "left")
#: Gaze limit of each eye (deg, each Fick angle), as :class:`eyelab.imaging.contract.View`.
MAX_GAZE_DEG = 60.0


@dataclass(frozen=True)
class Binocular:
    """A wearer's two eyes and the frame's two lenses.

    right, left : :class:`~eyelab.optics.eye.thin.Eye`; right_lens, left_lens : lens or None
    (each posed relative to its own eye's pupil); monocular_pd : (right, left) m, each
    pupil centre's distance from the midline (primary gaze); frame_pd : m, the distance
    between the lenses' optical centres (informational: the lenses' poses hold it);
    fixation_distance : m from the cyclopean centre of rotation (inf: parallel lines of
    sight); output : one of :data:`OUTPUTS`.
    """

    right: Eye
    left: Eye
    right_lens: object = None
    left_lens: object = None
    monocular_pd: tuple = (0.032, 0.032)
    frame_pd: float | None = None
    fixation_distance: float = math.inf
    output: str = "side-by-side"

    def eye(self, side: str) -> Eye:
        return self.right if side == "right" else self.left

    def lens(self, side: str):
        return self.right_lens if side == "right" else self.left_lens

    def without_lenses(self) -> Binocular:
        return dataclasses.replace(self, right_lens=None, left_lens=None)

    def pupil(self, side: str) -> np.ndarray:
        """(3,) m: the eye's pupil centre in primary gaze, in the head frame."""
        x = self.monocular_pd[0] if side == "right" else -self.monocular_pd[1]
        return np.array([x, 0.0, 0.0])

    def rotation_centre(self, side: str) -> np.ndarray:
        """(3,) m: the eye's centre of rotation in the head frame."""
        return self.pupil(side) + np.array([0.0, 0.0, self.eye(side).rotation_centre])

    @property
    def cyclopean_centre(self) -> np.ndarray:
        """(3,) m: midway between the two centres of rotation."""
        return 0.5 * (self.rotation_centre("right") + self.rotation_centre("left"))

    def fixation(self, gaze_deg=(0.0, 0.0)) -> ObjectPoints:
        """The fixated point in the head frame, ``fixation_distance`` along the cyclopean
        gaze (Fick angles (right, up), deg) from the cyclopean centre of rotation."""
        f = fick_direction(gaze_deg)
        if not math.isfinite(self.fixation_distance):
            return ObjectPoints(f[None], np.array([math.inf]))
        return ObjectPoints.from_positions(self.cyclopean_centre
                                           + self.fixation_distance * f)

    def points_for(self, side: str, points: ObjectPoints) -> ObjectPoints:
        """Head-frame object points as the ``side`` eye's frame holds them (its pupil at
        the origin); points at infinity keep their direction."""
        fin = points.finite
        pos = points.direction * np.where(fin, points.distance, 1.0)[:, None] \
            - self.pupil(side)
        rel = np.where(fin[:, None], pos, points.direction)
        return ObjectPoints(rel / np.linalg.norm(rel, axis=1, keepdims=True),
                            np.where(fin, np.linalg.norm(pos, axis=1), np.inf))

    def gaze(self, side: str, gaze_deg=(0.0, 0.0)) -> tuple:
        """(right, up) Fick angles (deg) of the ``side`` eye fixating :meth:`fixation`
        (from its own centre of rotation; refused beyond :data:`MAX_GAZE_DEG`)."""
        fix = self.fixation(gaze_deg)
        if not fix.finite[0]:
            f = fix.direction[0]
        else:
            f = fix.positions()[0] - self.rotation_centre(side)
            f = f / np.linalg.norm(f)
        a = math.degrees(math.atan2(f[0], -f[2]))
        e = math.degrees(math.asin(float(np.clip(f[1], -1.0, 1.0))))
        if max(abs(a), abs(e)) > MAX_GAZE_DEG:
            raise SpecError("binocular.fixation_distance_m",
                            f"the {side} eye would turn ({a:+.1f}, {e:+.1f}) deg to fixate "
                            f"it; each eye turns at most {MAX_GAZE_DEG:g} deg")
        return a, e

    def to_eye(self, side: str) -> np.ndarray:
        """(4, 4) homogeneous matrix: head frame -> the ``side`` eye's frame."""
        m = np.eye(4)
        m[:3, 3] = -self.pupil(side)
        return m

    def scene_for(self, side: str, scene):
        """The scene as the ``side`` eye's frame holds it (moved by minus its pupil)."""
        m = self.to_eye(side)
        return dataclasses.replace(scene, meshes=[x.transformed(m) for x in scene.meshes])


def fick_direction(gaze_deg) -> np.ndarray:
    """(3,) unit line of sight for Fick angles (right, up) in degrees:
    (cos e sin a, sin e, -cos e cos a)."""
    a, e = (math.radians(float(v)) for v in gaze_deg)
    return np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])


def rms_blur(res) -> np.ndarray:
    """(n,) root-mean-square semi-axis of each retinal blur ellipse, m."""
    return np.sqrt(0.5 * (res.a ** 2 + res.b ** 2))


def analyze_binocular(bino: Binocular, points: ObjectPoints, *, wavelength_nm=EYE_REFERENCE_NM,
                      fixation: str = "rotating", accommodation=None,
                      vertex_sphere: str = "rotation_centre", no_lens: bool = False) -> dict:
    """Both eyes' analyses of head-frame ``points`` with one accommodative response.

    ``fixation`` "rotating": each eye turns about its centre of rotation toward each point
    (both eyes fixate it: vergence); "fixed": the pupils stay put (Kakimoto's model).
    ``accommodation`` None: per point by the less-blurred-eye rule (module docstring),
    decided at the eyes' reference wavelength (one accommodation whatever the colour, as
    :func:`eyelab.optics.chain.analysis.analyze_points` takes it through a dispersive lens);
    else the fixed value for both (each clipped to its eye's amplitude).

    Returns {"right": PointAnalysis, "left": PointAnalysis, "accommodation_d": (n,),
    "driving_eye": (n,) of "right"/"left"/"fixed", "points": {side: ObjectPoints},
    "line_of_sight_prism": {side: (prism (n,), deviation (n, 3), ok (n,))} (lenses only)}.
    """
    check_choice("fixation", fixation, FIXATIONS)
    if not isinstance(bino.right, Eye):
        return _schematic_pair(bino, points, wavelength_nm=wavelength_nm, fixation=fixation,
                               accommodation=accommodation, no_lens=no_lens)
    chief, pts = {}, {}
    for side in SIDES:
        eye = bino.eye(side)
        lens = None if no_lens else bino.lens(side)
        pts[side] = bino.points_for(side, points)
        target = np.array([0.0, 0.0, eye.rotation_centre]) if fixation == "rotating" \
            else np.zeros(3)
        chief[side] = (lens, find_chief_rays(lens, target, pts[side], wavelength_nm))

    def trace(side, acc):
        lens, ch = chief[side]
        return trace_chain(bino.eye(side), lens, ch, pts[side], wavelength_nm=wavelength_nm,
                           fixation=fixation, accommodation=acc, vertex_sphere=vertex_sphere)

    n = len(points)
    lenses = [chief[s][0] for s in SIDES if chief[s][0] is not None]
    if accommodation is None and wavelength_nm != EYE_REFERENCE_NM \
            and any(lens.material.dispersive for lens in lenses):
        ref = analyze_binocular(bino, points, fixation=fixation, vertex_sphere=vertex_sphere,
                                no_lens=no_lens)
        acc, driving = ref["accommodation_d"], ref["driving_eye"]
    elif accommodation is not None:
        acc = np.full(n, float(accommodation))
        driving = np.array(["fixed"] * n, dtype=object)
    else:
        own = {s: trace(s, None).accommodation for s in SIDES}
        acc, driving = _less_blurred(own, lambda s, a: rms_blur(trace(s, a)))
    los = {s: line_of_sight_prism(bino.eye(s), chief[s][0], pts[s], wavelength_nm)
           for s in SIDES if chief[s][0] is not None}
    return {"right": trace("right", acc), "left": trace("left", acc),
            "accommodation_d": acc, "driving_eye": driving, "points": pts,
            "line_of_sight_prism": los}


def _less_blurred(own: dict, blur) -> tuple:
    """(accommodation (n,), driving eye (n,)) by the less-blurred-eye rule: of the eyes'
    own responses ``own`` {side: (n,)}, the one whose smaller retinal blur over both eyes
    (``blur(side, candidate)`` (n,), any unit) is smaller; the lower response when equal
    within rounding (least effort)."""
    score = {cand: np.minimum(*[blur(s, own[cand]) for s in SIDES]) for cand in SIDES}
    tol = 1e-10 * max(1.0, float(max(np.max(np.abs(v)) for v in score.values())))
    right_wins = (score["right"] < score["left"] - tol) | (
        (np.abs(score["right"] - score["left"]) <= tol) & (own["right"] <= own["left"]))
    return (np.where(right_wins, own["right"], own["left"]),
            np.where(right_wins, "right", "left").astype(object))


def _schematic_pair(bino: Binocular, points: ObjectPoints, *, wavelength_nm, fixation,
                    accommodation, no_lens) -> dict:
    """:func:`analyze_binocular` for two schematic eyes: each eye's exact trace
    (:func:`~eyelab.optics.chain.retina.trace_objects`, a :class:`~eyelab.optics.chain.
    retina.RetinalTrace` per side) at the accommodation both share — the less-blurred-eye
    rule on each eye's own response (the one that focuses the point on its axis) and its
    geometric blur, the entrance pupil's radius times the refraction error's RMS
    principal value (rad), decided at the eyes' reference wavelength."""
    from eyelab.optics.chain.retina import trace_objects

    pts = {s: bino.points_for(s, points) for s in SIDES}
    lenses = {s: None if no_lens else bino.lens(s) for s in SIDES}

    def trace(side, acc, wl=wavelength_nm):
        eye = bino.eye(side)
        a = None if acc is None else np.minimum(np.asarray(acc, float), eye.accommodation_max)
        return trace_objects(eye, lenses[side], pts[side], fixation=fixation,
                             accommodation=a, wavelength_nm=wl)

    n = len(points)
    if accommodation is not None:
        acc = np.full(n, float(accommodation))
        driving = np.array(["fixed"] * n, dtype=object)
    else:
        own = {s: np.clip(trace(s, None, EYE_REFERENCE_NM).accommodation, 0.0,
                          bino.eye(s).accommodation_max) for s in SIDES}

        def blur(side, acc):
            e = trace(side, acc, EYE_REFERENCE_NM).refraction           # (n, 3) D
            mean, half = (e[:, 0] + e[:, 2]) / 2, np.hypot((e[:, 0] - e[:, 2]) / 2, e[:, 1])
            rms = np.sqrt(((mean + half) ** 2 + (mean - half) ** 2) / 2)
            return bino.eye(side).pupil_diameter / 2 * rms

        acc, driving = _less_blurred(own, blur)
    los = {s: line_of_sight_prism(bino.eye(s), lenses[s], pts[s], wavelength_nm)
           for s in SIDES if lenses[s] is not None}
    return {"right": trace("right", acc), "left": trace("left", acc),
            "accommodation_d": acc, "driving_eye": driving, "points": pts,
            "line_of_sight_prism": los}


def fixation_blur_arcmin(eye, trace, i: int) -> list:
    """[major, minor] (arcmin) of the retinal blur of row ``i`` of one eye's trace in a
    two-eye analysis: a thin eye's blur ellipse semi-axes
    (:class:`~eyelab.optics.chain.analysis.PointAnalysis`), a schematic eye's geometric
    blur, the entrance pupil's radius times the refraction error's principal values."""
    if hasattr(trace, "blur_axes"):
        maj, mnr, _ = trace.blur_axes()
        return [float(trace.to_arcmin(maj[i])), float(trace.to_arcmin(mnr[i]))]
    exx, exy, eyy = trace.refraction[i]
    mean, half = (exx + eyy) / 2, math.hypot((exx - eyy) / 2, exy)
    ax = sorted((abs(mean + half), abs(mean - half)), reverse=True)
    return [float(math.degrees(eye.pupil_diameter / 2 * a) * 60) for a in ax]


def prism_rows(bino: Binocular, an: dict, i: int) -> dict | None:
    """Point ``i``'s induced prism per eye (:func:`line_of_sight_prism`, in each lens's
    plane) and binocularly (:func:`prism_imbalance`); None without lenses or where a line
    of sight misses a lens."""
    from eyelab.optics.chain.analysis import prism_row

    los = an["line_of_sight_prism"]
    if len(los) < 2 or not all(los[s][2][i] for s in SIDES):
        return None
    rows = {s: prism_row(los[s][0][i], los[s][1][i], bino.lens(s)) for s in SIDES}
    return {"right": rows["right"], "left": rows["left"],
            "binocular": prism_imbalance(rows["right"], rows["left"])}


def prism_imbalance(right: dict, left: dict) -> dict:
    """Binocular prism from the two eyes' prism rows (``base_right_d``, ``base_up_d`` in each lens's
    plane, :func:`eyelab.optics.chain.analysis.prism_row`): the total horizontal prism, base out
    positive (the right eye's base toward +x, the left's toward -x), and the vertical imbalance,
    right base up positive."""
    out = right["base_right_d"] - left["base_right_d"]
    up = right["base_up_d"] - left["base_up_d"]
    return {"horizontal_base_out_d": float(out),
            "horizontal": f"{abs(out):.2f} Δ base {'out' if out >= 0 else 'in'}",
            "vertical_right_base_up_d": float(up),
            "vertical": f"{abs(up):.2f} Δ {'right' if up >= 0 else 'left'} base up"}


def line_of_sight_prism(eye: Eye, lens, points: ObjectPoints, wavelength_nm=587.56
                        ) -> tuple:
    """The prism a lens induces on each line of sight: the eye's centre of rotation toward
    each point (in the eye's frame), as the eye is aimed without the lens — where a
    focimeter reads the lens's prism for that point and what fusional vergence must make
    up (Prentice's c F for a thin lens decentred by c). Reverse-traces that line through
    the lens. Returns (prism dioptres (n,), deviation (n, 3) toward the base, as
    :func:`~eyelab.optics.chain.analysis.chief_prism`; ok (n,) bool: the line passes the lens)."""
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    fin = points.finite
    f = np.where(fin[:, None], points.positions() - cor, points.direction)
    f = f / np.linalg.norm(f, axis=1, keepdims=True)
    res = lens.trace(np.broadcast_to(cor, f.shape), f, wavelength_nm, reverse=True)
    ok = res["status"] == 0
    d_in = -np.where(ok[:, None], res["out_dirs"], f)      # the light before the lens
    d_out = -f                                             # ... and after it, to the eye
    cos = np.clip(np.sum(d_in * d_out, axis=1), -1.0, 1.0)
    return 100.0 * np.tan(np.arccos(cos)), d_out - cos[:, None] * d_in, ok
