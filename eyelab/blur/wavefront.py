"""Blur fields by wavefront tracing (Kakimoto et al. 2007, §4.2-4.4, Table 1).

Per column of voxels (one NDC x, y): one chief ray through the lens, shared by every depth
slice (§4.2; eyelab finds it by Newton path finding, not image processing). Per voxel: the
wave source is the point of the shared outgoing ray at the slice's centre depth; its wave
(K = -I/L) is carried through the lens by the column's 4x4 transport matrix
(:mod:`eyelab.optics.rays.raymatrix`, equal to the step-by-step Eq. 1-5), then accommodation
(Eq. 13, or a fixed focus), the thin toric eye (Eq. 7) and the conoid section (Eq. 8). The
retina -> NDC scaling (Eq. 9) uses the real lens: the Jacobian of the NDC position of the
scene point seen along a ray, at the voxel's depth, with respect to that ray's direction at
the eye, by central differences of exactly traced rays (not the thin-lens Fig. 9 estimate).
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.blur.field import (
    DEPTH_MODES,
    BlurField,
    VoxelStatus,
    extend_into_invisible,
    slice_centres,
)
from eyelab.core.cache import content_key
from eyelab.core.constants import RAD_TO_ARCMIN
from eyelab.core.errors import SpecError
from eyelab.core.parallel import map_row_chunks
from eyelab.core.progress import bar as progress_bar
from eyelab.core.vecmath import UP, cross, unit
from eyelab.optics.rays.camera import Camera, eye_camera, fit_virtual_camera
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays
from eyelab.optics.rays.raymatrix import apply_isotropic, lens_path_matrix
from eyelab.optics.rays.surfaces import sym2_eig
from eyelab.optics.rays.trace import FATAL

#: Angular step (rad) for the retina -> NDC Jacobian: central differences, error ~h^2.
JACOBIAN_STEP = 1e-5


def compute_blur_field(eye, lens=None, camera: Camera | None = None, *,
                       shape=(128, 32, 32), depth_mode: str = "ndc", focus=None,
                       scene_bounds=None, wavelength_nm: float = 587.56,
                       reference_depth: float | None = None, workers: int | None = None,
                       pupil=(0.0, 0.0, 0.0), accommodation=None) -> BlurField:
    """Compute a blur field.

    Parameters
    ----------
    eye : Eye
    lens : SpectacleLens or None (the naked eye's field)
    camera : the field's camera; default: the eye camera (naked) or the virtual camera
        fitted behind the lens for a 60 deg eye camera (through the lens).
    shape : (nz, ny, nx), each in [1, 1024]
    depth_mode : "ndc" or "linear" (see :mod:`eyelab.blur.field`)
    focus : None for the best accommodation per voxel (Eq. 13); a number (D) for a fixed
        accommodation over the whole view (clipped to [0, accommodation_max]).
    scene_bounds : None or ((xmin, ymin, zmin), (xmax, ymax, zmax)) world box; voxels that
        cannot hold geometry in it are not computed (status OUTSIDE_SCENE).
    reference_depth : depth (m) at which each column's chief ray is aimed at the column
        (default: the dioptric middle of the scene's depth range, or of near..far).
    wavelength_nm : the lens is traced and the eye's power taken (its chromatic aberration,
        :meth:`~eyelab.optics.eye.thin.Eye.power_shift`) at this wavelength.
    accommodation : None, or (nz, ny, nx) D per voxel: the eye's accommodation as found at
        another wavelength (the eye has one accommodation state whatever the colour: a
        per-channel field takes it from the field at the eye's reference wavelength);
        NaN where unknown (there Eq. 13 at this wavelength). Ignored when ``focus`` is set.
    """
    t0 = time.perf_counter()
    shape = tuple(int(s) for s in shape)
    if len(shape) != 3 or not all(1 <= s <= 1024 for s in shape):
        raise SpecError("shape", f"must be (nz, ny, nx) with each in [1, 1024], got {shape}")
    if depth_mode not in DEPTH_MODES:
        raise SpecError("depth_mode", f"must be one of {DEPTH_MODES}, got {depth_mode!r}")
    if accommodation is not None:
        accommodation = np.broadcast_to(np.asarray(accommodation, float), shape)
    pupil = np.asarray(pupil, float)
    timings = {}
    if camera is None:
        ec = eye_camera()
        camera = ec if lens is None else fit_virtual_camera(lens, ec,
                                                            wavelength_nm=wavelength_nm).camera
    timings["camera_s"] = time.perf_counter() - t0
    nz, ny, nx = shape
    depths = slice_centres(camera, nz, depth_mode)
    # --- sparsity: which columns and slices can hold scene geometry
    col_ok = np.ones((ny, nx), bool)
    slice_ok = np.ones(nz, bool)
    skip_reason = "no scene bounds given: every voxel computed"
    if scene_bounds is not None:
        col_ok, slice_ok, w_lo, w_hi = _scene_mask(camera, shape, depth_mode, scene_bounds)
        skip_reason = (f"scene depth {w_lo:.3g}-{w_hi:.3g} m: {int((~slice_ok).sum())} of {nz} "
                       f"slices and {int((~col_ok).sum())} of {ny * nx} columns skipped: no "
                       "geometry within one cell (the margin trilinear look-ups read)")
    iy, ix = np.nonzero(col_ok)
    ncol = len(iy)
    ndc_x = -1.0 + (2 * ix + 1.0) / nx
    ndc_y = -1.0 + (2 * iy + 1.0) / ny
    dirs_cam = camera.ray_directions(ndc_x, ndc_y)
    cop = np.asarray(camera.position, float)
    fwd = camera.basis[2]
    if reference_depth is None:
        ws = depths[slice_ok] if slice_ok.any() else depths
        reference_depth = 2.0 / (1.0 / ws.min() + 1.0 / ws.max())
    # --- one chief ray per column (§4.2)
    t = time.perf_counter()
    if lens is not None:
        aim = cop + dirs_cam * (reference_depth / (dirs_cam @ fwd))[:, None]
        # no global search for columns whose Newton start misses the lens: they are the
        # naked eye's columns (the raster draws what is seen through the lens in its own
        # pass), and searching every one of them costs ~10x the field where a small lens
        # leaves most of a wide view outside it
        chief = find_chief_rays(lens, pupil, ObjectPoints.from_positions(aim - pupil) if
                                np.allclose(pupil, 0) else _shifted(aim, pupil), wavelength_nm,
                                search=False)
        q = chief.entry
        d_out = -chief.dir_in                      # outgoing (scene-ward) direction
        col_status = chief.status
        d_rev = -chief.dir_out                     # eye-side reverse direction
    else:
        chief = None
        # the column ray from the camera's centre of projection; the source lies on it
        q = np.broadcast_to(cop, (ncol, 3)).copy()
        d_out = dirs_cam
        col_status = np.zeros(ncol, np.uint8)
        d_rev = None
    timings["paths_s"] = time.perf_counter() - t
    schem = None
    if not hasattr(eye, "power_matrix"):       # a schematic eye: eyelab/blur/schematic.py
        from eyelab.blur.schematic import schematic_columns, schematic_map

        schem = schematic_columns(eye, lens, -dirs_cam if lens is None else chief.dir_out,
                                  pupil, focus, wavelength_nm, reference_depth)
        col_status = col_status | schem["status"]
    x_eye_cols = None
    t_mats = None
    if lens is not None:
        n_arr = chief.dir_out
        x_eye_cols = unit(cross(np.broadcast_to(UP, n_arr.shape), n_arr))
        t_mats, _ = lens_path_matrix(chief, lens, wavelength_nm,
                                     np.broadcast_to(pupil, (ncol, 3)), x_eye_cols)
        jac_rays = _jacobian_rays(lens, pupil, d_rev, x_eye_cols, wavelength_nm)
    else:
        jac_rays = None
    out = {k: np.zeros((nz, ny, nx)) for k in ("a", "b", "omega", "major", "acc")}
    matrix = np.zeros((nz, ny, nx, 2, 2))
    status = np.full((nz, ny, nx), VoxelStatus.OUTSIDE_SCENE, np.uint8)
    sources = np.zeros((nz, ny, nx, 3))
    ks = np.flatnonzero(slice_ok)
    counters = {"in_focus_skipped": 0}

    def run(a, b):
        _column_block(a, b, eye, lens, camera, depths, ks, iy, ix, q, d_out, col_status,
                      t_mats, jac_rays, pupil, focus, out, matrix, status, sources, counters,
                      wavelength_nm, accommodation, schem)

    t = time.perf_counter()
    with progress_bar(ncol, f"blur field {nz}x{ny}x{nx} at {wavelength_nm:g} nm",
                      "column") as bar:
        def run_shown(a, b):
            run(a, b)
            bar.update(b - a)

        map_row_chunks(run_shown, ncol, workers=workers,
                       block=max(1, 16384 // max(len(ks), 1)))
    timings["voxels_s"] = time.perf_counter() - t
    # a schematic eye: the rays' own map (eyelab/blur/aberration.py)
    aberration, fit_report = (None, None) if schem is None else schematic_map(
        eye, lens, camera, pupil, -dirs_cam if lens is None else chief.dir_out,
        schem["accommodation"], wavelength_nm, depths, ks, iy, ix, sources, status,
        matrix, workers, timings)
    extended = extend_into_invisible(matrix, status) if lens is not None else 0
    timings["total_s"] = time.perf_counter() - t0
    counts = {s.name.lower(): int((status == s).sum()) for s in VoxelStatus}
    report = {
        "method": "wavefront",
        "shape": list(shape),
        "depth_mode": depth_mode,
        "focus": ("best effort per voxel (Eq. 13)" if accommodation is None else
                  "given per voxel") if focus is None else float(focus),
        "wavelength_nm": float(wavelength_nm),
        "eye_power_shift_d": eye.power_shift(wavelength_nm) if schem is None else None,
        "voxels_total": int(np.prod(shape)),
        "voxels_computed": int(ncol * len(ks)),
        "voxel_status": counts,
        "in_focus_skipped": counters["in_focus_skipped"],
        "not_visible_extended": extended,
        "skipped_why": skip_reason,
        "columns": ncol,
        "reference_depth_m": float(reference_depth),
        "path_iterations_mean": 0.0 if chief is None or not chief.iterations.size
        else float(chief.iterations.mean()),
        "timings": timings,
    }
    report.update({} if fit_report is None else {"aberration_fit": fit_report})
    key = content_key(method="wavefront", eye=eye, lens=lens, camera=camera, shape=shape,
                    depth_mode=depth_mode, focus=focus, scene_bounds=None if scene_bounds is None
                    else np.asarray(scene_bounds, float), wavelength=wavelength_nm,
                    reference_depth=reference_depth, pupil=pupil, accommodation=accommodation)
    return BlurField(camera, shape, depth_mode, matrix, out["a"], out["b"], out["omega"],
                     out["major"], out["acc"], status, sources, "wavefront", key, report,
                     aberration)


def cached_blur_field(cache_dir, eye, lens=None, camera=None, *, method="wavefront",
                      **kwargs) -> BlurField:
    """:func:`compute_blur_field` (or the bundle method) through an on-disk cache.

    The file name is a hash of every input that matters (eye, lens, camera, grid, method and
    options); a hit loads the ``.npz`` and marks ``report["cache"] = "hit"``.
    """
    from pathlib import Path

    if method not in ("wavefront", "bundle"):
        raise SpecError("method", f"must be 'wavefront' or 'bundle', got {method!r}")
    key = content_key(method=method, eye=eye, lens=lens, camera=camera, **kwargs)
    path = Path(cache_dir) / f"blurfield-{key}.npz"
    if path.is_file():
        field = BlurField.load(path)
        field.report = dict(field.report, cache="hit", cache_file=str(path))
        return field
    if method == "wavefront":
        field = compute_blur_field(eye, lens, camera, **kwargs)
    else:
        from eyelab.blur.bundle import compute_blur_field_bundles

        field = compute_blur_field_bundles(eye, lens, camera, **kwargs)
    path.parent.mkdir(parents=True, exist_ok=True)
    field.report = dict(field.report, cache="miss", cache_file=str(path))
    field.save(path)
    return field


def _shifted(points, pupil):
    return ObjectPoints.from_positions(points - pupil)


def _scene_mask(camera, shape, depth_mode, bounds):
    lo, hi = (np.asarray(b, float) for b in bounds)
    if lo.shape != (3,) or hi.shape != (3,) or np.any(hi < lo):
        raise SpecError("scene_bounds", "must be ((xmin, ymin, zmin), (xmax, ymax, zmax)) with "
                        "max >= min")
    nz, ny, nx = shape
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    w = camera.depth(corners)
    w_lo, w_hi = max(w.min(), camera.near), min(w.max(), camera.far)
    from eyelab.blur.field import slice_bounds

    sb = slice_bounds(camera, nz, depth_mode)
    slice_ok = _dilate1((sb[1:] >= w_lo) & (sb[:-1] <= w_hi))
    col_ok = np.ones((ny, nx), bool)
    if w.min() > 0:  # the whole box in front: its NDC footprint bounds the columns
        ndc = camera.world_to_ndc(corners)
        x0, x1 = ndc[:, 0].min(), ndc[:, 0].max()
        y0, y1 = ndc[:, 1].min(), ndc[:, 1].max()
        ex = -1.0 + 2 * np.arange(nx + 1) / nx
        ey = -1.0 + 2 * np.arange(ny + 1) / ny
        cx = (ex[1:] >= x0) & (ex[:-1] <= x1)
        cy = (ey[1:] >= y0) & (ey[:-1] <= y1)
        col_ok = _dilate1(cy)[:, None] & _dilate1(cx)[None, :]
    return col_ok, slice_ok, w_lo, w_hi


def _dilate1(ok):
    """One more cell on each side of every run of True (n,) -> (n,): values live at cell
    centres and are read by trilinear interpolation, so a point anywhere in a needed cell
    also reads its neighbours; a neighbour left uncomputed (zero) would shrink the blur by
    up to half towards the edge of the scene's range (a flat chart sits in one slice)."""
    out = ok.copy()
    out[1:] |= ok[:-1]
    out[:-1] |= ok[1:]
    return out


def _thin_eye(eye, kxx, kxy, kyy, kbar, focus, given_acc, ks, iy, ix, cols, wavelength_nm):
    """Accommodation (Eq. 13 or the focus), the angular blur matrix (c, m, 2, 2: the
    retinal matrix of Eq. 8 times -n2/z_r: a retinal offset h is a line of sight turned by
    -n2 h / z_r, the nodal point at the lens) and Eq. 8's eigen-decomposition."""
    n2, zr, rp = eye.n_vitreous, eye.retina_distance, eye.pupil_diameter / 2
    if focus is None:
        acc = eye.accommodation_for(kbar)                                # Eq. 13
        if given_acc is not None:
            g = given_acc[ks[None, :], iy[cols][:, None], ix[cols][:, None]]
            acc = np.where(np.isnan(g), acc, g)
    else:
        acc = np.full_like(kbar, min(max(float(focus), 0.0), eye.accommodation_max))
    pxx, pxy, pyy = eye.power_matrix(acc, wavelength_nm)
    k11 = kxx / n2 + pxx / n2                                            # Eq. 7
    k12 = kxy / n2 + pxy / n2
    k22 = kyy / n2 + pyy / n2
    m11 = rp * (1.0 - zr * k11)                                          # Eq. 8
    m12 = -rp * zr * k12
    m22 = rp * (1.0 - zr * k22)
    scale = -n2 / zr
    g = scale * np.stack([np.stack([m11, m12], -1), np.stack([m12, m22], -1)], -2)
    return acc, g, sym2_eig(m11, m12, m22)


def _jacobian_rays(lens, pupil, d_rev, x_eye, wavelength_nm):
    """Rays leaving the lens for eye-side directions perturbed by +-h along x_eye, y_eye."""
    h = JACOBIAN_STEP
    y_eye = cross(-d_rev, x_eye)
    rays = []
    for e in (x_eye, y_eye):
        pair = []
        for sgn in (1.0, -1.0):
            d = unit(d_rev + sgn * h * e)
            res = lens.trace(np.broadcast_to(pupil, d.shape), d, wavelength_nm, reverse=True)
            pair.append((res["out_points"], res["out_dirs"]))
        rays.append(pair)
    return rays


def _point_at_depth(cam_pos, fwd, q, d, w):
    """Points q + s d at camera depth w; q, d (n, 3), w (m,) -> (n, m, 3), s (n, m)."""
    s = (w[None, :] - ((q - cam_pos) @ fwd)[:, None]) / (d @ fwd)[:, None]
    return q[:, None, :] + s[..., None] * d[:, None, :], s


def _column_block(a, b, eye, lens, camera, depths, ks, iy, ix, q, d_out, col_status, t_mats,
                  jac_rays, pupil, focus, out, matrix, status, sources, counters,
                  wavelength_nm, given_acc, schem=None):
    cols = slice(a, b)
    w = depths[ks]
    cop = np.asarray(camera.position, float)
    fwd = camera.basis[2]
    src, s = _point_at_depth(cop, fwd, q[cols], d_out[cols], w)       # (c, m, 3)
    c, m = s.shape
    st = np.zeros((c, m), np.uint8)
    fatal = (col_status[cols] & np.uint8(FATAL)) != 0
    st[fatal] = VoxelStatus.NOT_VISIBLE
    behind = (s <= 0) & ~fatal[:, None]
    if lens is None:
        # the source must be in front of the pupil
        to_pupil = pupil - src
        behind |= (to_pupil @ np.array([0.0, 0.0, 1.0])) <= 0
    st[behind] = VoxelStatus.BEHIND
    ok = st == 0
    if lens is None:
        dist = np.linalg.norm(src - pupil, axis=-1)
        v = -1.0 / np.where(ok, dist, 1.0)
        kxx = v.copy()
        kyy = v.copy()
        kxy = np.zeros_like(v)
        n_dir = unit(pupil - src)                                      # toward the eye
        x_eye = unit(cross(np.broadcast_to(UP, n_dir.shape).reshape(-1, 3),
                             n_dir.reshape(-1, 3))).reshape(n_dir.shape)
        y_eye = cross(n_dir.reshape(-1, 3), x_eye.reshape(-1, 3)).reshape(n_dir.shape)
    else:
        v = -1.0 / np.where(ok, s, 1.0)
        t = t_mats[cols][:, None]
        kxx, kxy, kyy, _ = apply_isotropic(t, v)
    kbar = 0.5 * (kxx + kyy)
    if schem is not None:                  # the schematic eye's own optics
        from eyelab.blur.schematic import schematic_blur

        sb = schematic_blur(schem, cols, kxx, kxy, kyy)
        g, l2, l1, omega, major = sb["g"], sb["a"], sb["b"], sb["omega"], sb["major"]
        acc = np.full_like(kbar, schem["accommodation"])
    else:
        acc, g, (l1, l2, cs, sn) = _thin_eye(eye, kxx, kxy, kyy, kbar, focus, given_acc, ks,
                                             iy, ix, cols, wavelength_nm)
    # retina -> NDC (Eq. 9): NDC of the scene point seen along a ray turned by theta at the
    # eye; a retinal offset h corresponds to theta = -n2 h / z_r (nodal point at the lens)
    jac = np.empty((c, m, 2, 2))
    h = JACOBIAN_STEP
    for col_k in range(2):
        ndc_pm = []
        for pm in range(2):
            if lens is None:
                e = x_eye if col_k == 0 else y_eye
                dd = unit(-n_dir + (1.0 if pm == 0 else -1.0) * h * e)
                p = pupil + dd * (np.linalg.norm(src - pupil, axis=-1)
                                  / np.einsum("cmi,cmi->cm", dd, -n_dir))[..., None]
            else:
                qq, dd = jac_rays[col_k][pm]
                p, _ = _point_at_depth(cop, fwd, qq[cols], dd[cols], w)
            ndc_pm.append(camera.world_to_ndc(p.reshape(-1, 3))[:, :2].reshape(c, m, 2))
        jac[..., :, col_k] = (ndc_pm[0] - ndc_pm[1]) / (2 * h)
    bm = np.einsum("cmij,cmjk->cmik", jac, g)
    bm[~ok] = 0.0
    if schem is None and lens is None and eye.astigmatism == 0.0 and focus is None \
            and given_acc is None \
            and eye.power_shift(wavelength_nm) == 0.0:
        # a spherical naked eye focuses every source inside its accommodation range exactly:
        # mark those voxels zero instead of keeping ~1e-16 round-off
        fv = eye.emmetropic_power - eye.power_min
        in_range = ok & (v <= fv + 1e-12) & (v >= fv - eye.accommodation_max - 1e-12)
        bm[in_range] = 0.0
        l1 = np.where(in_range, 0.0, l1)
        l2 = np.where(in_range, 0.0, l2)
        counters["in_focus_skipped"] += int(in_range.sum())
    if schem is None:
        major = np.maximum(np.abs(l1), np.abs(l2)) * eye.n_vitreous / eye.retina_distance \
            * RAD_TO_ARCMIN
        omega = np.mod(np.arctan2(cs, -sn), math.pi)
    jj, ii = iy[cols], ix[cols]
    for arr, val in ((out["a"], l2), (out["b"], l1), (out["omega"], omega),
                     (out["major"], major), (out["acc"], acc)):
        arr[ks[None, :], jj[:, None], ii[:, None]] = np.where(ok, val, 0.0)
    matrix[ks[None, :], jj[:, None], ii[:, None]] = bm
    status[ks[None, :], jj[:, None], ii[:, None]] = st
    sources[ks[None, :], jj[:, None], ii[:, None]] = src


def sharing_error(field: BlurField, eye, lens, *, samples: int = 200, seed: int = 0,
                  wavelength_nm: float = 587.56) -> dict:
    """Error introduced by sharing one chief ray per column (§4.2).

    For ``samples`` random computed voxels, the exact chain for the voxel's centre (its own
    Fermat path, by :func:`~eyelab.optics.chain.analysis.analyze_points`) is compared with the
    field's value (computed for the wave source on the shared path). Returns the offset of
    the wave source from the voxel centre in voxel widths (NDC x, y), and the relative
    difference of the retinal ellipse's semi-axes (exact vs shared; relative to the exact
    major semi-axis, for voxels whose blur exceeds 0.1 arcmin).
    """
    from eyelab.optics.chain.analysis import analyze_points

    rng = np.random.default_rng(seed)
    ok = np.argwhere(field.status == VoxelStatus.OK)
    if len(ok) == 0:
        return {"samples": 0}
    pick = ok[rng.choice(len(ok), size=min(samples, len(ok)), replace=False)]
    nz, ny, nx = field.shape
    k, j, i = pick.T
    depth = field.slice_depths()[k]
    cam = field.camera
    ndc_x = -1.0 + (2 * i + 1.0) / nx
    ndc_y = -1.0 + (2 * j + 1.0) / ny
    dirs = cam.ray_directions(ndc_x, ndc_y)
    centres = np.asarray(cam.position) + dirs * (depth / (dirs @ cam.basis[2]))[:, None]
    res = analyze_points(eye, lens, ObjectPoints.from_positions(centres),
                         wavelength_nm=wavelength_nm)
    maj, mnr, _ = res.blur_axes()
    f_maj = np.maximum(np.abs(field.a[k, j, i]), np.abs(field.b[k, j, i]))
    f_mnr = np.minimum(np.abs(field.a[k, j, i]), np.abs(field.b[k, j, i]))
    src_ndc = cam.world_to_ndc(field.sources[k, j, i])
    off = np.hypot((src_ndc[:, 0] - ndc_x) * nx / 2, (src_ndc[:, 1] - ndc_y) * ny / 2)
    sel = (res.to_arcmin(maj) > 0.1) & (res.status == 0)
    rel = np.abs(np.concatenate([f_maj - maj, f_mnr - mnr])[np.tile(sel, 2)]) / \
        np.tile(maj, 2)[np.tile(sel, 2)] if sel.any() else np.zeros(1)
    return {"samples": int(len(pick)),
            "source_offset_voxels": {"median": float(np.median(off)), "max": float(off.max())},
            "ellipse_rel_error": {"median": float(np.median(rel)), "max": float(rel.max())},
            "exact_paths_failed": int((res.status != 0).sum())}
