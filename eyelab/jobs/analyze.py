"""Point analysis: the engine's public face (``eyelab analyze``).

:func:`analyze_spec` runs the full chain for a :class:`~eyelab.spec.Spec` and returns a
JSON-ready report; :func:`format_report` renders it for people.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from eyelab.core.fileio import with_units
from eyelab.jobs.points import (
    format_lens,
    format_lenslets,
    lens_info,
    lenslet_row,
    line_of_sight_lens,
    no_path_reason,
    object_row,
)
from eyelab.optics.chain.analysis import (
    analyze_points,
    chief_prism,
    lens_angle,
    power_error,
    principal_angles,
    prism_row,
    status_text,
)
from eyelab.optics.eye.aberrations import point_power_matrix
from eyelab.optics.eye.prescription import power_row, tabo_axis
from eyelab.optics.eye.thin import Eye
from eyelab.optics.rays.trace import Status
from eyelab.spec import Spec, no_camera
from eyelab.spec.schema import FIXATION_MEANINGS


def _v(a):
    return [float(x) for x in a]


def _principal(wave, x_axis, i, lens=None):
    k1, k2, ang = principal_angles(wave, x_axis)
    out = {"vergence_1_d": float(k1[i]), "vergence_2_d": float(k2[i]),
           "direction_1_deg": float(np.degrees(ang[i])),
           "mean_d": float(0.5 * (k1[i] + k2[i])), "cylinder_d": float(k2[i] - k1[i])}
    if lens is not None:
        y_axis = np.cross(wave.N[i], x_axis[i])
        e1 = math.cos(ang[i]) * x_axis[i] + math.sin(ang[i]) * y_axis
        out["direction_1_tabo_deg"] = tabo_axis(lens_angle(lens, e1) % 180.0)
    return out


def analyze_spec(spec: Spec, *, no_lens: bool = False) -> dict:
    """Run the chain for every point of ``spec``; returns a JSON-serialisable dict, its
    first key ``"units"`` (:data:`eyelab.core.fileio.REPORT_UNITS`: each key names its
    unit by suffix, ``_mm``, ``_um``, ``_arcmin``, ``_deg``, ``_d`` (dioptres), ...).
    Directions and vergences are given in the eye's (x, y) frame of §4.4.1: x horizontal
    (the wearer's right for a straight-ahead gaze), y up, angles counter-clockwise seen
    from behind the wearer. A binocular spec gives :func:`analyze_binocular_spec`'s report.
    """
    no_camera(spec, "analyze")
    if spec.binocular is not None:
        return with_units(analyze_binocular_spec(spec, no_lens=no_lens))
    if not isinstance(spec.eye, Eye):                   # a schematic eye: exact traces
        from eyelab.jobs.retinal import schematic_report

        return with_units(schematic_report(spec, no_lens=no_lens))
    lens = None if no_lens else spec.lens
    res = analyze_points(spec.eye, line_of_sight_lens(lens), spec.points,
                         wavelength_nm=spec.wavelength_nm, fixation=spec.fixation,
                         accommodation=spec.accommodation, vertex_sphere=spec.vertex_sphere)
    report = {"source": spec.source}
    report.update(_eye_report(spec.eye, lens, res, spec.points, spec))
    return with_units(report)


def eye_table(eye) -> dict:
    """The ``[eye]`` spec keys that make ``eye`` (an :class:`~eyelab.optics.eye.thin.Eye`), in
    the spec's units (D, deg, mm): how reports write an eye. ``aberrations`` (the
    ``[eye.aberrations]`` keys) only where the eye has them."""
    import dataclasses

    out = eye.spec_keys()
    if eye.aberrations is not None:
        a = dataclasses.asdict(eye.aberrations)
        out["aberrations"] = dict(a, coefficients_um=list(a["coefficients_um"]))
    return out


def _eye_report(eye, lens, res, points, spec) -> dict:
    """One eye's part of the report: eye, lens, vertex sphere, settings and points (the
    points' objects as this eye's frame holds them)."""
    maj, mnr, ang = res.blur_axes()
    if lens is not None:
        prism, deviation = chief_prism(res)
        # the power error against the prescription (none for surface-by-surface lenses)
        err = None if lens.rx is None else power_error(res, lens.rx, points)
    out_points = []
    for i in range(len(points)):
        st = int(res.status[i])
        entry = {"index": i, "status": status_text(st), "object": object_row(points, i)}
        if st & int(Status.MISSED | Status.TIR | Status.NOT_CONVERGED | Status.BEHIND):
            entry["reason"] = no_path_reason(st)
            out_points.append(entry)
            continue
        ch = res.chief
        path = {"direction_to_eye": _v(ch.dir_out[i]),
                "pupil_mm": _v(res.pupil[i] * 1e3),
                "path_residual_rad": float(ch.residual[i]),
                "path_iterations": int(ch.iterations[i])}
        if lens is not None:
            path.update({"entry_mm": _v(ch.entry[i] * 1e3), "exit_mm": _v(ch.exit[i] * 1e3),
                         "direction_in": _v(ch.dir_in[i]),
                         "direction_in_glass": _v(ch.dir_glass[i])})
        entry["chief_ray"] = path
        entry["wavefront_at_eye"] = _principal(res.wave_eye, res.eye_x, i)
        if lens is not None:
            entry["wavefront_at_exit"] = _principal(res.wave_exit, res.eye_x, i, lens)
            entry["wavefront_at_vertex_sphere"] = _principal(res.wave_vertex_sphere,
                                                             res.eye_x, i, lens)
            entry["prism"] = prism_row(prism[i], deviation[i], lens)
            if err is not None:
                entry["power_error"] = power_row(
                    err["sphere_d"][i], err["cylinder_d"][i],
                    tabo_axis(float(err["axis_wearer_deg"][i])), err["mean_d"][i])
        entry["accommodation_d"] = float(res.accommodation[i])
        entry["blur"] = {
            "major_um": float(maj[i] * 1e6), "minor_um": float(mnr[i] * 1e6),
            "major_arcmin": float(res.to_arcmin(maj[i])),
            "minor_arcmin": float(res.to_arcmin(mnr[i])),
            "major_axis_deg": float(np.degrees(ang[i])),
            "a_um": float(res.a[i] * 1e6), "b_um": float(res.b[i] * 1e6),
            "omega_deg": float(np.degrees(res.omega[i])),
            "matrix_um": (res.retina_matrix[i] * 1e6).tolist(),
        }
        entry["wave"] = _wave(eye, res, i, spec.wavelength_nm)
        if lens is not None and lens.has_lenslets:
            m = point_power_matrix(eye, res, i, spec.wavelength_nm)
            entry["lenslets"] = lenslet_row(lens, points, i, res.pupil[i], ch.dir_out[i],
                                            eye.pupil_diameter / 2, spec.wavelength_nm,
                                            entry=ch.entry[i],
                                            carrier_defocus_d=0.5 * (m[0] + m[2]))
        out_points.append(entry)
    k1, k2 = eye.refraction()
    return {
        "eye": dict(eye_table(eye), far_point_vergence_d=[k1, k2]),
        "lens": None if lens is None else lens_info(lens, spec.wavelength_nm),
        "vertex_sphere": None if res.vertex_sphere is None else {
            "centre": res.vertex_sphere["centre"],
            "centre_mm": _v(np.asarray(res.vertex_sphere["centre_m"]) * 1e3),
            "radius_mm": res.vertex_sphere["radius_m"] * 1e3},
        "wavelength_nm": spec.wavelength_nm,
        "fixation": spec.fixation,
        "fixation_meaning": FIXATION_MEANINGS[spec.fixation],
        "accommodation": "best effort (Kakimoto Eq. 13)" if spec.accommodation is None
        else spec.accommodation,
        "points": out_points,
    }


def _wave(eye, res, i, wavelength_nm) -> dict:
    """Point ``i``'s wave aberration over the eye's pupil: its RMS (um; orders >= 2, the
    eye's defocus and astigmatism for the point included) and that of the eye's higher
    orders, and the Strehl ratio (diffraction included; None past the PSF's grid)."""
    from eyelab.optics.eye import zernike as zk
    from eyelab.optics.eye.aberrations import point_strehl, point_wave

    c = point_wave(eye, res, i, wavelength_nm)
    return {"rms_um": zk.rms(c, from_order=2), "rms_higher_orders_um": zk.rms(c, from_order=3),
            "strehl": point_strehl(eye, c, wavelength_nm), "pupil_mm": eye.pupil_diameter * 1e3}


def analyze_binocular_spec(spec: Spec, *, no_lens: bool = False) -> dict:
    """Both eyes of a binocular spec (:mod:`eyelab.optics.chain.binocular`): the points are in
    the head frame (the cyclopean pupil at the origin); each eye's report as :func:`analyze_spec`
    gives it (objects in that eye's frame), with one accommodative response per point
    (the less-blurred-eye rule, or ``eye.accommodation_d``) and the binocular prism
    (total horizontal base out, vertical imbalance) at each point."""
    from eyelab.optics.chain.binocular import SIDES, analyze_binocular, prism_rows

    b = spec.binocular
    traced = dataclasses.replace(b, right_lens=line_of_sight_lens(b.right_lens),
                                 left_lens=line_of_sight_lens(b.left_lens))
    an = analyze_binocular(traced, spec.points, wavelength_nm=spec.wavelength_nm,
                           fixation=spec.fixation, accommodation=spec.accommodation,
                           vertex_sphere=spec.vertex_sphere, no_lens=no_lens)
    if isinstance(b.right, Eye):
        eyes = {s: _eye_report(b.eye(s), None if no_lens else b.lens(s), an[s],
                               an["points"][s], spec) for s in SIDES}
    else:                                   # schematic eyes: their exact traces' rows
        from eyelab.jobs.retinal import schematic_eye_report

        eyes = {s: dict(schematic_eye_report(b.eye(s), None if no_lens else b.lens(s),
                                             an[s], spec), accommodation="shared (below)")
                for s in SIDES}
    points = []
    for i in range(len(spec.points)):
        row = {"index": i, "object": object_row(spec.points, i),
               "accommodation_d": float(an["accommodation_d"][i]),
               "driving_eye": str(an["driving_eye"][i])}
        prism = None if no_lens else prism_rows(b, an, i)
        if prism is not None:
            row["prism"] = prism
        points.append(row)
    return {"source": spec.source, "binocular": {
        "monocular_pd_mm": [v * 1e3 for v in b.monocular_pd],
        "frame_pd_mm": None if b.frame_pd is None or no_lens else b.frame_pd * 1e3,
        "fixation": spec.fixation,
        "fixation_meaning": FIXATION_MEANINGS[spec.fixation],
        "accommodation": "fixed" if spec.accommodation is not None else
        "less-blurred eye (Toor et al. 2018)"},
        "points": points, "eyes": eyes}


def format_report(rep: dict) -> str:
    """Human-readable text of a report from :func:`analyze_spec`."""
    if "binocular" in rep:
        return _format_binocular(rep)
    if rep["eye"].get("model", "thin") != "thin":
        from eyelab.jobs.retinal import format_schematic

        return format_schematic(rep)
    return "\n".join([f"eyelab analyze — {rep['source']}", *_format_eye(rep)])


def _format_binocular(rep: dict) -> str:
    b = rep["binocular"]
    lines = [f"eyelab analyze — {rep['source']} (binocular)",
             "monocular PDs {:.1f} / {:.1f} mm (right / left)".format(*b["monocular_pd_mm"])
             + ("" if b["frame_pd_mm"] is None else f", frame PD {b['frame_pd_mm']:.1f} mm")
             + f"; accommodation {b['accommodation']}",
             f"fixation {b['fixation']}: {b['fixation_meaning']}"]
    for p in rep["points"]:
        o = p["object"]
        dist = o["distance_m"] if o["distance_m"] == "inf" else f"{o['distance_m']:g} m"
        line = (f"point {p['index']}: {dist} at ({o['field_deg'][0]:+.1f}, "
                f"{o['field_deg'][1]:+.1f}) deg from the cyclopean eye: accommodation "
                f"{p['accommodation_d']:.3f} D ({p['driving_eye']})")
        if "prism" in p:
            pr = p["prism"]
            line += (f"; induced prism {pr['binocular']['horizontal']}, "
                     f"{pr['binocular']['vertical']} (right {pr['right']['prism_d']:.2f} Δ "
                     f"base {pr['right']['base_deg']:.0f} deg, left {pr['left']['prism_d']:.2f}"
                     f" Δ base {pr['left']['base_deg']:.0f} deg)")
        lines.append(line)
    for side, eye_rep in rep["eyes"].items():
        lines.append(f"\n— {side} eye —")
        if eye_rep["eye"].get("model", "thin") != "thin":
            from eyelab.jobs.retinal import schematic_eye_lines

            lines.extend(schematic_eye_lines(eye_rep))
        else:
            lines.extend(_format_eye(eye_rep))
    return "\n".join(lines)


def _format_eye(rep: dict) -> list:
    lines = []
    e = rep["eye"]
    lines.append(f"eye: P_min {e['power_min_d']:.3f} D, astigmatism {e['astigmatism_d']:.3f} D "
                 f"@ {e['astigmatism_axis_deg']:.1f} deg, amplitude {e['accommodation_max_d']:.2f} "
                 f"D, pupil {e['pupil_diameter_mm']:.2f} mm, far-point vergences "
                 f"{e['far_point_vergence_d'][0]:+.3f} / {e['far_point_vergence_d'][1]:+.3f} D")
    lines.append(format_lens(rep["lens"]))
    if rep["lens"] is not None:
        vs = rep["vertex_sphere"]
        lines.append(f"vertex sphere: centred on the {vs['centre'].replace('_', ' ')}, radius "
                     f"{vs['radius_mm']:.2f} mm")
    lines.append(f"wavelength {rep['wavelength_nm']} nm, accommodation "
                 f"{rep['accommodation']}")
    lines.append(f"fixation {rep['fixation']}: {rep['fixation_meaning']}")
    for p in rep["points"]:
        o = p["object"]
        dist = o["distance_m"] if o["distance_m"] == "inf" else f"{o['distance_m']:g} m"
        lines.append(f"\npoint {p['index']}: {dist} at field ({o['field_deg'][0]:+.1f}, "
                     f"{o['field_deg'][1]:+.1f}) deg — {p['status']}")
        if "reason" in p:
            lines.append(f"  {p['reason']}")
            continue
        c = p["chief_ray"]
        if "entry_mm" in c:
            lines.append("  chief ray: enters lens at ({:+.2f}, {:+.2f}, {:+.2f}) mm, leaves at "
                         "({:+.2f}, {:+.2f}, {:+.2f}) mm; residual {:.1e} rad in {} it."
                         .format(*c["entry_mm"], *c["exit_mm"], c["path_residual_rad"],
                                 c["path_iterations"]))
        for key, label in (("wavefront_at_exit", "wavefront at lens exit"),
                           ("wavefront_at_vertex_sphere", "at vertex sphere"),
                           ("wavefront_at_eye", "at eye")):
            if key in p:
                w = p[key]
                lines.append(f"  {label}: vergences {w['vergence_1_d']:+.4f} D @ "
                             f"{w['direction_1_deg']:.1f} deg, {w['vergence_2_d']:+.4f} D "
                             f"(mean {w['mean_d']:+.4f}, cyl {w['cylinder_d']:+.4f})")
        if "prism" in p:
            pr = p["prism"]
            lines.append(f"  prism {pr['prism_d']:.3f} Δ base {pr['base_deg']:.0f} deg "
                         f"(right {pr['base_right_d']:+.3f}, up {pr['base_up_d']:+.3f} Δ)")
        if "power_error" in p:
            pe = p["power_error"]
            cyl = (f" / {pe['cylinder_d']:+.3f} x {pe['axis_tabo_deg']:.0f}"
                   if pe["axis_tabo_deg"] is not None else " DS")
            lines.append(f"  power error vs the Rx: {pe['sphere_d']:+.3f}{cyl} "
                         f"(mean {pe['mean_d']:+.3f} D)")
        b = p["blur"]
        lines.append(f"  accommodation {p['accommodation_d']:.3f} D; retinal blur ellipse "
                     f"{b['major_um']:.2f} x {b['minor_um']:.2f} um semi-axes "
                     f"({b['major_arcmin']:.2f}' x {b['minor_arcmin']:.2f}'), major axis "
                     f"{b['major_axis_deg']:.1f} deg")
        if "lenslets" in p:
            lines.append(format_lenslets(p["lenslets"]))
        if "wave" in p:
            w = p["wave"]
            strehl = "n/a" if w["strehl"] is None else f"{w['strehl']:.3f}"
            lines.append(f"  wave aberration over the {w['pupil_mm']:g} mm pupil: RMS "
                         f"{w['rms_um']:.3f} um (higher orders {w['rms_higher_orders_um']:.3f}"
                         f" um), Strehl ratio {strehl}")
    return lines
