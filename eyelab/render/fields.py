"""Blur fields as PyVista data: volumes, Sturm-conoid ellipse glyphs, a conoid inside the eye.

All lengths in the returned datasets are metres in eyelab's world frame (see
:mod:`eyelab.optics.lens.spectacle`), except :func:`blur_field_to_pyvista` with ``world=False``,
which lays the voxels out on the NDC grid.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from eyelab.blur.field import ARRAY_NAMES, BlurField, slice_bounds
from eyelab.core.fileio import atomic_path


def _cell_arrays(field: BlurField):
    nz, ny, nx = field.shape
    # VTK orders cells x fastest: our [k, j, i] arrays ravel in C order to exactly that
    m = field.matrix.reshape(nz, ny, nx, 4)
    return {
        "blur_arcmin": field.major_arcmin.ravel(),
        "a_um": field.a.ravel() * 1e6,
        "b_um": field.b.ravel() * 1e6,
        "omega_deg": np.degrees(field.omega).ravel(),
        "accommodation_d": field.accommodation.ravel(),
        "status": field.status.ravel().astype(np.uint8),
        "matrix": m.reshape(-1, 4),
        "ndc_blur_radius": np.linalg.norm(m, axis=-1).ravel() / np.sqrt(2.0),
    }


def blur_field_to_pyvista(field: BlurField, *, world: bool = False):
    """The field as cell data.

    ``world=False``: ``pv.ImageData`` over the NDC grid, spacing (2/nx, 2/ny, 2/nz) in NDC x,
    y and the slice parameter (NDC z, or the linear depth mapped to [-1, 1]).
    ``world=True``: ``pv.StructuredGrid`` whose points are the voxel corners in world space
    (the frustum, sliced as the field is). Arrays: blur_arcmin, a_um, b_um, omega_deg,
    accommodation_d, status, matrix (4 components, row-major 2x2), ndc_blur_radius.
    """
    nz, ny, nx = field.shape
    if not world:
        grid = pv.ImageData(dimensions=(nx + 1, ny + 1, nz + 1),
                            spacing=(2.0 / nx, 2.0 / ny, 2.0 / nz), origin=(-1.0, -1.0, -1.0))
    else:
        cam = field.camera
        wb = slice_bounds(cam, nz, field.depth_mode)
        xs = np.linspace(-1, 1, nx + 1)
        ys = np.linspace(-1, 1, ny + 1)
        z, y, x = np.meshgrid(cam.depth_to_ndc_z(wb), ys, xs, indexing="ij")
        pts = cam.ndc_to_world(np.stack([x, y, z], -1))          # (nz+1, ny+1, nx+1, 3)
        grid = pv.StructuredGrid(*(np.ascontiguousarray(pts[..., c].transpose(2, 1, 0))
                                   for c in range(3)))
    for name, arr in _cell_arrays(field).items():
        grid.cell_data[name] = arr
    grid.field_data["depth_mode"] = [field.depth_mode]
    grid.field_data["method"] = [field.method]
    grid.field_data["key"] = [field.key]
    return grid


def save_vti(field: BlurField, path) -> None:
    """Write the field as VTK image data on the NDC grid (``.vti``, for ParaView), every
    array exactly, written atomically; :func:`load_vti` reads it back."""
    path = str(path)
    with atomic_path(path, suffix=".vti") as tmp:
        grid = blur_field_to_pyvista(field)
        for name, arr in field.arrays().items():
            grid.cell_data[f"eyelab_{name}"] = arr.reshape(int(np.prod(field.shape)), -1)
        grid.field_data["eyelab_meta"] = [field.meta_json()]
        grid.save(tmp)


def load_vti(path) -> BlurField:
    """A field written by :func:`save_vti`."""
    import json

    g = pv.read(str(path))
    meta = json.loads(str(g.field_data["eyelab_meta"][0]))
    nz, ny, nx = meta["shape"]
    tail = {"matrix": (2, 2), "sources": (3,)}
    arrays = {k: np.asarray(g.cell_data[f"eyelab_{k}"]).reshape((nz, ny, nx) + tail.get(k, ()))
              for k in ARRAY_NAMES}
    return BlurField.from_parts(meta, arrays)


def ellipse_glyphs(field: BlurField, *, slices=None, stride: int = 1, segments: int = 32,
                   min_arcmin: float = 0.0, scale: float = 1.0) -> pv.PolyData:
    """Sturm-conoid ellipses (Kakimoto Figs. 12-13): at each voxel's wave source, in the plane
    of constant depth, the ellipse a unit-disc seed sweeps when displaced by the voxel's
    matrix, i.e. the blur the voxel produces, in world units (times ``scale``).

    slices : None (all), an int, or an iterable of slice indices; stride : every n-th column.
    Returns line loops with cell arrays blur_arcmin and slice.
    """
    nz, ny, nx = field.shape
    ks = range(nz) if slices is None else ([slices] if np.isscalar(slices) else list(slices))
    cam = field.camera
    b = cam.basis
    tx, ty = cam.tan_half
    t = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], 0)                  # (2, segments)
    pts, lines, blur, sl = [], [], [], []
    n_pts = 0
    for k in ks:
        for j in range(0, ny, stride):
            for i in range(0, nx, stride):
                if field.status[k, j, i] != 0 or field.major_arcmin[k, j, i] < min_arcmin:
                    continue
                c = field.sources[k, j, i]
                w = cam.depth(c[None])[0]
                disp = field.matrix[k, j, i] @ circle                 # NDC, (2, segments)
                world = c[None] + scale * ((disp[0] * w * tx)[:, None] * b[0]
                                           + (disp[1] * w * ty)[:, None] * b[1])
                pts.append(world)
                lines.append(np.concatenate([[segments + 1], n_pts + np.arange(segments),
                                             [n_pts]]))
                n_pts += segments
                blur.append(field.major_arcmin[k, j, i])
                sl.append(k)
    if not pts:
        return pv.PolyData()
    poly = pv.PolyData(np.concatenate(pts), lines=np.concatenate(lines))
    poly.cell_data["blur_arcmin"] = np.array(blur)
    poly.cell_data["slice"] = np.array(sl)
    return poly


def sturm_conoid(eye, wave_k, accommodation: float, *, rays: int = 48, rings: int = 3,
                 beyond: float = 1.3, start: float = 0.0, transverse_scale: float = 1.0):
    """A 3D view of one point's Sturm conoid inside the eye, in millimetres in the eye frame
    (x, y in the pupil plane, z from the thin eye lens toward the retina).

    wave_k : (kxx, kxy, kyy) of the wave arriving at the eye, in the eye (x, y) frame (1/m).
    Returns a dict of PolyData: 'rays' (pupil -> beyond the retina), 'focal_lines' (the two
    line foci, where they lie in front of ``beyond`` z_r), 'retina_section' (the Eq. 8
    ellipse on the retina) and 'pupil' (its rim). ``start`` (fraction of z_r) trims the rays'
    beginning and ``transverse_scale`` magnifies x and y (not z) for display.
    """
    kxx, kxy, kyy = (float(v) for v in wave_k)
    n2, zr, rp = eye.n_vitreous, eye.retina_distance, eye.pupil_diameter / 2
    pxx, pxy, pyy = (float(v) for v in eye.power_matrix(accommodation))
    k = np.array([[kxx + pxx, kxy + pxy], [kxy + pxy, kyy + pyy]]) / n2   # Eq. 7
    z_end = beyond * zr
    t = np.linspace(0, 2 * np.pi, rays, endpoint=False)
    rho = np.concatenate([(r / rings) * rp * np.stack([np.cos(t), np.sin(t)], 1)
                          for r in range(1, rings + 1)])
    zs = np.linspace(start * zr, z_end, 40)
    segs = [np.column_stack([p[None] - zs[:, None] * (k @ p)[None], zs]) for p in rho]
    lines = np.concatenate([np.r_[len(zs), i * len(zs) + np.arange(len(zs))]
                            for i in range(len(segs))])
    ray_poly = pv.PolyData(np.concatenate(segs) * 1e3, lines=lines)
    evals, evecs = np.linalg.eigh(k)
    focal = []
    for idx in range(2):
        lam = evals[idx]
        if lam > 1.0 / z_end:
            zf = 1.0 / lam
            other = evecs[:, 1 - idx]
            # at z = 1/lam the bundle collapses along this eigenvector and is a line along the
            # other one, of half-length r_p |1 - z lam_other|
            half = rp * abs(1.0 - zf * evals[1 - idx])
            focal.append(pv.Line(np.r_[-half * other, zf] * 1e3, np.r_[half * other, zf] * 1e3))
    m = rp * (np.eye(2) - zr * k)
    rim = np.stack([np.cos(t), np.sin(t)], 1)
    ell = rim @ m.T
    ret = pv.PolyData(np.column_stack([ell, np.full(len(t), zr)]) * 1e3,
                      lines=np.r_[len(t) + 1, np.arange(len(t)), 0])
    pup = pv.PolyData(np.column_stack([rim * rp, np.zeros(len(t))]) * 1e3,
                      lines=np.r_[len(t) + 1, np.arange(len(t)), 0])
    focal_poly = pv.merge(focal) if focal else pv.PolyData()
    parts = {"rays": ray_poly, "focal_lines": focal_poly, "retina_section": ret, "pupil": pup}
    if transverse_scale != 1.0:
        for poly in parts.values():
            if poly.n_points:
                poly.points[:, :2] *= transverse_scale
    return parts


def voxel_conoid(field: BlurField, eye, lens, index, **kwargs):
    """The Sturm conoid (see :func:`sturm_conoid`) of voxel ``index`` = (k, j, i): the wave
    from the voxel's wave source, traced through the lens, with the field's accommodation."""
    from eyelab.optics.chain.analysis import analyze_points
    from eyelab.optics.rays.paths import ObjectPoints

    k, j, i = index
    res = analyze_points(eye, lens, ObjectPoints.from_positions(field.sources[k, j, i][None]),
                         accommodation=float(field.accommodation[k, j, i]))
    wave = [v[0] for v in res.wave_eye.in_basis(res.eye_x)]
    return sturm_conoid(eye, wave, float(res.accommodation[0]), **kwargs)


def plot_volume(field: BlurField, plotter=None, *, scalars="blur_arcmin", world=False,
                cmap="magma"):
    """Add the field as a volume (NDC grid) or, with ``world=True``, as its frustum of voxels
    coloured by ``scalars``; returns the plotter (offscreen if none was given)."""
    p = plotter or pv.Plotter(off_screen=True)
    grid = blur_field_to_pyvista(field, world=world)
    if world:
        p.add_mesh(grid, scalars=scalars, cmap=cmap, opacity=0.4)
    else:
        p.add_volume(grid.cell_data_to_point_data(), scalars=scalars, cmap=cmap,
                     opacity="linear")
        p.add_mesh(grid.outline(), color="black")
    return p


def plot_glyphs(field: BlurField, plotter=None, *, depth=None, **kwargs):
    """Add Sturm-conoid ellipse glyphs, all slices or the slice containing ``depth`` (m);
    returns the plotter."""
    p = plotter or pv.Plotter(off_screen=True)
    slices = None
    if depth is not None:
        bounds = field.slice_bounds_depth()
        slices = int(np.clip(np.searchsorted(bounds, depth) - 1, 0, field.shape[0] - 1))
    glyphs = ellipse_glyphs(field, slices=slices, **kwargs)
    if glyphs.n_points:
        p.add_mesh(glyphs, scalars="blur_arcmin", line_width=2)
    return p
