"""The schematic eye against its papers and against an independent tracer (optiland).

Truths: the indices Escudero-Sanz & Navarro 1999 (JOSA A 16:1881, Table 1) list at four
wavelengths; the chromatic eye's measured LCA (Thibos et al. 1992); optiland's paraxial
solve and its real-ray tracer (independent code: its own surface intersection, Snell's
law, conic sag) for the chief rays, and fans of real rays about them whose crossings give
the astigmatic foci, a brute-force measure of what eyelab gets from Coddington's equations.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from eyelab.optics.chain.retina import trace_field, trace_objects
from eyelab.optics.eye.models import MEDIA, herzberger_weights, navarro_index
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.eye.thin import ocular_lca
from eyelab.optics.lens.spectacle import SpectacleLens

#: Escudero-Sanz & Navarro 1999, Table 1: (cornea, aqueous, lens, vitreous) by wavelength.
ESCUDERO_SANZ_INDICES = {458.0: (1.3828, 1.3445, 1.4292, 1.3428),
                         543.0: (1.3777, 1.3391, 1.4222, 1.3377),
                         589.3: (1.376, 1.3374, 1.42, 1.336),
                         632.8: (1.3747, 1.336, 1.4183, 1.3347)}


def test_dispersion_reproduces_the_published_indices():
    """Navarro 1985's Herzberger formula gives the 1999 table to its 4 decimals (one entry,
    the aqueous at 458 nm, rounds 1.34435 the other way: 1.5e-4), and its weights sum
    to 1 (the check that exposed the 1985 paper's misprints)."""
    for wl, published in ESCUDERO_SANZ_INDICES.items():
        got = [float(navarro_index(m, wl)) for m in MEDIA]
        assert np.allclose(got, published, atol=1.6e-4, rtol=0), (wl, got)
    w = herzberger_weights(np.linspace(400, 800, 41))
    assert np.allclose(w.sum(0), 1.0, atol=2e-8)


def test_the_published_eye_focuses_its_design_wavelength():
    """The relaxed eye of the paper is emmetropic at 543 nm (its design wavelength) to
    0.01 D; the d line focuses 0.23 D behind (eyelab's Rx wavelength: ``from_rx`` fits the
    axial length there)."""
    eye = SchematicEye()
    assert abs(eye.refraction(0.0, 543.0)) < 0.01
    assert SchematicEye.from_rx("plano").refraction() == pytest.approx(0.0, abs=1e-9)
    myope = SchematicEye.from_rx("-3.00")
    assert myope.refraction() == pytest.approx(-3.0 / (1 + 0.012 * 3.0), abs=1e-9)
    # axial myopia: about 0.37 mm per dioptre (docs/SCIENCE.md §5: 0.35-0.37 mm/D)
    per_d = (myope.axial_length - eye.axial_length) * 1e3 / (3.0 / 1.036 + 0.2337)
    assert 0.33 < per_d < 0.39


def test_lca_matches_the_chromatic_eye():
    """The model's chromatic difference of refraction 458 -> 632.8 nm against Thibos et
    al.'s fit to measured eyes: within 0.15 D (the spread of the eyes they fitted is about
    that; Navarro 1985 fitted the dispersion to the same kind of data)."""
    eye = SchematicEye()
    model = eye.refraction(0.0, 458.0) - eye.refraction(0.0, 632.8)
    measured = float(ocular_lca(458.0) - ocular_lca(632.8))
    assert model == pytest.approx(measured, abs=0.15), (model, measured)


def test_accommodation_is_monotone_and_inverted_exactly():
    """Navarro 1985's accommodation parameter A (D) raises the eye's power monotonically
    (by 1.22 D at A = 1 and 4.76 D at A = 5: A is the model's parameter, not the change
    of refraction), and ``accommodation_for`` finds the A that focuses a vergence to
    1e-9 D."""
    eye = SchematicEye()
    prev = eye.refraction(0.0)
    for a in (0.5, 1.0, 2.0, 4.0, 6.0, 8.0, 10.0):
        k = eye.refraction(a)
        assert k < prev
        assert eye.power(a) > eye.power(a - 0.5)
        assert eye.accommodation_for(k) == pytest.approx(a, abs=1e-9)
        prev = k
    assert eye.accommodation_for(-50.0) == eye.accommodation_max
    assert eye.accommodation_for(2.0) == 0.0


# ---------------------------------------------------------------------- optiland
optiland = pytest.importorskip("optiland", reason="optiland is a test extra")


def _optic(eye, accommodation, wavelength_nm, lens=None):
    """The same eye (and lens) in optiland, mm; returns (optic, offset: optiland z = world
    z (mm) + offset, index of the eye's last refracting surface)."""
    from optiland.materials import IdealMaterial
    from optiland.optic import Optic

    g = eye.geometry(accommodation)
    n = eye.indices(wavelength_nm, accommodation)
    surfaces = []
    if lens is None:
        offset = 5.0
        surfaces.append(dict(radius=np.inf, thickness=5.0))
    else:
        ct, vd = lens.center_thickness * 1e3, lens.pose.vertex_distance * 1e3
        offset = 5.0 + ct + vd
        nl = lens.material.n(wavelength_nm)
        surfaces += [dict(radius=np.inf, thickness=5.0),
                     dict(radius=1e3 / lens.front.curvature, conic=lens.front.conic,
                          thickness=ct, material=IdealMaterial(nl)),
                     dict(radius=1e3 / lens.back.curvature, conic=lens.back.conic,
                          thickness=vd)]
    z = g["z_mm"]
    names = ("cornea_front", "cornea_back", "lens_front", "lens_back", "retina")
    for i, name in enumerate(names):
        s = dict(radius=g[name][0], conic=g[name][1])
        if i < 4:
            s.update(thickness=z[i + 1] - z[i], material=IdealMaterial(n[i + 1]))
        if name == "lens_front":          # the stop is at its vertex
            s.update(is_stop=True)
        surfaces.append(s)
    with warnings.catch_warnings():       # optiland's API moves between releases
        warnings.simplefilter("ignore")
        op = Optic()
        op.add_surface(index=0, thickness=np.inf)
        for k, s in enumerate(surfaces, start=1):
            op.add_surface(index=k, **s)
        op.set_aperture("EPD", 4.0)
        op.set_field_type("angle")
        op.add_field(y=0)
        op.add_wavelength(wavelength_nm / 1e3, is_primary=True)
    return op, offset, len(surfaces) - 1


def _trace(op, starts_mm, dirs, wavelength_nm):
    """Real rays through the optic: per-surface positions (k, n, 3) and directions."""
    import optiland.backend as be
    from optiland.rays import RealRays

    n = len(starts_mm)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rays = RealRays(starts_mm[:, 0], starts_mm[:, 1], starts_mm[:, 2], dirs[:, 0],
                        dirs[:, 1], dirs[:, 2], np.ones(n), np.full(n, wavelength_nm / 1e3))
        sg = op.surface_group
        sg.trace(rays)
        pos = np.stack([be.to_numpy(sg.x), be.to_numpy(sg.y), be.to_numpy(sg.z)], -1)
        dr = np.stack([be.to_numpy(sg.L), be.to_numpy(sg.M), be.to_numpy(sg.N)], -1)
    return pos, dr


def _closest(p1, d1, p2, d2):
    """Midpoints of the closest approach of two lines (n, 3)."""
    w = p1 - p2
    a, b, c = (d1 * d1).sum(1), (d1 * d2).sum(1), (d2 * d2).sum(1)
    d, e = (d1 * w).sum(1), (d2 * w).sum(1)
    den = a * c - b * b
    s, t = (b * e - c * d) / den, (a * e - b * d) / den
    return 0.5 * (p1 + s[:, None] * d1 + p2 + t[:, None] * d2)


CASES = [  # (rx of eye and lens or None, object distance m, accommodation: None = fixation)
    ("plano", None, np.inf),
    ("plano", None, 0.25),
    ("-3.00", "-3.00", np.inf),
    ("-3.00", "-3.00", 0.4),
]


@pytest.mark.parametrize("eye_rx, lens_rx, distance", CASES)
def test_exact_trace_agrees_with_optiland(eye_rx, lens_rx, distance):
    """Retinal positions <= 1e-6 mm, the chief ray through the stop's centre (optiland's
    ray crosses the stop plane within 1e-9 mm of it) and the tangential and sagittal
    vergences behind the eye's last surface <= 1e-4 D against the foci of real-ray fans,
    0-40 deg off axis in three meridians, relaxed and accommodated."""
    eye = SchematicEye.from_rx(eye_rx)
    lens = None if lens_rx is None else SpectacleLens.from_rx(Prescription.parse(lens_rx))
    fx = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 14.0, 0.0, -25.0])
    fy = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 14.0, -30.0, 20.0])
    wl = 587.56
    r = trace_field(eye, lens, fx, fy, distance, wavelength_nm=wl)
    assert r.ok.all()
    acc = float(r.accommodation[0])
    if np.isfinite(distance):
        assert acc > 1.0
    op, offset, last = _optic(eye, acc, wl, lens)
    to_op = np.array([0.0, 0.0, offset])
    q = r.entry * 1e3 + to_op
    d = r.entry_dir
    pos, dirs = _trace(op, q - 2.0 * d, d, wl)
    retina = pos[-1] - to_op
    assert np.abs(retina - r.retina * 1e3).max() <= 1e-6
    # the stop plane (the lens's front vertex), crossed in the aqueous
    k_back = last - 2                                  # the cornea's back surface
    z_stop = eye.stop_z(acc) * 1e3 + offset
    s = (z_stop - pos[k_back, :, 2]) / dirs[k_back, :, 2]
    at_stop = pos[k_back] + s[:, None] * dirs[k_back]
    assert np.abs(at_stop[:, :2]).max() <= 1e-9
    # fans about each chief ray: tangential in the plane of the axis and the ray
    axis = np.array([0.0, 0.0, 1.0])
    t = axis - (d @ axis)[:, None] * d
    tn = np.linalg.norm(t, axis=1)
    t = np.where(tn[:, None] > 1e-12, t / np.where(tn > 1e-12, tn, 1)[:, None], [1.0, 0, 0])
    sv = np.cross(d, t)
    h = 2e-4                                            # mm
    n_vit = eye.indices(wl, acc)[-1]
    for j, e in enumerate((t, sv)):
        ends = []
        for sign in (1.0, -1.0):
            if np.isfinite(distance):
                obj = r.object_points.positions() * 1e3 + to_op
                aim = q + sign * h * e
                dd = (aim - obj) / np.linalg.norm(aim - obj, axis=1, keepdims=True)
                p, dr = _trace(op, obj, dd, wl)
            else:
                p, dr = _trace(op, q - 2.0 * d + sign * h * e, d, wl)
            ends.append((p[last], dr[last]))
        focus = _closest(ends[0][0], ends[0][1], ends[1][0], ends[1][1])
        along = ((focus - pos[last]) * dirs[last]).sum(1)       # mm from the last surface
        vergence = n_vit / (along * 1e-3)
        assert np.abs(vergence - r.image_vergence[:, j]).max() <= 1e-4, (j, vergence,
                                                                          r.image_vergence)


