"""A schematic eye's point analysis and its peripheral refraction over the visual field
(:mod:`eyelab.optics.chain.retina`): the JSON reports of ``eyelab analyze`` and ``eyelab
maps --kind peripheral``, their text, and the map's figure (matplotlib).

Peripheral refraction is what myopia research measures: the refraction M, J0, J45 (power
vectors, Thibos et al. 1997) along each line of sight while the eye fixates straight
ahead, and the relative peripheral refraction RPR = M - M(on axis). Its tangential and
sagittal parts are the refraction across and along the meridian.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.jobs.points import (
    format_lens,
    format_lenslets,
    lens_info,
    lenslet_row,
    line_of_sight_lens,
    no_path_reason,
    object_row,
)
from eyelab.optics.chain.retina import RetinalTrace, trace_field, trace_objects
from eyelab.optics.chain.retinal_wave import retinal_waves
from eyelab.optics.rays.trace import Status

#: The quantities of a line of sight, by report key: what each means (units by suffix).
DEFINITIONS = {
    "m_d": "spherical equivalent of the refraction along the line of sight (D; negative: "
           "myopic), where the chief ray crosses the corneal vertex plane",
    "j0_d, j45_d": "the refraction's Jackson cross-cylinders (Thibos et al. 1997) in the "
                   "eye's frame: x the wearer's right, y up",
    "tangential_d, sagittal_d": "the refraction across and along the meridian of the "
                                "field point (the astigmatic foci's directions)",
    "rpr_d": "relative peripheral refraction: m_d less m_d on the eye's axis",
    "focus_behind_retina_mm": "where the tangential and sagittal focal lines lie along the "
                              "chief ray, behind the retina (negative: in front of it)",
    "retina_mm": "where the chief ray lands on the retina, in the eye's frame (the corneal "
                 "vertex at the origin, z toward the retina)",
    "rms_um, rms_higher_um": "the wave aberration's RMS over the pupil (the stop), all of "
                             "it and with defocus, astigmatism and tilts removed: the wave "
                             "a point source at the retinal point sends out through eye and "
                             "lens, against the object's (ANSI Z80.28 sign)",
    "strehl": "the point-spread function's peak over the aberration-free peak of the same "
              "pupil, at the wavelength (wherever the peak lies)",
    "through_focus": "with lenslets: the intensity at the chief ray's image point over the "
                     "aberration-free one (|sum of the pupil's amplitudes|^2: the same pupil, "
                     "its lenslets' light and dark rims included), with the retina moved to "
                     "where a wave vergence_d "
                     "more converging at the entrance pupil focuses (the forward wave); "
                     "peaks: the carrier's image and the lenslets'",
    "share, myopic_defocus_d": "maps --kind peripheral through lenslets (lens.lenslets): "
                               "the share of the pupil's light through them, and the defocus "
                               "of their image at the retina: their add as worn less m_d "
                               "through the carrier (positive: in front of the retina)",
    "object_field_deg": "the object's field angles as seen from the eye's corneal vertex "
                        "(through a lens the line of sight is bent: this is where it points)",
}


def _row(r: RetinalTrace, i: int, wave=None) -> dict:
    """Line of sight ``i``'s report row; with its :class:`~eyelab.optics.chain.retinal_wave.
    RetinalWave`, the wave's measures too."""
    obj = r.object_points
    d = obj.direction[i]
    measures = {} if wave is None else {
        "rms_um": wave.rms * 1e6, "rms_higher_um": wave.rms_higher * 1e6,
        "strehl": wave.strehl}
    return {
        "object_field_deg": [math.degrees(math.atan2(d[0], -d[2])),
                             math.degrees(math.atan2(d[1], -d[2]))],
        "field_deg": [float(v) for v in r.field_deg[i]],
        "eccentricity_deg": float(r.eccentricity_deg[i]),
        "meridian_deg": float(r.meridian_deg[i]),
        "accommodation_d": float(r.accommodation[i]),
        "m_d": float(r.m[i]), "j0_d": float(r.j0[i]), "j45_d": float(r.j45[i]),
        "tangential_d": float(r.tangential[i]), "sagittal_d": float(r.sagittal[i]),
        "focus_behind_retina_mm": [float(v) * 1e3 for v in r.focus[i]],
        "image_vergence_d": [float(v) for v in r.image_vergence[i]],
        "retina_mm": [float(v) * 1e3 for v in r.retina[i]],
    } | measures


def schematic_report(spec, *, no_lens: bool = False) -> dict:
    """``eyelab analyze`` of a spec whose eye is schematic: per point, the real chief ray to
    the retina and the refraction along it (:data:`DEFINITIONS`), naked (``no_lens``) or
    through the spec's lens; fixation and accommodation as the spec says (``auto``:
    the fixation's accommodation at each point's distance)."""
    eye = spec.eye
    lens = None if no_lens else spec.lens
    r = trace_objects(eye, line_of_sight_lens(lens), spec.points, fixation=spec.fixation,
                      accommodation=spec.accommodation, wavelength_nm=spec.wavelength_nm)
    return dict({"source": spec.source}, **schematic_eye_report(eye, lens, r, spec))


def schematic_eye_report(eye, lens, r: RetinalTrace, spec) -> dict:
    """One schematic eye's part of analyze's report from its trace ``r`` (through ``lens``'s
    carrier, the points in the eye's frame: one eye's, or a side's of two): the eye, the
    lens, and per point its row (:data:`DEFINITIONS`), the wave along it and, through
    lenslets, their share and the image through focus."""
    waves = retinal_waves(eye, line_of_sight_lens(lens), r, fixation=spec.fixation,
                          wavelength_nm=spec.wavelength_nm)
    points = []
    for i in range(len(r.status)):
        st = int(r.status[i])
        entry = {"index": i, "status": Status.describe(st),
                 "object": object_row(r.object_points, i)}
        if not r.ok[i]:
            entry["reason"] = no_path_reason(st)
        else:
            entry.update(_row(r, i, waves[i]))
            if lens is not None and lens.has_lenslets:
                entry["lenslets"] = _lenslets(eye, lens, r, i, spec)
                entry["through_focus"] = _through_focus(eye, lens, r, i, spec)
        points.append(entry)
    return {"eye": dict(eye.spec_keys(), **_eye_optics(eye, spec)),
            "lens": None if lens is None else lens_info(lens, spec.wavelength_nm),
            "wavelength_nm": spec.wavelength_nm, "fixation": spec.fixation,
            "accommodation": "the fixation's: the eye focuses the object on its axis at each "
            "point's distance (paraxially)" if spec.accommodation is None
            else spec.accommodation,
            "definitions": DEFINITIONS, "points": points}


def _lenslets(eye, lens, r: RetinalTrace, i: int, spec) -> dict:
    """Line of sight ``i``'s beam through the lens's lenslets, over the entrance pupil."""
    from eyelab.optics.chain.retina import eye_in_world

    rot, vertex = eye_in_world(eye, spec.fixation, r.eye_dir[i])
    z_ep, _ = eye.entrance_pupil(float(r.accommodation[i]), spec.wavelength_nm)
    return lenslet_row(lens, r.object_points, i, vertex + rot @ np.array([0.0, 0.0, z_ep]),
                       r.eye_dir[i], eye.pupil_diameter / 2, spec.wavelength_nm)


#: The through-focus range (D) beyond the lenslets' add and its step.
FOCUS_MARGIN_D, FOCUS_STEP_D = 1.5, 0.05


def _through_focus(eye, lens, r: RetinalTrace, i: int, spec) -> dict:
    """Line of sight ``i``'s image through focus (the forward wave,
    :mod:`eyelab.optics.chain.forward_wave`): from -1.5 D to the add + 1.5 D."""
    from eyelab.optics.chain.forward_wave import focus_peaks, forward_wave, through_focus
    from eyelab.optics.chain.retina import eye_in_world

    rot, vertex = eye_in_world(eye, spec.fixation, r.eye_dir[i])
    wave = forward_wave(eye, lens, rot, vertex, r.object_points, i,
                        float(r.accommodation[i]), wavelength_nm=spec.wavelength_nm)
    add = lens.front.add_d
    lo, hi = min(0.0, add) - FOCUS_MARGIN_D, max(0.0, add) + FOCUS_MARGIN_D
    tf = through_focus(wave, np.round(np.arange(lo, hi + 1e-9, FOCUS_STEP_D), 10))
    return dict(tf, peaks=focus_peaks(tf))


def _eye_optics(eye, spec) -> dict:
    wl = spec.wavelength_nm
    z_ep, mag = eye.entrance_pupil(0.0, wl)
    return {"refraction_d": eye.refraction(0.0, wl), "power_d": eye.power(0.0, wl),
            "entrance_pupil_mm": z_ep * 1e3, "stop_radius_mm": eye.stop_radius(0.0, wl) * 1e3}


def format_schematic(rep: dict) -> str:
    """The text of :func:`schematic_report`."""
    return "\n".join([f"eyelab analyze — {rep['source']}", *schematic_eye_lines(rep)])


def schematic_eye_lines(rep: dict) -> list:
    """The text lines of :func:`schematic_eye_report`'s part of a report."""
    e = rep["eye"]
    lines = [f"eye: {e['model']} schematic eye, axial length {e['axial_length_mm']:.3f} mm, "
             f"paraxial refraction {e['refraction_d']:+.3f} D, power {e['power_d']:.3f} D, "
             f"entrance pupil {e['pupil_diameter_mm']:.2f} mm at {e['entrance_pupil_mm']:.3f}"
             " mm",
             format_lens(rep["lens"]),
             f"wavelength {rep['wavelength_nm']} nm, fixation {rep['fixation']}, "
             f"accommodation {rep['accommodation']}"]
    for p in rep["points"]:
        o = p["object"]
        dist = o["distance_m"] if o["distance_m"] == "inf" else f"{o['distance_m']:g} m"
        lines.append(f"\npoint {p['index']}: {dist} at field ({o['field_deg'][0]:+.1f}, "
                     f"{o['field_deg'][1]:+.1f}) deg — {p['status']}")
        if "reason" in p:
            lines.append(f"  {p['reason']}")
            continue
        lines.append(f"  on the retina at ({p['retina_mm'][0]:+.3f}, {p['retina_mm'][1]:+.3f},"
                     f" {p['retina_mm'][2]:.3f}) mm, {p['eccentricity_deg']:.2f} deg off axis;"
                     f" accommodation {p['accommodation_d']:.3f} D")
        lines.append(f"  refraction M {p['m_d']:+.3f} D, J0 {p['j0_d']:+.3f}, J45 "
                     f"{p['j45_d']:+.3f}; tangential {p['tangential_d']:+.3f}, sagittal "
                     f"{p['sagittal_d']:+.3f} D; focal lines "
                     "{:+.3f} / {:+.3f} mm behind the retina".format(
                         *p["focus_behind_retina_mm"]))
        lines.append(f"  wave RMS {p['rms_um']:.3f} um ({p['rms_higher_um']:.3f} um above "
                     f"second order), Strehl ratio {p['strehl']:.3f}")
        if "lenslets" in p:
            lines.append(format_lenslets(p["lenslets"]))
        if "through_focus" in p:
            peaks = ", ".join(f"{v:+.2f} D ({a:.3f})" for v, a in p["through_focus"]["peaks"])
            lines.append(f"  through focus (intensity at the image point over the "
                         f"aberration-free peak): peaks at {peaks}")
    return lines


# ------------------------------------------------------------------ peripheral map
def peripheral_map(spec, *, half_angle_deg: float = 40.0, n: int = 33,
                   distance_m: float = math.inf) -> dict:
    """Peripheral refraction over the visual field of the spec's schematic eye fixating
    straight ahead, naked and (where the spec has one) through its lens: an n x n grid of
    field angles within +-``half_angle_deg`` and 1-degree profiles along the horizontal
    and vertical meridians, objects at ``distance_m``. The accommodation is the spec's
    ``eye.accommodation_d``, else the one that focuses the straight-ahead object (naked
    and through the lens each its own)."""
    from eyelab.core.checks import check_in

    check_in("maps.half_angle_deg", half_angle_deg, {"maps.half_angle_deg": (1.0, 60.0)})
    check_in("maps.n", n, {"maps.n": (3, 201)})
    grid = np.linspace(-half_angle_deg, half_angle_deg, int(n))
    gx, gy = np.meshgrid(grid, grid)
    line = np.arange(-math.floor(half_angle_deg), math.floor(half_angle_deg) + 1.0)
    out = {"source": spec.source, "eye": spec.eye.spec_keys(),
           "distance_m": "inf" if math.isinf(distance_m) else distance_m,
           "wavelength_nm": spec.wavelength_nm, "definitions": DEFINITIONS,
           "grid": {"field_x_deg": grid.tolist(), "field_y_deg": grid.tolist()}}
    from eyelab.optics.lens.lenslets import carrier

    for name, lens in (("naked", None), ("lens", carrier(spec.lens))):
        if name == "lens" and lens is None:
            out[name] = None
            continue
        kw = dict(accommodation=spec.accommodation, wavelength_nm=spec.wavelength_nm)
        field = trace_field(spec.eye, lens, gx.ravel(), gy.ravel(), distance_m, **kw)
        acc = float(field.accommodation[0])
        kw["accommodation"] = acc
        m0 = float(trace_field(spec.eye, lens, 0.0, 0.0, distance_m, **kw).m[0])
        part = {"accommodation_d": acc, "m_on_axis_d": m0}
        for key, v in (("m_d", field.m), ("j0_d", field.j0), ("j45_d", field.j45),
                       ("tangential_d", field.tangential), ("sagittal_d", field.sagittal),
                       ("rpr_d", field.m - m0)):
            part[key] = np.where(np.isfinite(v), v, np.nan).reshape(gx.shape).tolist()
        part["profiles"] = {}
        for meridian, (fx, fy) in (("horizontal", (line, 0.0 * line)),
                                   ("vertical", (0.0 * line, line))):
            prof = trace_field(spec.eye, lens, fx, fy, distance_m, **kw)
            part["profiles"][meridian] = {"field_deg": line.tolist(),
                                          "points": [dict(_row(prof, i), rpr_d=float(
                                              prof.m[i] - m0)) for i in range(len(line))]}
        if name == "lens" and spec.lens.has_lenslets:
            part["lenslets"] = lenslet_map(spec, field, gx.shape)
        out[name] = part
    return out


#: Rays across a map point's beam (:func:`~eyelab.optics.lens.lenslets.beam_lenslets`'
#: grid): ~700 in a 4 mm pupil, the share to about 0.01.
MAP_BEAM_GRID = 48


def lenslet_map(spec, field: RetinalTrace, shape) -> dict:
    """The myopic defocus a lenslet lens puts on the retina over the visual field (the
    field's lines of sight through the carrier, ``shape`` their grid): per point the share
    of the pupil's light through lenslets (:func:`~eyelab.optics.lens.lenslets.
    beam_lenslets`, :data:`MAP_BEAM_GRID` rays across) and the defocus of their image at
    the retina, the lenslets' add as worn less the refraction M through the carrier (D;
    positive: focused in front of the retina, myopic), where any light passes them."""
    from eyelab.optics.chain.retina import eye_in_world
    from eyelab.optics.lens.lenslets import beam_lenslets

    eye, lens = spec.eye, spec.lens
    share = np.full(len(field.m), np.nan)
    for i in np.flatnonzero(field.status == 0):
        rot, vertex = eye_in_world(eye, "fixed", field.eye_dir[i])
        z_ep, _ = eye.entrance_pupil(float(field.accommodation[i]), spec.wavelength_nm)
        share[i] = beam_lenslets(lens, field.object_points, int(i), vertex + rot @ np.array(
            [0.0, 0.0, z_ep]), field.eye_dir[i], eye.pupil_diameter / 2, spec.wavelength_nm,
            grid=MAP_BEAM_GRID, entry=field.entry[i])["fraction"]
    defocus = np.where(share > 0, lens.front.add_d - field.m, np.nan)
    return {"add_d": lens.front.add_d, "beam_grid": MAP_BEAM_GRID,
            "share": share.reshape(shape).tolist(),
            "myopic_defocus_d": defocus.reshape(shape).tolist()}


def plot_peripheral(rep: dict, path, title: str) -> None:
    """The map's figure: M and RPR along both meridians, the tangential and sagittal
    refraction along the horizontal one (naked dashed, through the lens solid), and RPR
    over the visual field (through the lens where there is one)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5), constrained_layout=True)
    parts = [(k, rep[k]) for k in ("naked", "lens") if rep[k] is not None]
    style = {"naked": "--", "lens": "-"}
    label = {"naked": "naked eye", "lens": "through the lens"}
    for name, part in parts:
        for meridian, colour in (("horizontal", "tab:blue"), ("vertical", "tab:green")):
            prof = part["profiles"][meridian]
            x = prof["field_deg"]
            lw = 3.0 if meridian == "horizontal" else 1.3    # both seen where they agree
            axes[0, 0].plot(x, [p["m_d"] for p in prof["points"]], style[name], color=colour,
                            lw=lw, label=f"{label[name]}, {meridian}")
            axes[0, 1].plot(x, [p["rpr_d"] for p in prof["points"]], style[name],
                            color=colour, lw=lw, label=f"{label[name]}, {meridian}")
        prof = part["profiles"]["horizontal"]
        x = prof["field_deg"]
        axes[1, 0].plot(x, [p["tangential_d"] for p in prof["points"]], style[name],
                        color="tab:red", label=f"tangential, {label[name]}")
        axes[1, 0].plot(x, [p["sagittal_d"] for p in prof["points"]], style[name],
                        color="tab:purple", label=f"sagittal, {label[name]}")
    for ax, ylabel in ((axes[0, 0], "M (D)"), (axes[0, 1], "relative peripheral refraction "
                                                            "(D)"),
                       (axes[1, 0], "refraction, horizontal meridian (D)")):
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_xlabel("field angle (deg; + toward the wearer's right / up)")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    name, part = parts[-1]
    g = rep["grid"]
    if "lenslets" in part:
        _plot_lenslet_map(axes[1, 1], fig, g, part["lenslets"])
        fig.suptitle(title, fontsize=11)
        fig.savefig(path, dpi=100, format="png")
        plt.close(fig)
        return
    rpr = np.array(part["rpr_d"], float)
    lim = max(0.25, float(np.nanmax(np.abs(rpr))))
    im = axes[1, 1].contourf(g["field_x_deg"], g["field_y_deg"], rpr, levels=np.linspace(
        -lim, lim, 21), cmap="RdBu_r")
    cs = axes[1, 1].contour(g["field_x_deg"], g["field_y_deg"], rpr, levels=np.arange(
        -math.floor(lim), math.floor(lim) + 0.5, 0.5), colors="k", linewidths=0.6)
    axes[1, 1].clabel(cs, fontsize=7, fmt="%+.1f")
    axes[1, 1].set_aspect("equal")
    axes[1, 1].set_xlabel("field x (deg, + toward the wearer's right)")
    axes[1, 1].set_ylabel("field y (deg, + up)")
    axes[1, 1].set_title(f"RPR {label[name]} (D; + hyperopic)", fontsize=10)
    fig.colorbar(im, ax=axes[1, 1], shrink=0.85)
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


def _plot_lenslet_map(ax, fig, g, lm) -> None:
    """The share of the pupil's light through lenslets over the visual field, with contours
    of their image's myopic defocus."""
    share = np.array(lm["share"], float)
    im = ax.contourf(g["field_x_deg"], g["field_y_deg"], share, levels=np.linspace(0, 1, 11),
                     cmap="viridis")
    defocus = np.array(lm["myopic_defocus_d"], float)
    if np.isfinite(defocus).any():
        lo, hi = np.nanmin(defocus), np.nanmax(defocus)
        cs = ax.contour(g["field_x_deg"], g["field_y_deg"], defocus, levels=np.arange(
            math.floor(lo * 2) / 2, hi + 0.5, 0.5), colors="w", linewidths=0.7)
        ax.clabel(cs, fontsize=7, fmt="%+.1f")
    ax.set_aspect("equal")
    ax.set_xlabel("field x (deg, + toward the wearer's right)")
    ax.set_ylabel("field y (deg, + up)")
    ax.set_title(f"light through the {lm['add_d']:+.2f} D lenslets (share);\nwhite: their "
                 "image's myopic defocus (D)", fontsize=9)
    fig.colorbar(im, ax=ax, shrink=0.85)


def peripheral_summary(rep: dict) -> list:
    """One line per part: M on axis and the RPR at +-30 deg (or the map's edge) along the
    horizontal meridian."""
    lines = []
    for name in ("naked", "lens"):
        part = rep[name]
        if part is None:
            continue
        prof = part["profiles"]["horizontal"]
        x = np.array(prof["field_deg"])
        at = min(30.0, float(x.max()))
        pick = {v: prof["points"][int(np.argmin(np.abs(x - v)))] for v in (-at, at)}
        lines.append(f"{'naked eye' if name == 'naked' else 'through the lens'}: M on axis "
                     f"{part['m_on_axis_d']:+.3f} D (accommodation {part['accommodation_d']:.3f}"
                     f" D); RPR at {-at:+.0f} / {at:+.0f} deg horizontally "
                     f"{pick[-at]['rpr_d']:+.3f} / {pick[at]['rpr_d']:+.3f} D")
        lm = part.get("lenslets")
        if lm is not None:
            share = np.array(lm["share"], float)
            defocus = np.array(lm["myopic_defocus_d"], float)
            lines.append(
                f"lenslets ({lm['add_d']:+.2f} D add): up to {100 * np.nanmax(share):.0f} % "
                f"of the pupil's light through them ({100 * np.nanmean(share > 0):.0f} % of "
                f"the field's points); their image's myopic defocus "
                + (f"{np.nanmin(defocus):+.2f} to {np.nanmax(defocus):+.2f} D"
                   if np.isfinite(defocus).any() else "nowhere (no light through them)"))
    return lines
