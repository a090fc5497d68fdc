"""As-worn maps (:mod:`eyelab.optics.lens.asworn`) as PyVista data: an image over eye rotations
whose point arrays are the maps, and their iso-lines — for ParaView or a PyVista window."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from eyelab.optics.lens.asworn import AsWornMaps

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


def contour_step(span: float) -> float:
    """Iso-line step (D) for a map whose values reach ``span`` (D) in magnitude: the
    designers' 0.25 D, finer where the whole map is within a dioptre (at most 12 steps),
    as ``eyelab maps`` draws them."""
    return next((s for s in (0.05, 0.1, 0.25, 0.5) if span / s <= 12), 1.0)


def finite_cells(maps: AsWornMaps, name: str) -> pv.UnstructuredGrid:
    """The cells of :func:`maps_to_pyvista`'s image whose four points all have a value of
    map ``name`` (the others — outside the lens, or outside the frame it is cut to — are
    dropped, so that nothing is interpolated from NaN); point arrays as the image's."""
    img = maps_to_pyvista(maps)
    z = np.isfinite(np.asarray(getattr(maps, name), float))           # (ny, nx)
    keep = z[:-1, :-1] & z[:-1, 1:] & z[1:, :-1] & z[1:, 1:]           # cells, x fastest
    return img.extract_cells(np.flatnonzero(keep.ravel()))


def map_edge(maps: AsWornMaps) -> pv.PolyData:
    """The edge of the region of eye rotations whose line of sight passes the lens (the
    ``ok`` = 0.5 iso-line, between the grid points inside and outside): the frame's outline
    as the eye sees it where the lens is cut to a frame, else the blank's rim; empty when
    every line of sight on the grid passes."""
    if maps.ok is None or bool(np.all(maps.ok)):
        return pv.PolyData()
    img = maps_to_pyvista(maps)
    img.point_data["ok"] = maps.ok.ravel().astype(float)
    return img.contour(isosurfaces=[0.5], scalars="ok")
