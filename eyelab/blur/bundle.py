"""Blur fields by ray bundles (the method of Kakimoto, Tatsukawa & Nishita's earlier paper,
"Rendering Refractive Corrected Image Using Per-Vertex Ray Tracing", in Japanese, §4.3).

For each reference ray from the pupil centre through the lens (the paper scans lens
points; eyelab aims them at a regular NDC grid, ``oversample`` per voxel column), two
bundles leave the pupil: one focused at the eye's near point (accommodation Delta_max) and
one at its far point (no accommodation). For a toric eye the bundle through pupil point
rho leaves with the slope -(P - n2/z_r) rho that brings it back to the fovea, so the
near/far 'points' are astigmatic, as the wavefront method's eye. Both bundles are traced
exactly through the lens; the corrected near and far points are where each refracted
bundle is most convergent (least RMS spread, closed form for straight rays).

The refracted reference ray is then walked through the NDC voxel grid with the
Amanatides & Woo (1987) traversal. In each voxel, at the midpoint of the ray's segment, the
plane perpendicular to the ray cuts the bundle: the cut points minus the midpoint are the
displacement set (near bundle before the corrected near point, far bundle beyond the
corrected far point, zero between). The set is reduced to the 2x2 matrix that maps the
pupil seeds to it (least squares; exact for a linear spread), projected to NDC by the
camera's Jacobian, and averaged over all visits of the voxel (the paper averages the
displacement sets; the least-squares map is linear in the set, so this is the same).

Only NDC depth slicing is supported: a straight ray is straight in NDC (a projective
map), which the traversal needs; it is not straight in the linear-depth grid.
"""

from __future__ import annotations

import math
import time

import numpy as np

from eyelab.blur.field import BlurField, VoxelStatus
from eyelab.core.cache import content_key
from eyelab.core.constants import RAD_TO_ARCMIN
from eyelab.core.errors import SpecError
from eyelab.core.sampling import disc_seeds
from eyelab.core.vecmath import UP, cross, unit
from eyelab.optics.rays.camera import Camera, eye_camera, fit_virtual_camera
from eyelab.optics.rays.paths import ObjectPoints, find_chief_rays
from eyelab.optics.rays.trace import FATAL


