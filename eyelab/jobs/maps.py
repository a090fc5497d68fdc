"""As-worn maps for a person: contour plots (matplotlib), a text summary of the maps
computed by :mod:`eyelab.optics.lens.asworn`, and the designer's figures of merit read off them
(:mod:`eyelab.optics.lens.figures`); both read from the on-disk cache when this eye and lens
were mapped before (:mod:`eyelab.optics.lens.mapcache`), and lines saying so."""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import renamed
from eyelab.optics.lens.asworn import AsWornMaps

#: ``eyelab maps``'s flags, by the argument field :func:`~eyelab.optics.lens.asworn.as_worn_maps`
#: names in its errors.
MAPS_FLAGS = {"maps.half_angle_deg": "--half-angle", "maps.n": "--points"}
#: The grid the figures of merit are read from, whatever grid the maps are drawn on: eye
#: rotations within +-40 deg (a progressive lens's near zone lies about 30 deg down) in
#: 2 deg steps (the figures of docs/gallery/pal.toml agree with a 1 deg grid's to 0.02 mm
#: and 0.01 D).
FIGURES_GRID = {"half_angle_deg": 40.0, "n": 41}
#: The figures' definitions, in the JSON (``figures.definitions``); the sources are cited
#: in :mod:`eyelab.optics.lens.figures`.
DEFINITIONS = {
    "lens_mm": "where the line of sight leaves the lens's front surface, in its own "
               "coordinates: mm from the lens centre (a progressive lens's fitting cross), x "
               "to the wearer's right, y up",
    "power": "the lens's power as worn for the object the maps' model puts on that line of "
             "sight (vertex-sphere vergence less the object's): sphere / cylinder x axis "
             "(TABO), D",
    "add_as_worn_d": "mean power at the near reference point less that at the distance "
                     "reference point (objects at 0.4 m and at infinity)",
    "corridor": "the path: the line of least cylinder from the fitting cross to the near "
                "reference point; length_mm: between its points where the add reaches 10 % "
                "and 90 % of the add as worn; widths: the narrowest, on horizontal sections "
                "between those points, of the interval about the path where the cylinder "
                "is below 0.50 / 0.75 D",
    "distance_zone, near_zone": "widths on horizontal sections every 1 mm (Sheedy 2004, "
                                "2006) where the cylinder is below 0.50 D and the mean power "
                                "within 0.25 D of the reference point's; open: the width "
                                "reaches the map's edge (a lower bound)",
    "peak_cylinder": "the largest unwanted cylinder on the figures' grid (D); ratio_to_add: "
                     "over the add as worn",
    "minkwitz": "ratio: the lateral cylinder gradient over twice the vertical power gradient "
                "between the 25 % and 75 % add points, 1 at Minkwitz's limit (Sheedy et al. "
                "2005)",
    "minimum_fitting_height_mm": "the depth of the near zone's top (the add within 0.25 D "
                                 "of the add as worn) below the fitting cross, plus a 4 mm "
                                 "reading area; a fitting-point height as ISO 13666 "
                                 "measures it, to the lens's lower edge",
    "clear_field": "the largest eye-rotation radius (deg) within which |mean power error| "
                   "and the unwanted cylinder stay at or below 0.25 D",
}


def named_maps(eye, lens, names: dict | None = None, **kw) -> tuple:
    """(maps, origin): :func:`~eyelab.optics.lens.asworn.as_worn_maps` (``kw``: its keywords)
    through the on-disk cache (:func:`eyelab.optics.lens.mapcache.maps`: read back bit for bit
    when this eye, lens and grid were mapped before, for a lens with a complete content
    key); ``origin`` where they came from (the cache's status: ``source`` "disk" or
    "computed", ``path``, ``note``). An error in an argument is named as the caller's user
    wrote it: ``names`` maps the engine's field to that name (e.g. :data:`MAPS_FLAGS`:
    ``--half-angle (maps.half_angle_deg)``)."""
    from eyelab.optics.lens import mapcache

    with named_as(names):
        maps, status = mapcache.maps(eye, lens, **kw)
    return maps, status.to_json()


def named_as(names: dict | None):
    """A context in which a SpecError of a field in ``names`` (engine field -> what the
    user typed, e.g. :data:`MAPS_FLAGS`) is raised again naming both
    (``--points (maps.n)``)."""
    return renamed({k: f"{v} ({k})" for k, v in (names or {}).items()})


