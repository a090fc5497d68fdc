"""The rows of point reports shared by the thin eye's and the schematic eye's analysis:
an object as the report writes it, and why a point has no light path."""

from __future__ import annotations

import math

import numpy as np

from eyelab.optics.rays.trace import Status

#: Decimals of an object's echoed angles (deg): 1e-9 deg, far below any field a spec
#: names, far above the 1e-14 deg a direction's round trip through sines leaves
#: (29.999999999999996 is 30).
ANGLE_DECIMALS = 9


def object_row(points, i) -> dict:
    """Point ``i`` of ``points`` as a report writes its object: distance (m or "inf"),
    field angles and polar field angles (deg)."""
    dist = float(points.distance[i])
    d = points.direction[i]

    def deg(v):                 # the angle as the spec gave it, without the trig's noise
        return round(float(np.degrees(v)), ANGLE_DECIMALS) + 0.0

    return {"distance_m": dist if math.isfinite(dist) else "inf",
            "field_deg": [deg(math.atan2(d[0], -d[2])), deg(math.atan2(d[1], -d[2]))],
            "field_polar_deg": [deg(math.acos(np.clip(-d[2], -1, 1))),
                                deg(math.atan2(d[1], d[0])) % 360.0]}


def no_path_reason(st) -> str:
    """Why a point with status ``st`` has no light path, in words."""
    if st & Status.BEHIND:
        return "the point is behind the eye or the lens: no light path"
    if st & Status.MISSED:
        return "not visible through the lens (the chief ray misses the lens aperture)"
    if st & Status.TIR:
        return "total internal reflection in the lens"
    return "the light path did not converge"


def line_of_sight_lens(lens):
    """The lens a report traces its lines of sight through: a lenslet lens's carrier (the
    image the eye focuses: the power error, blur and wave are the carrier's; the lenslets'
    light is reported on its own, :func:`lenslet_row`), else the lens (None: none)."""
    from eyelab.optics.lens.lenslets import carrier

    return carrier(lens)


def lenslet_row(lens, points, i, pupil, axis, pupil_radius, wavelength_nm, *, entry=None,
                carrier_defocus_d: float | None = None) -> dict:
    """Point ``i``'s beam through a lenslet lens (:func:`~eyelab.optics.lens.lenslets.
    beam_lenslets`, the pupil at ``pupil`` across ``axis``: the carrier's line of sight,
    ``entry`` its front-surface crossing): the fraction of the pupil's light through
    lenslets, how many it meets, their add, and the carrier's share. With
    ``carrier_defocus_d`` (the mean of the carrier image's M, D: > 0 before the retina)
    also the lenslets' image: its defocus (the carrier's plus the add, which each
    lenslet has as worn by design) and its blur, the angle a whole lenslet's pencil
    spreads over at that defocus (|defocus| x diameter, arcmin)."""
    from eyelab.core.constants import RAD_TO_ARCMIN
    from eyelab.optics.lens.lenslets import beam_lenslets

    b = beam_lenslets(lens, points, i, pupil, axis, pupil_radius, wavelength_nm, entry=entry)
    add = lens.front.add_d
    row = {"fraction": b["fraction"], "carrier_fraction": 1.0 - b["fraction"],
           "count": len(b["lenslets"]), "indices": b["lenslets"], "add_d": add,
           "rays": b["rays"]}
    if carrier_defocus_d is not None and row["count"]:
        v = carrier_defocus_d + add
        row.update({"carrier_defocus_d": carrier_defocus_d, "image_defocus_d": v,
                    "image_blur_arcmin": abs(v) * 2 * float(np.mean(
                        lens.front.radius[b["lenslets"]])) * RAD_TO_ARCMIN})
    return row


def format_lenslets(row: dict) -> str:
    """The text line of :func:`lenslet_row`."""
    if not row["count"]:
        return "  lenslets: the pupil's light misses them (the carrier only)"
    text = (f"  lenslets: {100 * row['fraction']:.1f} % of the pupil's light through "
            f"{row['count']} lenslet{'s' if row['count'] != 1 else ''} of "
            f"{row['add_d']:+.2f} D add (a second image, "
            f"{'myopically' if row['add_d'] > 0 else 'hyperopically'} defocused")
    if "image_defocus_d" in row:
        text += (f" {row['image_defocus_d']:+.2f} D, a lenslet's pencil blurred over "
                 f"{row['image_blur_arcmin']:.1f}'")
    return text + (f"); the rest of this point's report is the carrier's image, "
                   f"{100 * row['carrier_fraction']:.1f} % of the light")


def lens_info(lens, wavelength_nm: float) -> dict:
    """The lens block of analyze's report (every eye model): its prescription (None for a
    lens given by its surfaces alone), material, thicknesses (mm), pose and the traced
    back vertex powers (D) at ``wavelength_nm``."""
    f1, f2, a = lens.back_vertex_powers(wavelength_nm)
    e_min, e_max, _, _ = lens.edge_thickness()
    return {"rx": None if lens.rx is None else lens.rx.format(),
            "edge_thickness_mm": [e_min * 1e3, e_max * 1e3],
            "material": lens.material.name, "n": lens.material.n(wavelength_nm),
            "abbe": lens.material.v_d if lens.material.dispersive else "inf",
            "center_thickness_mm": lens.center_thickness * 1e3,
            "diameter_mm": lens.diameter * 1e3,
            "vertex_distance_mm": lens.pose.vertex_distance * 1e3,
            "pantoscopic_tilt_deg": lens.pose.pantoscopic_tilt_deg,
            "wrap_deg": lens.pose.wrap_deg,
            "back_vertex_powers_d": [f1, f2], "back_vertex_direction_1_deg": math.degrees(a)}


def format_lens(ln: dict | None) -> str:
    """The text line of a :func:`lens_info` block (None: the naked eye)."""
    if ln is None:
        return "lens: none (naked eye)"
    made = ln["rx"] if ln["rx"] is not None else "explicit surfaces"
    return (f"lens: {made} in {ln['material']} (n {ln['n']:.4f}), CT "
            f"{ln['center_thickness_mm']:.2f} mm, edge "
            "{:.2f}-{:.2f} mm".format(*ln["edge_thickness_mm"])
            + f", vertex {ln['vertex_distance_mm']:.1f} mm, tilt "
            f"{ln['pantoscopic_tilt_deg']:.1f} deg; traced back vertex powers "
            "{:+.4f} / {:+.4f} D".format(*ln["back_vertex_powers_d"]))