def traverse(g0, g1, shape):
    """Amanatides & Woo (1987) voxel traversal of segments g0 -> g1 (each (r, 3) in grid
    units: voxel (i, j, k) spans [i, i+1] x [j, j+1] x [k, k+1], coordinates (x, y, z) with
    grid shape (nz, ny, nx)), vectorised over segments.

    Returns (ray index, k, j, i, lam_in, lam_out) arrays of every voxel visit, with lam the
    segment parameter in [0, 1].
    """
    nz, ny, nx = shape
    dims = np.array([nx, ny, nz], float)
    d = g1 - g0
    # clip to the grid box (slab test)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t_a = (0.0 - g0) * inv
        t_b = (dims - g0) * inv
    t_lo = np.where(d == 0, np.where((g0 >= 0) & (g0 <= dims), -np.inf, np.inf),
                    np.minimum(t_a, t_b))
    t_hi = np.where(d == 0, np.where((g0 >= 0) & (g0 <= dims), np.inf, -np.inf),
                    np.maximum(t_a, t_b))
    lam0 = np.maximum(t_lo.max(1), 0.0)
    lam1 = np.minimum(t_hi.min(1), 1.0)
    live = lam1 > lam0
    rays, ks, js, is_, lin, lout = [], [], [], [], [], []
    idx = np.flatnonzero(live)
    if len(idx) == 0:
        z = np.zeros(0, int)
        return z, z, z, z, np.zeros(0), np.zeros(0)
    g0, d, lam0, lam1 = g0[idx], d[idx], lam0[idx], lam1[idx]
    start = g0 + (lam0 + 1e-12 * (lam1 - lam0))[:, None] * d
    cell = np.clip(np.floor(start).astype(int), 0, np.array([nx, ny, nz]) - 1)
    step = np.where(d > 0, 1, np.where(d < 0, -1, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        next_b = cell + (step > 0)
        t_max = np.where(step != 0, (next_b - g0) / d, np.inf)
        t_delta = np.where(step != 0, np.abs(1.0 / d), np.inf)
    lam = lam0.copy()
    active = np.ones(len(idx), bool)
    limit = np.array([nx, ny, nz])
    while active.any():
        a = np.flatnonzero(active)
        tm = t_max[a]
        axis = np.argmin(tm, axis=1)
        t_next = np.minimum(tm[np.arange(len(a)), axis], lam1[a])
        rays.append(idx[a])
        is_.append(cell[a, 0])
        js.append(cell[a, 1])
        ks.append(cell[a, 2])
        lin.append(lam[a])
        lout.append(t_next)
        lam[a] = t_next
        done = t_next >= lam1[a]
        rows = a[~done]
        ax = axis[~done]
        cell[rows, ax] += step[rows, ax]
        t_max[rows, ax] += t_delta[rows, ax]
        out = (cell[rows, ax] < 0) | (cell[rows, ax] >= limit[ax])
        active[a[done]] = False
        active[rows[out]] = False
    cat = np.concatenate
    return cat(rays), cat(ks), cat(js), cat(is_), cat(lin), cat(lout)


def _ndc_to_grid(ndc, shape):
    nz, ny, nx = shape
    return np.stack([(ndc[..., 0] + 1) * 0.5 * nx, (ndc[..., 1] + 1) * 0.5 * ny,
                     (ndc[..., 2] + 1) * 0.5 * nz], -1)


def _grid_to_ndc(g, shape):
    nz, ny, nx = shape
    return np.stack([g[..., 0] / nx * 2 - 1, g[..., 1] / ny * 2 - 1, g[..., 2] / nz * 2 - 1], -1)


def _projection_jacobian(camera: Camera, p):
    """(n, 2, 3) d(ndc_x, ndc_y)/d(world position) at points p (n, 3)."""
    b = camera.basis
    rel = p - np.asarray(camera.position, float)
    w = rel @ b[2]
    tx, ty = camera.tan_half
    jx = (b[0][None] / w[:, None] - ((rel @ b[0]) / w**2)[:, None] * b[2][None]) / tx
    jy = (b[1][None] / w[:, None] - ((rel @ b[1]) / w**2)[:, None] * b[2][None]) / ty
    return np.stack([jx, jy], 1)


def _bundle(eye, lens, pupil, d_rev, seeds, accommodation, wavelength_nm):
    """Reference ray + one bundle per reference ray, traced out of the lens.

    Returns q, d (r, s+1, 3) (index 0 the reference ray), the eye x axes (r, 3) and status."""
    r = len(d_rev)
    n_in = -d_rev
    x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
    y_e = cross(n_in, x_e)
    rp = eye.pupil_diameter / 2
    pxx, pxy, pyy = (float(v) for v in eye.power_matrix(accommodation, wavelength_nm))
    e = eye.emmetropic_power
    g = np.array([[pxx - e, pxy], [pxy, pyy - e]])
    rho = np.vstack([[0.0, 0.0], seeds]) * rp                      # (s+1, 2) eye frame
    slope = rho @ g.T                                              # incoming slope = G rho
    origins = pupil + rho[None, :, :1] * x_e[:, None] + rho[None, :, 1:] * y_e[:, None]
    dirs = unit(d_rev[:, None] - slope[None, :, :1] * x_e[:, None]
                 - slope[None, :, 1:] * y_e[:, None])
    flat_o = origins.reshape(-1, 3)
    flat_d = dirs.reshape(-1, 3)
    if lens is None:
        return origins, dirs, x_e, np.zeros(r, np.uint8)
    res = lens.trace(flat_o, flat_d, wavelength_nm, reverse=True)
    st = ((res["status"] & np.uint8(FATAL)) != 0).reshape(r, -1).any(1)
    return (res["out_points"].reshape(origins.shape), res["out_dirs"].reshape(dirs.shape), x_e,
            st.astype(np.uint8))


def _spread_coefficients(q, d):
    """delta_j(s) = alpha_j + s beta_j: offsets of bundle ray j from the reference ray in the
    plane perpendicular to it at distance s along it. q, d (r, m, 3)."""
    q0, d0 = q[:, :1], d[:, :1]
    dq = q - q0
    cos = np.einsum("rmi,rmi->rm", d, np.broadcast_to(d0, d.shape))
    alpha = dq - (np.einsum("rmi,rmi->rm", dq, np.broadcast_to(d0, dq.shape)) / cos)[..., None] * d
    beta = d / cos[..., None] - d0
    return alpha, beta


def _focus_distance(alpha, beta):
    """Distance along the reference ray where the bundle's RMS spread is least; inf where
    the bundle never converges in front of the lens (parallel or diverging)."""
    ab = np.einsum("rmi,rmi->r", alpha, beta)
    bb = np.einsum("rmi,rmi->r", beta, beta)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -ab / bb
    return np.where((bb > 1e-30) & (s > 0), s, np.inf)


def compute_blur_field_bundles(eye, lens=None, camera: Camera | None = None, *,
                               shape=(128, 32, 32), samples: int = 32, oversample: int = 2,
                               wavelength_nm: float = 587.56, pupil=(0.0, 0.0, 0.0)
                               ) -> BlurField:
    """Blur field by ray bundles and voxel traversal (see the module docstring).

    ``samples`` pupil seeds per bundle (in [3, 1024]); ``oversample`` reference rays per
    voxel column along x and y (in [1, 8]). Voxels no reference ray visits are reported
    NOT_VISIBLE with a count in the report.
    """
    t0 = time.perf_counter()
    shape = tuple(int(s) for s in shape)
    if len(shape) != 3 or not all(1 <= s <= 1024 for s in shape):
        raise SpecError("shape", f"must be (nz, ny, nx) with each in [1, 1024], got {shape}")
    if not 3 <= samples <= 1024:
        raise SpecError("samples", f"must be in [3, 1024], got {samples}")
    if not 1 <= oversample <= 8:
        raise SpecError("oversample", f"must be in [1, 8], got {oversample}")
    pupil = np.asarray(pupil, float)
    if camera is None:
        ec = eye_camera()
        camera = ec if lens is None else fit_virtual_camera(lens, ec,
                                                            wavelength_nm=wavelength_nm).camera
    nz, ny, nx = shape
    # reference rays: aimed at an oversampled NDC grid of the field camera
    gx = -1.0 + (2 * np.arange(nx * oversample) + 1.0) / (nx * oversample)
    gy = -1.0 + (2 * np.arange(ny * oversample) + 1.0) / (ny * oversample)
    mx, my = np.meshgrid(gx, gy)
    dirs_cam = camera.ray_directions(mx.ravel(), my.ravel())
    cop = np.asarray(camera.position, float)
    fwd = camera.basis[2]
    if lens is None:
        aim = cop + dirs_cam * (1.0 / (dirs_cam @ fwd))[:, None]
        d_rev = unit(aim - pupil)
        ref_status = np.zeros(len(d_rev), np.uint8)
    else:
        ref_depth = 2.0 / (1.0 / camera.near + 1.0 / camera.far)
        aim = cop + dirs_cam * (ref_depth / (dirs_cam @ fwd))[:, None]
        chief = find_chief_rays(lens, pupil, ObjectPoints.from_positions(aim - pupil),
                                wavelength_nm, search=False)   # as the blur field's columns
        d_rev = -chief.dir_out
        ref_status = ((chief.status & np.uint8(FATAL)) != 0).astype(np.uint8)
    seeds = disc_seeds(samples)
    pinv = np.linalg.pinv(seeds)                                   # (2, s)
    bundles = {}
    for name, acc in (("near", eye.accommodation_max), ("far", 0.0)):
        q, d, x_e, st = _bundle(eye, lens, pupil, d_rev, seeds, acc, wavelength_nm)
        alpha, beta = _spread_coefficients(q, d)
        bundles[name] = (alpha[:, 1:], beta[:, 1:], _focus_distance(alpha[:, 1:], beta[:, 1:]))
        ref_status |= st
    q0, d0 = q[:, 0], d[:, 0]                                      # reference, outgoing
    ok_ref = ref_status == 0
    # segment from where the reference ray enters the view volume to the far plane
    w_q = (q0 - cop) @ fwd
    cosf = d0 @ fwd
    with np.errstate(divide="ignore", invalid="ignore"):
        s_start = np.maximum(0.0, (camera.near - w_q) / cosf)
        s_end = (camera.far - w_q) / cosf
    ok_ref &= (cosf > 1e-6) & (s_end > s_start)
    p_start = q0 + s_start[:, None] * d0
    p_end = q0 + s_end[:, None] * d0
    g0 = _ndc_to_grid(camera.world_to_ndc(p_start), shape)
    g1 = _ndc_to_grid(camera.world_to_ndc(p_end), shape)
    sel = np.flatnonzero(ok_ref)
    ray, kk, jj, ii, lin, lout = traverse(g0[sel], g1[sel], shape)
    ray = sel[ray]
    lam_mid = 0.5 * (lin + lout)
    gm = g0[ray] + lam_mid[:, None] * (g1[ray] - g0[ray])
    mid = camera.ndc_to_world(_grid_to_ndc(gm, shape))
    s_mid = np.einsum("ni,ni->n", mid - q0[ray], d0[ray])
    # displacement sets -> world 3x2 maps W (least squares on the seeds) per visit
    w_map = np.zeros((len(ray), 3, 2))
    acc_v = np.zeros(len(ray))
    for name, acc in (("near", eye.accommodation_max), ("far", 0.0)):
        alpha, beta, s_focus = bundles[name]
        use = (s_mid < s_focus[ray]) if name == "near" else (s_mid > s_focus[ray])
        if name == "far":
            use &= ~(s_mid < bundles["near"][2][ray])
        r = ray[use]
        delta = alpha[r] + s_mid[use][:, None, None] * beta[r]      # (v, s, 3)
        # the source displaced by -delta is what the pupil point sees (bundle reversibility)
        w_map[use] = -np.einsum("vsi,ks->vik", delta, pinv)
        acc_v[use] = acc
    between = (s_mid >= bundles["near"][2][ray]) & (s_mid <= bundles["far"][2][ray])
    dist_mid = np.linalg.norm(mid - pupil, axis=1)
    acc_v[between] = eye.accommodation_for(-1.0 / dist_mid[between])
    jac = _projection_jacobian(camera, mid)
    bmat = np.einsum("vij,vjk->vik", jac, w_map)
    # accumulate (average) per voxel
    flat = (kk * ny + jj) * nx + ii
    nvox = nz * ny * nx
    count = np.bincount(flat, minlength=nvox).astype(float)
    def acc_sum(vals):  # noqa: E306
        return np.stack([np.bincount(flat, vals[:, c], minlength=nvox)
                         for c in range(vals.shape[1])], 1)
    visited = count > 0
    safe = np.where(visited, count, 1.0)[:, None]
    bsum = acc_sum(bmat.reshape(-1, 4)) / safe
    wsum = acc_sum(w_map.reshape(-1, 6)) / safe
    msum = acc_sum(mid) / safe
    asum = np.bincount(flat, acc_v, minlength=nvox) / safe[:, 0]
    matrix = bsum.reshape(nz, ny, nx, 2, 2)
    # angular ellipse of the averaged world map, seen from the pupil
    wm = wsum.reshape(-1, 3, 2)
    dist = np.linalg.norm(msum - pupil, axis=1)
    sv = np.linalg.svd(wm, compute_uv=False) / np.where(visited, dist, 1.0)[:, None]
    major = (sv[:, 0] * RAD_TO_ARCMIN).reshape(nz, ny, nx)
    n_in = unit(pupil - np.where(visited[:, None], msum, pupil + [0, 0, -1.0]))
    x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
    y_e = cross(n_in, x_e)
    wxy = np.stack([np.einsum("ni,nik->nk", x_e, wm), np.einsum("ni,nik->nk", y_e, wm)], 1)
    u, _, _ = np.linalg.svd(wxy)
    omega = np.mod(np.arctan2(u[:, 1, 0], u[:, 0, 0]), math.pi).reshape(nz, ny, nx)
    to_ret = eye.retina_distance / eye.n_vitreous
    status = np.where(visited, VoxelStatus.OK, VoxelStatus.NOT_VISIBLE).astype(np.uint8)
    status = status.reshape(nz, ny, nx)
    report = {"method": "bundle", "shape": list(shape), "depth_mode": "ndc",
              "samples": samples, "oversample": oversample,
              "reference_rays": int(len(d_rev)), "reference_rays_failed": int((~ok_ref).sum()),
              "visits": int(len(ray)), "voxels_total": nvox,
              "voxels_unvisited": int((~visited).sum()),
              "voxel_status": {s.name.lower(): int((status == s).sum()) for s in VoxelStatus},
              "timings": {"total_s": time.perf_counter() - t0}}
    key = content_key(method="bundle", eye=eye, lens=lens, camera=camera, shape=shape,
                    samples=samples, oversample=oversample, wavelength=wavelength_nm,
                    pupil=pupil)
    return BlurField(camera, shape, "ndc", matrix,
                     -(sv[:, 1] * to_ret).reshape(nz, ny, nx),
                     (sv[:, 0] * to_ret).reshape(nz, ny, nx), omega, major,
                     asum.reshape(nz, ny, nx), status, msum.reshape(nz, ny, nx, 3), "bundle",
                     key, report)
