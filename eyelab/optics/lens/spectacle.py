"""Spectacle lenses: two surfaces, a centre thickness, a material and a pose in front of the eye.

World frame (used throughout eyelab): origin at the centre of the eye's entrance pupil (the
thin eye lens at the corneal vertex, Kakimoto Table 2); x to the wearer's right, y up; the
wearer looks along -z, so light from the scene travels +z. The retina is at z = +z_r.
Lens frame: origin at the back vertex, z along the lens's optical axis toward the eye, x, y
as in the world when the lens is not tilted. Lens frame -> world: p_w = R p_l + t with
t = (decentration_x, decentration_y, -vertex_distance) and R = R_y(-wrap)
R_x(-pantoscopic_tilt): pantoscopic tilt turns the lower rim toward the cheeks, wrap turns
the +x rim (the temporal rim of a right eye's lens) toward the face; a left eye's lens of a
face-form frame has the opposite wrap (:mod:`eyelab.optics.chain.binocular`). The rotation
is about the back vertex. The front surface's vertex is at z_l = -center_thickness.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_in
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.lens.pose import LIMITS, LensPose
from eyelab.optics.rays.fresnel import COATINGS, PolarisedTransmission
from eyelab.optics.rays.materials import Material, get_material
from eyelab.optics.rays.surfaces import REVOLVE_AXES, Asphere, Surface, Toric
from eyelab.optics.rays.trace import FATAL, PlacedSurface, Status, intersect, refract

#: Minimum centre thickness of minus lenses by material (m) (docs/SCIENCE.md §7, lab
#: practice).
MIN_CENTER_THICKNESS = {"cr39": 2.0e-3, "crown": 2.0e-3, "trivex": 1.2e-3,
                        "polycarbonate": 1.5e-3, "mr8": 1.4e-3, "mr7": 1.2e-3,
                        "mr174": 1.5e-3}
#: Minimum edge thickness of plus lenses (m) (docs/SCIENCE.md §7: 0.5-1.0 mm).
MIN_EDGE_THICKNESS = 1.0e-3
#: Lowest n_d of a lens made from a prescription (the lowest spectacle material is
#: ~1.49; below 1.3 the surfaces of ordinary powers become hemispheres).
MIN_LENS_INDEX = 1.3


def check_feasible(front, back, center_thickness, diameter, *, min_edge=0.0,
                   field="lens.center_thickness_mm", undefined_ok=False) -> None:
    """Refuse (:class:`SpecError` naming ``field``) a lens whose surfaces meet or cross
    inside its diameter, or whose rim is thinner than ``min_edge`` (m), saying what would
    make it feasible: the centre thickness, or the diameter, that would. Thickness at lens
    polar point (r, theta): t - sag_front + sag_back (sags positive toward the eye). A
    surface steeper than a hemisphere inside the diameter has no sag there: refused
    (naming ``lens.diameter_mm``) unless ``undefined_ok`` (the library's own check, which
    lets such a surface miss rays with a status instead)."""
    rr = np.linspace(0.0, diameter / 2, 49)[1:]
    th = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    r, t = np.meshgrid(rr, th)
    x, y = r * np.cos(t), r * np.sin(t)
    with np.errstate(invalid="ignore"):
        thick = center_thickness - front.sag(x, y) + back.sag(x, y)
    undefined = ~np.isfinite(thick)
    if undefined.any():
        if not undefined_ok:
            reach = rr[:np.argmax(undefined.any(axis=0))]
            fix = f"reduce diameter_mm to <= {np.floor(2 * reach[-1] * 1e3):.0f}" \
                if len(reach) else "use flatter surfaces"
            raise SpecError("lens.diameter_mm", f"a surface is steeper than a hemisphere "
                            f"inside the diameter (no surface beyond "
                            f"{r[undefined].min() * 1e3:.1f} mm from the centre): {fix}")
        thick = np.where(undefined, np.inf, thick)
    need = np.where(r >= rr[-1] - 1e-12, min_edge, 0.0)      # min_edge on the rim
    short = float((need - thick).max())
    if short <= 0:
        return
    k = np.unravel_index((need - thick).argmax(), thick.shape)
    # the largest diameter whose rim (and everything inside) would be thick enough
    ok = [(thick[:, :i + 1] >= 0).all() and (thick[:, i] >= min_edge).all()
          for i in range(len(rr))]
    fits = [rr[i] for i in range(len(rr)) if ok[i]]
    fix = f"increase center_thickness_mm to >= {(center_thickness + short) * 1e3:.2f}"
    if fits and fits[-1] >= 0.005:
        fix += f" or reduce diameter_mm to <= {np.floor(2 * fits[-1] * 1e3):.0f}"
    what = "the surfaces cross" if thick.min() < 0 else "the edge is too thin"
    raise SpecError(field, f"{what}: thickness {thick[k] * 1e3:.2f} mm at {r[k] * 1e3:.1f} mm "
                           f"from the centre (at least {need[k] * 1e3:.2f} mm needed); {fix}")


@dataclass(frozen=True)
class SpectacleLens:
    """A single spectacle lens.

    :meth:`from_rx` designs the lens for a prescription, as a spec's ``[lens] rx`` does;
    the repr shows the ``[lens]`` spec keys (mm, D, degrees).

    Parameters
    ----------
    front, back : Surface
        In their local frames (sag along +z, toward the eye). For a usual meniscus both
        curvatures are positive (centres of curvature on the eye's side).
    center_thickness : float
        m, in (0.0002, 0.03].
    material : Material
        The lens material.
    diameter : float
        m, in [0.01, 0.09].
    pose : LensPose
        Where the lens sits in front of the eye.
    rx : Prescription or None
        The prescription the lens was designed for (informational).
    coating : str
        "none" (Fresnel reflection of the bare surfaces) or "ar" (anti-reflection:
        :data:`eyelab.optics.rays.fresnel.AR_REFLECTANCE` per surface).
    design : object
        How the lens was designed beyond its surfaces (below).
    outline : Outline or None
        The frame's shape the lens is cut to (:class:`eyelab.optics.lens.frame.Outline`),
        in the lens frame (x, y m; the fitting point at the origin), inside the round
        blank; rays meeting either surface outside it miss. None: the round blank.

    Examples
    --------
    A +3.00 / -1.00 x 090 lens in CR-39 (the default material), tilted 8 degrees: the
    thinnest that leaves a 1 mm edge, its back vertex powers (D) traced through it.

    >>> import eyelab
    >>> rx = eyelab.Prescription.parse("+3.00 -1.00 x 90")
    >>> lens = eyelab.SpectacleLens.from_rx(rx, pose=eyelab.LensPose(pantoscopic_tilt_deg=8.0))
    >>> lens.material.name, round(lens.center_thickness * 1e3, 2)
    ('cr39', 3.96)
    >>> round(lens.edge_thickness()[0] * 1e3, 2)
    1.0
    >>> [round(power, 3) for power in lens.back_vertex_powers()[:2]]
    [3.0, 2.0]
    """

    front: Surface
    back: Surface
    center_thickness: float
    material: Material
    diameter: float = 0.060
    pose: LensPose = field(default_factory=LensPose)
    rx: Prescription | None = None
    coating: str = "none"
    #: How the lens was designed beyond its surfaces (a progressive design's reference
    #: points), metadata for reports and maps.
    design: object = field(default=None, compare=False, repr=False)
    #: The frame's outline the lens is cut to (lens frame), or None for the round blank.
    outline: object = field(default=None, repr=False)

    def __repr__(self) -> str:
        from eyelab.core.reprs import Raw, spec_repr, value

        def surface(s):
            if not dataclasses.is_dataclass(s):
                return repr(s)
            keys = {f.name: getattr(s, f.name) for f in dataclasses.fields(s) if f.repr}
            return spec_repr(type(s).__name__, keys)

        keys = {"rx": None if self.rx is None else self.rx.format(),
                "material": self.material.name,
                "center_thickness_mm": self.center_thickness * 1e3,
                "diameter_mm": self.diameter * 1e3, **self.pose.spec_keys(),
                "coating": self.coating, "front": Raw(surface(self.front)),
                "back": Raw(surface(self.back))}
        if self.outline is not None:
            keys["outline"] = Raw("frame")
        return "SpectacleLens(" + ", ".join(f"{k}={value(v)}" for k, v in keys.items()) + ")"

    def __post_init__(self):
        check_in("lens.center_thickness_mm", self.center_thickness * 1e3, LIMITS)
        check_in("lens.diameter_mm", self.diameter * 1e3, LIMITS)
        if self.outline is not None and self.outline.farthest_from() > self.diameter / 2:
            raise SpecError("lens.diameter_mm", f"the frame's outline reaches "
                            f"{self.outline.farthest_from() * 1e3:.1f} mm from the fitting "
                            f"point, beyond the {self.diameter * 1e3:g} mm blank")
        if self.coating not in COATINGS:
            raise SpecError("lens.coating", f"must be one of {', '.join(map(repr, COATINGS))},"
                                            f" got {self.coating!r}")
        self.check_feasible(min_edge=0.0)

    @property
    def has_lenslets(self) -> bool:
        """Whether the front carries lenslets (:mod:`eyelab.optics.lens.lenslets`)."""
        return getattr(self.front, "delta_curvature", None) is not None

    # ------------------------------------------------------------- thickness
    def thickness(self, r, theta) -> np.ndarray:
        """Axial thickness (m) at lens-frame polar points (r m, theta rad): centre thickness
        minus the front sag plus the back sag (sags positive toward the eye)."""
        x, y = r * np.cos(theta), r * np.sin(theta)
        return self.center_thickness - self.front.sag(x, y) + self.back.sag(x, y)

    def rim(self, samples: int = 360) -> tuple:
        """(centre (2,), angles (samples,) rad, radii (samples,) m): the lens's edge as
        polar points about a centre in the lens frame — the frame's outline about its own
        centre where the lens is cut, else the blank's rim about the origin."""
        th = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
        if self.outline is None:
            return np.zeros(2), th, np.full_like(th, self.diameter / 2)
        return np.asarray(self.outline.centre, float), th, self.outline.radius_at(th)

    def edge_thickness(self, samples: int = 360) -> tuple:
        """(thinnest, thickest) edge thickness on the rim (the cut edge of a lens cut to a
        frame) (m) and the rim angles (rad, about the origin) where they are."""
        c, th, rad = self.rim(samples)
        x, y = c[0] + rad * np.cos(th), c[1] + rad * np.sin(th)
        e = self.thickness(np.hypot(x, y), np.arctan2(y, x))
        ang = np.mod(np.arctan2(y, x), 2 * np.pi)
        return float(e.min()), float(e.max()), float(ang[e.argmin()]), float(ang[e.argmax()])

    def check_feasible(self, min_edge: float = 0.0, field: str = "lens.center_thickness_mm"
                       ) -> None:
        """See :func:`check_feasible` (this lens's surfaces, thickness and diameter)."""
        check_feasible(self.front, self.back, self.center_thickness, self.diameter,
                       min_edge=min_edge, field=field, undefined_ok=True)

    # --------------------------------------------------------------- placement
    def placed_surfaces(self) -> tuple[PlacedSurface, PlacedSurface]:
        """(front, back) in world coordinates, sharing the lens-frame aperture."""
        r = self.pose.rotation
        t = self.pose.translation
        t_front = t + r @ np.array([0.0, 0.0, -self.center_thickness])
        rad = self.diameter / 2
        return (PlacedSurface(self.front, r, t_front, rad, t),
                PlacedSurface(self.back, r, t, rad, t))

    def n(self, wavelength_nm: float = 587.56) -> float:
        return self.material.n(wavelength_nm)

    # ----------------------------------------------------------------- tracing
    def trace(self, origins, directions, wavelength_nm: float = 587.56, *, reverse=False):
        """Trace rays through the lens with exact Snell refraction.

        Forward rays travel +z (scene -> eye): front surface, then back. ``reverse=True``
        traces rays travelling -z (eye -> scene): back, then front.

        Returns
        -------
        dict
            The keys ``hit1``, ``hit2`` (:class:`Hit` at the first/second surface met),
            ``inside`` (n, 3) direction in the glass, ``out_points`` (n, 3), ``out_dirs``
            (n, 3), ``status`` (n,) uint8 and ``transmittance`` (n,): the fraction of
            unpolarised light the two surfaces pass (Fresnel, s and p tracked,
            :mod:`eyelab.optics.rays.fresnel`; 0 for failed rays).
        """
        return self.trace_wavelengths(origins, directions, (wavelength_nm,),
                                      reverse=reverse)[0]

    def trace_wavelengths(self, origins, directions, wavelengths_nm, *, reverse=False):
        """:meth:`trace` at several wavelengths: a list of its dicts, one per wavelength.
        The first surface's intersection does not depend on the wavelength (the rays meet
        it before any refraction), so it is computed once and shared."""
        origins = np.asarray(origins, float)
        directions = np.asarray(directions, float)
        s1, s2 = self.placed_surfaces()
        if reverse:
            s1, s2 = s2, s1
        h1 = intersect(s1, origins, directions)
        cut1 = self._cut_away(h1.points)
        out = []
        for wl in wavelengths_nm:
            nl = self.material.n(wl)
            d1, _, ci1, ct1, st1 = refract(directions, h1.normals, 1.0 / nl)
            h2 = intersect(s2, h1.points, d1)
            d2, _, ci2, ct2, st2 = refract(d1, h2.normals, nl)
            status = h1.status | st1 | h2.status | st2 | cut1 | self._cut_away(h2.points)
            # a ray that must go forward inside the glass but goes backward has missed
            back = np.einsum("ij,ij->i", h2.points - h1.points, d1) < 0
            status = status | np.where(back, Status.MISSED, 0).astype(np.uint8)
            # Fresnel: air -> glass, glass -> air, s and p tracked (eyelab.optics.rays.fresnel)
            with np.errstate(invalid="ignore", divide="ignore"):
                fresnel = PolarisedTransmission(len(directions))
                fresnel.surface(directions, h1.normals, ci1, ct1, 1.0, nl, self.coating)
                fresnel.surface(d1, h2.normals, ci2, ct2, nl, 1.0, self.coating)
            t = np.where((status & np.uint8(FATAL)) == 0, fresnel.transmittance, 0.0)
            out.append({"hit1": h1, "hit2": h2, "inside": d1, "out_points": h2.points,
                        "out_dirs": d2, "status": status, "transmittance": t})
        return out

    def _cut_away(self, points) -> np.ndarray:
        """(n,) uint8: MISSED where world ``points`` (n, 3) on a surface lie outside the
        frame's outline (measured in the lens frame, as the blank's aperture); 0 for an
        uncut lens."""
        if self.outline is None:
            return np.zeros(len(points), np.uint8)
        q = (np.asarray(points, float) - self.pose.translation) @ self.pose.rotation
        return np.where(self.outline.contains(q[:, 0], q[:, 1]), 0,
                        Status.MISSED).astype(np.uint8)

    def back_vertex_powers(self, wavelength_nm: float = 587.56):
        """Principal back vertex powers (D) and the direction (rad, lens frame) of the first,
        measured by wavefront tracing a flat wave along the lens's optical axis (check of
        the design by tracing, not by formula)."""
        from eyelab.optics.rays.wavefront import Wavefront

        r = self.pose.rotation
        axis = r @ np.array([0.0, 0.0, 1.0])
        t = self.pose.translation
        o = (t + r @ np.array([0.0, 0.0, -self.center_thickness - 0.01]))[None]
        res = self.trace(o, axis[None], wavelength_nm)
        wf = Wavefront.spherical(axis[None], np.inf)
        nl = self.material.n(wavelength_nm)
        wf.refract(res["hit1"], 1.0 / nl)
        wf.transfer(np.linalg.norm(res["hit2"].points - res["hit1"].points, axis=1))
        wf.refract(res["hit2"], nl)
        k1, k2, e1, _ = wf.principal()
        e1l = e1 @ r
        return float(k1[0]), float(k2[0]), float(math.atan2(e1l[0, 1], e1l[0, 0]) % math.pi)

    # -------------------------------------------------------------------- mesh
    def mesh(self, rings: int = 16, segments: int = 64):
        """Closed triangle mesh (front, back, edge) in world coordinates: polar rings
        about the rim's centre out to the rim (:meth:`rim`: the frame's outline where the
        lens is cut).

        Returns
        -------
        vertices : (v, 3) float, metres
        faces : (f, 3) int
        part : (v,) uint8, 0 front, 1 back (the edge band reuses the rim vertices)
        """
        c, th, rim = self.rim(segments)
        S, R = np.meshgrid(np.linspace(0.0, 1.0, rings + 1)[1:], rim, indexing="ij")
        T = np.broadcast_to(th, R.shape)
        x = np.concatenate([[c[0]], (c[0] + S * R * np.cos(T)).ravel()])
        y = np.concatenate([[c[1]], (c[1] + S * R * np.sin(T)).ravel()])
        fs, bs = self.placed_surfaces()
        faces = []
        for i in range(segments):  # centre fan
            j = (i + 1) % segments
            faces.append((0, 1 + i, 1 + j))
        for r_ in range(rings - 1):
            for i in range(segments):
                j = (i + 1) % segments
                a, b = 1 + r_ * segments + i, 1 + r_ * segments + j
                c, d = a + segments, b + segments
                faces += [(a, c, d), (a, d, b)]
        faces = np.array(faces)
        nv = len(x)
        verts = []
        for ps in (fs, bs):
            z = ps.surface.sag(x, y)
            z = np.where(np.isfinite(z), z, 0.0)
            verts.append(np.stack([x, y, z], 1) @ ps.rotation.T + ps.translation)
        rim = 1 + (rings - 1) * segments + np.arange(segments)
        edge = []
        for i in range(segments):
            j = (i + 1) % segments
            a, b = rim[i], rim[j]
            edge += [(a, b + nv, a + nv), (a, b, b + nv)]
        all_faces = np.concatenate([faces, faces[:, ::-1] + nv, np.array(edge)])
        part = np.concatenate([np.zeros(nv, np.uint8), np.ones(nv, np.uint8)])
        return np.concatenate(verts), all_faces, part

    # ----------------------------------------------------------------- design
    @classmethod
    def from_rx(cls, rx: Prescription, *, material="cr39", base_curve: float | None = None,
                center_thickness: float | None = None, diameter: float | None = None,
                pose: LensPose | None = None, wavelength_nm: float = 587.56,
                torus: str = "y", coating: str = "none") -> SpectacleLens:
        """Design a lens whose back vertex power equals ``rx`` (distance part) in both
        principal meridians.

        Front: a sphere of surface power ``base_curve`` (D, at the lens material's own index;
        default Vogel's rule, SE + 6 for plus and SE/2 + 6 for minus lenses, kept in
        [0.5, 12] D). Back: a toric (minus-cylinder, inner toric) surface whose power per
        principal meridian is F2 = F_v - F1 / (1 - t F1 / n) (docs/SCIENCE.md §7). Centre
        thickness: the thinnest that is at least the material minimum and leaves
        MIN_EDGE_THICKNESS at the rim (iterated, since t enters F2). ``diameter``
        (m) defaults to 60 mm, reduced for strong lenses so that no surface is steeper than
        0.9 of a hemisphere at the rim (the 'lenticular' limit); an explicit diameter that
        does not fit raises :class:`SpecError`.
        """
        mat = _design_material(rx, material, torus)
        pose = pose or LensPose()
        n = mat.n(wavelength_nm)
        if base_curve is None:
            base_curve = _vogel_base_curve(rx)
        check_in("lens.base_curve_d", base_curve, LIMITS)
        c1 = base_curve / (n - 1.0)
        if diameter is None:
            diameter = _fitting_diameter(rx, mat, n, base_curve, c1)
        rad = diameter / 2
        if abs(c1) * rad >= 0.98:
            raise SpecError("lens.base_curve_d", f"{base_curve:g} D is too steep for a "
                            f"{diameter * 1e3:g} mm lens of index {n:.3f}; allowed |F1| < "
                            f"{0.98 * (n - 1) / rad:.1f} D")
        key = mat.name if mat.name in MIN_CENTER_THICKNESS else "cr39"
        fixed_t = center_thickness is not None
        t = center_thickness if fixed_t else MIN_CENTER_THICKNESS[key]
        back, t = _design_back(rx, base_curve, n, c1, t, diameter, torus,
                               None if fixed_t else MIN_CENTER_THICKNESS[key])
        if fixed_t:       # the wearer's lens: the material's minimum centre, a real edge
            _check_wearer_lens(rx, mat, key, Asphere(c1), back, t, diameter)
        return cls(Asphere(c1), back, t, mat, diameter, pose, rx, coating)


# ------------------------------------------------------- from_rx's design steps
def _design_material(rx: Prescription, material, torus) -> Material:
    """The material of a lens designed for ``rx``, after refusing what cannot be designed:
    an add, an index below :data:`MIN_LENS_INDEX`, a torus other than 'x' or 'y'."""
    if rx.add > 0:
        raise SpecError("lens.design", f"{rx.format()} has an add: a single-vision lens "
                        "is made for rx.distance() or rx.near(), never silently for "
                        "one of them (spec: lens.design)")
    mat = get_material(material)
    if not MIN_LENS_INDEX <= mat.n_d:
        raise SpecError("lens.material", f"a lens made from a prescription needs n_d in "
                        f"[{MIN_LENS_INDEX}, 2.5], got {mat.n_d:g} ({mat.name})")
    if not isinstance(torus, str) or torus not in REVOLVE_AXES:
        raise SpecError("lens.torus", f"must be 'x' or 'y', got {torus!r}")
    return mat


def _vogel_base_curve(rx: Prescription) -> float:
    """Vogel's rule (D): SE + 6 for plus and SE/2 + 6 for minus lenses, kept in [0.5, 12]."""
    se = rx.sphere + rx.cylinder / 2
    base_curve = se + 6.0 if se > 0 else se / 2 + 6.0
    return min(max(base_curve, 0.5), 12.0)


def _fitting_diameter(rx: Prescription, mat: Material, n: float, base_curve: float,
                      c1: float) -> float:
    """The default diameter (m): 60 mm, reduced for strong lenses so that no surface is
    steeper than 0.9 of a hemisphere at the rim; under 10 mm is refused."""
    c2_est = max(abs(p - base_curve) for p in (rx.sphere, rx.sphere + rx.cylinder)) \
        / (n - 1.0) * 1.1
    diameter = min(0.060, 2 * 0.9 / max(abs(c1), c2_est, 1e-9))
    if diameter < 0.010:
        raise SpecError("lens.rx", f"{rx} in {mat.name} (n_d {mat.n_d:g}) needs "
                        "surfaces steeper than a hemisphere within 10 mm: use a "
                        "higher-index material or a weaker prescription")
    return diameter


def _back_surface(rx: Prescription, base_curve: float, n: float, t: float, diameter: float,
                  torus: str) -> Surface:
    """The back surface giving ``rx``'s back vertex power in both principal meridians
    (along the cylinder axis, and perpendicular to it) behind a front of ``base_curve``
    (D) at centre thickness ``t`` (m): F2 = F_v - F1 / (1 - t F1 / n)."""
    f2 = [p - base_curve / (1.0 - t * base_curve / n)
          for p in (rx.sphere, rx.sphere + rx.cylinder)]
    c2 = [f / (1.0 - n) for f in f2]
    if max(abs(c) for c in c2) * (diameter / 2) >= 0.98:
        raise SpecError("lens.rx", f"{rx} needs a back surface too steep for a "
                        f"{diameter * 1e3:g} mm lens; use a smaller diameter")
    axis_w = math.radians(rx.axis_wearer_deg)
    return Toric(c2[0], c2[1], axis_w, torus) if c2[0] != c2[1] else Asphere(c2[0])


def _design_back(rx: Prescription, base_curve: float, n: float, c1: float, t: float,
                 diameter: float, torus: str, min_center: float | None) -> tuple:
    """(back surface, centre thickness m). With ``min_center`` None the thickness ``t`` is
    kept; otherwise it is iterated (t enters F2) to the thinnest that is at least
    ``min_center`` and leaves MIN_EDGE_THICKNESS at the rim along the thinnest meridian."""
    rad = diameter / 2
    for _ in range(50):
        back = _back_surface(rx, base_curve, n, t, diameter, torus)
        if min_center is None:
            break
        # edge thickness at the rim along the thinnest meridian
        ang = np.linspace(0, np.pi, 181)
        s1 = Asphere(c1).sag(rad * np.cos(ang), rad * np.sin(ang))
        s2 = back.sag(rad * np.cos(ang), rad * np.sin(ang))
        edge = t - s1 + s2
        t_new = max(min_center, t + MIN_EDGE_THICKNESS - float(np.min(edge)))
        if abs(t_new - t) < 1e-10:
            break
        t = t_new
    return back, t


def _check_wearer_lens(rx: Prescription, mat: Material, key: str, front: Surface,
                       back: Surface, t: float, diameter: float) -> None:
    """Refuse a given centre thickness ``t`` (m) below the material's minimum for a minus
    lens, or one that leaves the rim thinner than MIN_EDGE_THICKNESS."""
    if rx.sphere + max(rx.cylinder, 0.0) < 0 and t < MIN_CENTER_THICKNESS[key]:
        raise SpecError("lens.center_thickness_mm", f"{t * 1e3:.2f} mm is below "
                        f"{mat.name}'s minimum for a minus lens: >= "
                        f"{MIN_CENTER_THICKNESS[key] * 1e3:.1f} mm")
    check_feasible(front, back, t, diameter, min_edge=MIN_EDGE_THICKNESS)
