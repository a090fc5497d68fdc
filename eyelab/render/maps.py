"""As-worn maps (:mod:`eyelab.optics.asworn`) as PyVista data: an image over eye rotations whose
point arrays are the maps, and their iso-lines — for ParaView or a PyVista window."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from eyelab.optics.asworn import AsWornMaps

MAP_ARRAYS = ("mean_error_d", "cylinder_d", "axis_tabo_deg", "sphere_error_d", "prism_d",
              "object_vergence_d", "object_x_deg", "object_y_deg")


def maps_to_pyvista(maps: AsWornMaps) -> pv.ImageData:
    """(nx, ny, 1) image data: x = eye rotation to the right, y = eye rotation up (Fick
    angles about the centre of rotation), in degrees (spacing the grid step); point arrays:
    every map (D, deg, Δ), the surfaces' own maps, and ``ok``."""
    gx, gy = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
    img = pv.ImageData(dimensions=(len(gx), len(gy), 1),
                       spacing=(float(gx[1] - gx[0]), float(gy[1] - gy[0]), 1.0),
                       origin=(float(gx[0]), float(gy[0]), 0.0))
    for name in MAP_ARRAYS:
        if getattr(maps, name) is not None:
            img.point_data[name] = np.asarray(getattr(maps, name), float).ravel()  # x fastest
    for name, values in maps.surface.items():
        img.point_data[name] = np.asarray(values, float).ravel()
    if maps.ok is not None:
        img.point_data["ok"] = maps.ok.ravel().astype(np.uint8)
    return img


def map_isolines(maps: AsWornMaps, name: str = "cylinder_d", step: float = 0.25
                 ) -> pv.PolyData:
    """Iso-lines of one map every ``step`` (D), as lens designers draw them."""
    img = maps_to_pyvista(maps)
    values = img.point_data[name]
    finite = values[np.isfinite(values)]
    if not len(finite):
        return pv.PolyData()
    lo, hi = np.floor(finite.min() / step) * step, np.ceil(finite.max() / step) * step
    levels = np.arange(lo, hi + step / 2, step)
    img.point_data[name] = np.where(np.isfinite(values), values, 0.0)
    return img.contour(isosurfaces=list(levels), scalars=name)