def test_map_and_analysis_agree():
    """The same line of sight found from its eye-side direction (the map) and from its
    object point (analysis) gives the same refraction to 1e-9 D."""
    eye = SchematicEye.from_rx("-3.00")
    lens = SpectacleLens.from_rx(Prescription.parse("-3.00"))
    r = trace_field(eye, lens, [0, 10, 20, 30, 40, -20], [0, 0, 10, -5, 0, 20])
    o = trace_objects(eye, lens, r.object_points, accommodation=r.accommodation)
    assert np.abs(o.refraction - r.refraction).max() <= 1e-9
    assert np.abs(o.retina - r.retina).max() <= 1e-12


def test_on_axis_refraction_is_paraxial():
    """Along the axis the chief ray's refraction is the paraxial one (both are the limit
    of a vanishing pupil), relaxed and accommodated, at three wavelengths."""
    for rx in ("plano", "-6.00", "+2.00"):
        eye = SchematicEye.from_rx(rx)
        for acc in (0.0, 3.0):
            for wl in (458.0, 587.56, 632.8):
                r = trace_field(eye, None, 0.0, 0.0, accommodation=acc, wavelength_nm=wl)
                assert r.m[0] == pytest.approx(eye.refraction(acc, wl), abs=1e-9)
                assert abs(r.j0[0]) < 1e-9 and abs(r.j45[0]) < 1e-9


def test_paraxial_eye_matches_optiland():
    """Power and entrance pupil against optiland's paraxial solve."""
    for acc in (0.0, 5.0):
        eye = SchematicEye()
        op, offset, _ = _optic(eye, acc, 589.3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            f1 = float(op.paraxial.f1())
            epl = float(op.paraxial.EPL())
        assert eye.power(acc, 589.3) == pytest.approx(-1e3 / f1, abs=1e-8)
        # optiland's entrance pupil is from its first surface (the dummy plane)
        assert eye.entrance_pupil(acc, 589.3)[0] * 1e3 == pytest.approx(epl - offset,
                                                                          abs=1e-9)
