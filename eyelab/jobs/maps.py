"""As-worn maps for a person: contour plots (matplotlib) and a text summary of the maps
computed by :mod:`eyelab.optics.asworn`."""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.optics.asworn import AsWornMaps, as_worn_maps

#: ``eyelab maps``'s flags, by the argument field :func:`~eyelab.optics.asworn.as_worn_maps`
#: names in its errors.
MAPS_FLAGS = {"maps.half_angle_deg": "--half-angle", "maps.n": "--points"}


def named_maps(eye, lens, names: dict | None = None, **kw) -> AsWornMaps:
    """:func:`~eyelab.optics.asworn.as_worn_maps` (``kw``: its keywords), an error in an
    argument named as the caller's user wrote it: ``names`` maps the engine's field to that
    name (e.g. :data:`MAPS_FLAGS`: ``--half-angle (maps.half_angle_deg)``)."""
    try:
        return as_worn_maps(eye, lens, **kw)
    except SpecError as e:
        if names and e.field in names:
            raise SpecError(f"{names[e.field]} ({e.field})", e.message) from None
        raise


def cli_maps(eye, lens, **kw) -> AsWornMaps:
    """``eyelab maps``'s call of :func:`~eyelab.optics.asworn.as_worn_maps`: the same
    arguments, an error naming the command's flag (:data:`MAPS_FLAGS`)."""
    return named_maps(eye, lens, MAPS_FLAGS, **kw)


def plot_maps(maps: AsWornMaps, path, title: str = "") -> None:
    """Contour maps as lens designers read them: mean power error and cylinder (0.25 D
    steps), over eye rotations in degrees (the eye turning about its centre of rotation
    behind the lens; Fick angles), as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), constrained_layout=True)
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
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


def maps_summary(maps: AsWornMaps) -> list:
    """Lines a designer reads first: the extremes and the central value."""
    c = len(maps.eye_rotation_y_deg) // 2
    lines = [f"eye rotation +-{maps.eye_rotation_x_deg[-1]:g} deg (Fick angles about the "
             f"centre of rotation), {len(maps.eye_rotation_x_deg)}^2 points; object "
             f"distances: {maps.model['up']} looking straight ahead and up; looking down, "
             f"{maps.model['down']}"]
    for key, label in (("mean_error_d", "mean power error"), ("cylinder_d", "cylinder")):
        z = getattr(maps, key)
        lines.append(f"{label}: centre {z[c, c]:+.3f} D, range {np.nanmin(z):+.3f} .. "
                     f"{np.nanmax(z):+.3f} D")
    lines.append(f"prism: up to {np.nanmax(maps.prism_d):.2f} Δ; "
                 f"{int((~maps.ok).sum())} eye rotations without a path through the lens")
    if not math.isfinite(float(np.nanmax(maps.prism_d))):
        lines.append("no line of sight passes the lens")
    return lines