def lens_wearer(eye):
    """The eye as-worn maps are measured for: a thin eye as it is; a schematic eye as a
    thin eye with its centre of rotation and pupil (the maps are the lens's: the wave at
    the vertex sphere about that centre against the prescription, which the eye's own
    optics do not enter)."""
    from eyelab.optics.eye.thin import Eye

    if isinstance(eye, Eye):
        return eye
    return Eye(rotation_centre=eye.rotation_centre, pupil_diameter=eye.pupil_diameter)


def cli_maps(eye, lens, **kw) -> tuple:
    """``eyelab maps``'s call of :func:`~eyelab.optics.lens.asworn.as_worn_maps`: the same
    arguments, an error naming the command's flag (:data:`MAPS_FLAGS`); (maps, origin) as
    :func:`named_maps`."""
    return named_maps(eye, lens, MAPS_FLAGS, **kw)


def plot_maps(maps: AsWornMaps, path, title: str = "") -> None:
    """Contour maps as lens designers read them: mean power error and cylinder (0.25 D
    steps), over eye rotations in degrees (the eye turning about its centre of rotation
    behind the lens; Fick angles), as a PNG at ``path``."""
    # a Figure on its own Agg canvas: no pyplot (its import and global state), and no
    # backend switched for the rest of the process
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from eyelab.core.fileio import png_writer

    fig = Figure(figsize=(10, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    for ax, key, label in ((axes[0], "mean_error_d", "mean power error (D)"),
                           (axes[1], "cylinder_d", "cylinder (D)")):
        z = np.ma.masked_invalid(getattr(maps, key))
        span = float(np.nanmax(np.abs(getattr(maps, key)))) if z.count() else 1.0
        # designers' 0.25 D contours, finer where the whole map is within a dioptre
        step = next((s for s in (0.05, 0.1, 0.25, 0.5) if span / s <= 12), 1.0)
        top = step * max(1, math.ceil(span / step))
        if key == "mean_error_d":
            lv, cmap = np.arange(-top, top + step / 2, step), "RdBu_r"
        else:
            lv, cmap = np.arange(-top, step / 2, step), "magma"
        cs = ax.contourf(maps.eye_rotation_x_deg, maps.eye_rotation_y_deg, z, levels=lv, cmap=cmap,
                         extend="both")
        ax.contour(maps.eye_rotation_x_deg, maps.eye_rotation_y_deg, z, levels=lv, colors="k",
                   linewidths=0.4)
        fig.colorbar(cs, ax=ax, shrink=0.85)
        for (name, (mx, my)), marker in zip(maps.marks.items(), ("+", "o", "o"),
                                            strict=False):
            ax.plot(mx, my, marker, color="k", mfc="none", ms=9, mew=1.5)
            ax.annotate(name, (mx, my), textcoords="offset points", xytext=(6, 4),
                        fontsize=7)
        ax.set_title(label)
        ax.set_xlabel("eye rotation right (deg, Fick azimuth)")
        ax.set_ylabel("eye rotation up (deg, Fick elevation)")
        ax.set_aspect("equal")
    if title:
        fig.suptitle(title)
    fig.set_dpi(100)
    fig.canvas.draw()                    # the figure's pixels, written by eyelab's PNG writer
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()   # (sRGB chunk, no tool tag)
    png_writer(rgb)(path)


def design_origin(lens) -> dict | None:
    """Where an optimised progressive ``lens``'s design came from in this process
    (:func:`eyelab.optics.lens.optimise.design_origin`: "computed" by the optimiser, or read
    from the on-disk cache, with the entry's path); None for any other lens. For the
    maps' JSON (``design``) and :func:`design_summary`."""
    from eyelab.optics.lens.optimise import design_origin as origin

    return origin(lens)


def design_summary(origin: dict | None) -> list:
    """The line saying whether the optimiser ran (:func:`design_origin`); none for a lens
    that was not optimised."""
    if origin is None:
        return []
    took = f"the optimiser's {origin['seconds']:.1f} s"
    if origin["source"] == "disk":
        return [f"design: optimised as worn ({origin['preset']}), from the on-disk cache "
                f"({origin['path']}; {took} saved)"]
    where = (f"cached in {origin['path']}" if origin["path"] and not origin["note"] else
             f"not cached: {origin['note']}" if origin["note"] else "not cached")
    return [f"design: optimised as worn ({origin['preset']}) in this run, {took}; {where}"
            + _replaced(origin)]


def _replaced(origin) -> str:
    """What a recomputation replaced in the cache (a damaged entry), or ""."""
    return f" (replacing a bad entry: {origin['replaced']})" if origin.get("replaced") else ""


def maps_summary(maps: AsWornMaps) -> list:
    """Lines a designer reads first: the extremes and the central value."""
    c = len(maps.eye_rotation_y_deg) // 2
    lines = [f"eye rotation +-{maps.eye_rotation_x_deg[-1]:g} deg (Fick angles about the "
             f"centre of rotation), {len(maps.eye_rotation_x_deg)}^2 points; object "
             f"distances: {maps.model['up']} looking straight ahead and up; looking down, "
             f"{maps.model['down']}"]
    if "lenslets" in maps.model:
        lines.append(maps.model["lenslets"])
    for key, label in (("mean_error_d", "mean power error"), ("cylinder_d", "cylinder")):
        z = getattr(maps, key)
        lines.append(f"{label}: centre {z[c, c]:+.3f} D, range {np.nanmin(z):+.3f} .. "
                     f"{np.nanmax(z):+.3f} D")
    lines.append(f"prism: up to {np.nanmax(maps.prism_d):.2f} Δ; "
                 f"{int((~maps.ok).sum())} eye rotations without a path through the lens")
    if not math.isfinite(float(np.nanmax(maps.prism_d))):
        lines.append("no line of sight passes the lens")
    return lines


def maps_figures(eye, lens, *, wavelength_nm: float = 587.56, maps: AsWornMaps | None = None,
                 **grid) -> dict:
    """The figures of merit of ``lens`` worn by ``eye``
    (:func:`~eyelab.optics.lens.figures.as_worn_figures`), read off as-worn maps on
    :data:`FIGURES_GRID` (``grid``: its half_angle_deg / n replaced); ``maps`` (of this eye
    and lens at ``wavelength_nm``) is used instead when it already is on that grid. Ready
    for JSON (:func:`json_ready`). :func:`figures_and_origin` says where they came from."""
    return figures_and_origin(eye, lens, wavelength_nm=wavelength_nm, maps=maps, **grid)[0]


def figures_and_origin(eye, lens, *, wavelength_nm: float = 587.56,
                       maps: AsWornMaps | None = None, **grid) -> tuple:
    """(figures, origin): :func:`maps_figures`'s figures, through the on-disk cache
    (:func:`eyelab.optics.lens.mapcache.figures`: read back when this eye, lens, wavelength and
    grid were measured before, for a lens with a complete content key — the same numbers
    either way); ``origin`` where they came from (the cache's status: ``source`` "disk" or
    "computed", ``path``, ``note``)."""
    from eyelab.optics.lens import mapcache

    g = dict(FIGURES_GRID, **grid)
    on_grid = maps is not None and len(maps.eye_rotation_x_deg) == g["n"] \
        and maps.eye_rotation_x_deg[-1] == g["half_angle_deg"]
    out, status = mapcache.figures(eye, lens, wavelength_nm=wavelength_nm,
                                   maps_on_grid=maps if on_grid else None, **g)
    out["definitions"] = {k: v for k, v in DEFINITIONS.items()
                          if k.split(",")[0] in out or k in ("lens_mm", "power")}
    return json_ready(out), status.to_json()


def origin_summary(what: str, origin: dict) -> list:
    """The line saying where ``what`` (the maps, the figures of merit) came from: the
    on-disk cache (``origin``: :func:`named_maps`'s or :func:`figures_and_origin`'s), or
    this run, and whether it was kept."""
    if origin["source"] == "disk":
        return [f"{what}: from the on-disk cache ({origin['path']})"]
    where = (f"cached in {origin['path']}" if origin["path"] and not origin["note"] else
             origin["note"] if (origin["note"] or "").startswith("not cached") else
             f"not cached: {origin['note']}" if origin["note"] else "not cached")
    return [f"{what}: computed in this run; {where}{_replaced(origin)}"]


def json_ready(obj):
    """``obj`` (nested dicts / lists of numbers) with numpy scalars made Python's and
    values that are not finite made None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {k: json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_ready(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def _width(w: float, is_open: bool, digits: int = 1) -> str:
    return f"{'>= ' if is_open else ''}{w:.{digits}f} mm"


def _reference_line(name: str, p: dict) -> str:
    obj = "at infinity" if p["object_vergence_d"] == 0 else \
        f"at {1 / p['object_vergence_d']:.2f} m"
    (x, y), (a, e) = ((round(v, 1) + 0.0 for v in p[k]) for k in ("lens_mm", "eye_rotation_deg"))
    return (f"  {name}: lens ({x:+.1f}, {y:+.1f}) mm, eye rotation ({a:+.1f}, {e:+.1f}) deg, "
            f"object {obj}: {p['power']} as worn, mean {p['mean_power_d']:+.2f} D (error "
            f"{p['mean_error_d']:+.2f} D, cylinder {p['cylinder_error_d']:+.2f} D)")


def _progressive_lines(f: dict) -> list:
    c = f["corridor"]
    w50, w75 = c["widths"]["0.50"], c["widths"]["0.75"]
    dz, nz, mk, pk = f["distance_zone"], f["near_zone"], f["minkwitz"], f["peak_cylinder"]
    widest = max(nz["sections"], key=lambda r: r["width_mm"], default=None)
    lines = [
        f"  add as worn {f['add_as_worn_d']:+.2f} D (near minus distance mean power; nominal "
        f"{f['add_nominal_d']:+.2f} D)",
        f"  corridor (10-90 % of the add along the umbilic path): {c['length_mm']:.1f} mm, "
        f"y {c['y10_mm']:+.1f} to {c['y90_mm']:+.1f} mm",
        f"  corridor width: {_width(w50['min_width_mm'], w50['open'], 2)} where cylinder < "
        f"0.50 D, {_width(w75['min_width_mm'], w75['open'], 2)} < 0.75 D (narrowest, y "
        f"{w50['at_y_mm']:+.1f} / {w75['at_y_mm']:+.1f} mm)",
        f"  distance zone (cylinder < 0.50 D, mean power within 0.25 D): "
        f"{_width(dz['width_at_reference_mm'], dz['reference_open'])} wide at the distance "
        f"reference; near zone {_width(nz['width_at_reference_mm'], nz['reference_open'])} at "
        f"the near reference" + ("" if widest is None else
                                 f", widest {_width(widest['width_mm'], widest['open'])} at y "
                                 f"{widest['y_mm']:+.0f} mm") + " (1 mm sections: the JSON)",
        f"  peak unwanted cylinder {pk['d']:.2f} D = {pk['ratio_to_add']:.1f} x the add, at eye "
        f"rotation ({pk['eye_rotation_deg'][0]:+.0f}, {pk['eye_rotation_deg'][1]:+.0f}) deg",
    ]
    if mk:
        lines.append(f"  Minkwitz ratio {mk['ratio']:.2f} (dC/dx "
                     f"{mk['cylinder_gradient_d_per_mm']:.2f} D/mm over 2 x dP/dy "
                     f"{mk['power_gradient_d_per_mm']:.2f} D/mm; 1 = Minkwitz's limit)")
    um = f.get("corridor_umbilic", {})
    if um:
        at = um.get("minkwitz_at_path")
        lines.append(f"  along the path: unwanted cylinder <= {um['path_cylinder_max_d']:.2f} D "
                     f"(at y {um['at_y_mm']:+.1f} mm)" + ("" if at is None else
                     f"; at the path dC/dx = {at['ratio']:.2f} x dP/dy (2 for an umbilic)"))
    lines.append(f"  minimum fitting height {f['minimum_fitting_height_mm']:.1f} mm (near zone top "
                 f"{-c['near_zone_top_mm']:.1f} mm below the fitting cross + 4 mm to read)")
    return lines


def figures_summary(f: dict) -> list:
    """The figures of merit (:func:`maps_figures`) as lines of text."""
    g = f["grid"]
    lines = [f"figures of merit ({f['kind']}; eye rotations within +-{g['half_angle_deg']:g} deg, "
             f"{g['step_deg']:g} deg steps; lens points: where the line of sight leaves the front "
             "surface, mm from the lens centre (a progressive lens's fitting cross), x to the "
             "wearer's right, y up):"]
    if f["kind"] == "progressive":
        lines += [_reference_line("distance reference", f["distance_reference"]),
                  _reference_line("near reference", f["near_reference"])]
        if "note" in f:
            return lines + [f"  {f['note']}"]
        return lines + _progressive_lines(f)
    if "note" in f:
        lines.append(f"  note: {f['note']}")
    cf, pk = f["clear_field"], f["peak_cylinder"]
    why = "" if cf["open"] else f", limited by {' and '.join(cf['limited_by'])} at eye " \
        f"rotation ({cf['limit_eye_rotation_deg'][0]:+.1f}, {cf['limit_eye_rotation_deg'][1]:+.1f})"
    return lines + [
        _reference_line("lens centre", f["optical_centre"]),
        f"  clear field (|mean power error| and cylinder <= {cf['tolerance_d']:.2f} D): "
        f"{'>= ' if cf['open'] else ''}{cf['radius_deg']:.1f} deg of eye rotation{why}; "
        f"power alone {cf['radius_mean_power_error_deg']:.1f} deg, cylinder alone "
        f"{cf['radius_cylinder_deg']:.1f} deg",
        f"  peak unwanted cylinder {pk['d']:.2f} D at eye rotation "
        f"({pk['eye_rotation_deg'][0]:+.0f}, {pk['eye_rotation_deg'][1]:+.0f}) deg"]
