"""What a lens designer reads from `eyelab analyze`, checked against independent real-ray
bundles: the wave at the lens exit (to 1e-6 D), the prism at the chief ray (to 0.01 Δ),
the vertex sphere stated, polar field angles, TABO axes in the lens plane, the power
error against the prescription, thicknesses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eyelab.jobs.analyze import analyze_spec, format_report
from eyelab.optics.chain.analysis import analyze_points
from eyelab.reference.bruteforce import extrapolated_vergence
from eyelab.spec import load_spec, parse_spec


def _extrapolated(lens, res, i, pupil, n_chief):
    return extrapolated_vergence(lens, res.chief.start[i], res.chief.dir_in[i],
                                 bool(np.isfinite(res.chief.object_distance_to_entry[i])),
                                 pupil, n_chief, res.eye_x[i])


def test_default_spec_exit_wave_and_prism_against_real_rays():
    spec = load_spec(None)
    res = analyze_points(spec.eye, spec.lens, spec.points, fixation=spec.fixation,
                         accommodation=spec.accommodation)
    rep = analyze_spec(spec)
    assert rep["vertex_sphere"]["centre"] == "rotation_centre"
    assert rep["vertex_sphere"]["radius_mm"] == pytest.approx(
        (spec.lens.pose.vertex_distance + spec.eye.rotation_centre) * 1e3)
    for i, p in enumerate(rep["points"]):
        if p["status"] != "ok":
            continue
        k_bf, _ = _extrapolated(spec.lens, res, i, res.chief.exit[i], res.wave_exit.N[i])
        k_en = np.array([k[i] for k in res.wave_exit.in_basis(res.eye_x)])
        assert np.abs(k_bf - k_en).max() < 1e-6, (i, k_bf, k_en)
        # prism: the mean deviation of a real pencil of rays around the chief ray
        lens = spec.lens
        d = res.chief.dir_in[i]
        tan = np.cross(d, [0.0, 1.0, 0.0])
        tan /= np.linalg.norm(tan)
        ups = np.cross(tan, d)
        offs = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]]) * 1e-5
        origins = res.chief.entry[i] - 0.01 * d + offs[:, :1] * tan + offs[:, 1:] * ups
        out = lens.trace(origins, np.broadcast_to(d, origins.shape).copy())["out_dirs"]
        ang = np.arccos(np.clip(out @ d, -1, 1)).mean()
        assert p["prism"]["prism_d"] == pytest.approx(100 * math.tan(ang), abs=0.01)


def test_polar_fields_tabo_axes_power_error_and_thickness():
    spec = parse_spec({
        "eye": {"rx": "-3.00 -1.00 x 30", "accommodation_max_d": 0},
        "lens": {"rx": "-3.00 -1.00 x 30"},
        "analysis": {"fixation": "rotating"},
        "points": [{"distance_m": "inf"}, {"distance_m": "inf",
                                           "field_polar_deg": [20.0, 90.0]}]})
    rep = analyze_spec(spec)
    on, up = rep["points"]
    # the lens's own Rx on axis: no power error, the cylinder's axis at 30 TABO
    assert abs(on["power_error"]["sphere_d"]) < 0.01
    assert abs(on["power_error"]["cylinder_d"]) < 0.01
    w = on["wavefront_at_exit"]
    axis = w["direction_1_tabo_deg"]
    # the weaker (less negative) principal vergence lies along the cylinder axis
    assert min(abs(axis - 30.0), abs(axis - 210.0)) < 0.5
    # polar angles: 20 deg up
    assert up["object"]["field_polar_deg"] == pytest.approx([20.0, 90.0])
    assert up["object"]["field_deg"][0] == pytest.approx(0.0, abs=1e-9)
    # looking 20 deg up through a minus lens: Prentice's prism (the power matrix times the
    # decentration in cm, base away from the centre), to 10 %, and an oblique-astigmatism
    # error
    c = np.array(up["chief_ray"]["exit_mm"][:2]) / 10.0
    prentice = -(spec.lens.rx.power_matrix() @ c)
    got = np.array([up["prism"]["base_right_d"], up["prism"]["base_up_d"]])
    assert got == pytest.approx(prentice, rel=0.1, abs=0.02)
    assert abs(up["power_error"]["cylinder_d"]) > 0.01
    lens = rep["lens"]
    assert lens["edge_thickness_mm"][0] > 1.0 and lens["center_thickness_mm"] >= 2.0


def test_pupil_vertex_sphere_and_surface_lens_report():
    spec = parse_spec({"lens": {"front": {"radius_mm": 100}, "back": {"radius_mm": 80},
                                "center_thickness_mm": 2.0},
                       "analysis": {"vertex_sphere": "pupil"}})
    rep = analyze_spec(spec)
    assert rep["vertex_sphere"] == {"centre": "pupil", "centre_mm": [0.0, 0.0, 0.0],
                                    "radius_mm": pytest.approx(12.0)}
    text = format_report(rep)
    assert "explicit surfaces" in text and "None" not in text
    assert "power_error" not in rep["points"][0]            # no prescription to compare


def test_a_surface_lens_before_a_schematic_eye_reports_as_before_a_thin_one():
    """The lens block is one for every eye: a lens given by its surfaces says so (never
    "lens: None") and carries its traced back vertex powers: for radii 100 / 80 mm, 2 mm
    thick, the thick lens's paraxial F1 / (1 - t F1 / n) + F2 (-1.212 D in CR-39)."""
    lens = {"front": {"radius_mm": 100}, "back": {"radius_mm": 80}, "center_thickness_mm": 2.0}
    reps = {m: analyze_spec(parse_spec({"eye": {"model": m}, "lens": lens}))
            for m in ("thin", "navarro")}
    assert reps["navarro"]["lens"] == reps["thin"]["lens"]
    ln = reps["navarro"]["lens"]
    assert ln["rx"] is None
    n = ln["n"]
    f1, f2 = (n - 1) / 0.100, (1 - n) / 0.080
    bvp = f1 / (1 - 0.002 * f1 / n) + f2
    assert ln["back_vertex_powers_d"] == pytest.approx([bvp] * 2, abs=1e-4)
    text = format_report(reps["navarro"])
    assert "lens: explicit surfaces" in text and "None" not in text
