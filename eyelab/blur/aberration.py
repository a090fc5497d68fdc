"""Ray-aberration fields: the blur field generalised from Kakimoto's matrix x seed (Eq. 9,
the Sturm conoid's second-order ellipse) to the map the exact rays give.

A pass of the raster displaces every vertex by the field at its voxel, evaluated at the
pass's pupil sample s (a point of the unit disc): today ``B s``. The real eye's rays do
not land on an ellipse: coma bends the blur into a comet and moves its light off the chief
ray, spherical aberration makes a defocused disc's edge brighter or softer, the eye's
lateral colour moves each colour's image. Per voxel and colour channel this module fits,
from rays traced exactly, the displacement d(s) (NDC, the field camera's) of the light of
a scene point that reaches a line of sight through the pupil point s, as a polynomial in
s = (x, y):

    d(s) = c + B s + Q (x^2, x y, y^2) + C (x^3, x^2 y, x y^2, y^3)

(:data:`BASIS`, 10 terms per component): the constant is the centroid's shift (lateral
colour, coma's), the linear part today's matrix (defocus, astigmatism, and the aperture's
average of the higher orders), the quadratic part coma's shape, the cubic spherical
aberration's. The order is the one whose measured residual stops paying
(:data:`ORDER`).

How the rays are found (for a schematic eye: :mod:`eyelab.optics.chain.retinal_rays`, the
reference renderer's own rays): a column of the field is a line of sight whose chief ray
lands at the retinal point R (at the eye's reference wavelength: the pixel grid is the
lines of sight). From R, rays leave through :data:`FIT_SAMPLES` equal-area points of the
stop (the iris) at the channel's wavelength, out through the eye and the spectacle lens
into the scene: each is a line in the scene. A vertex P at depth w on the line through
the stop point s is seen at R's pixel, so it is drawn displaced by the pixel's NDC less
P's own NDC (the field camera's projection). These displacements, at every depth slice of
the column, are fitted by least squares in the basis above (the stop point s = r_stop x
the unit-disc seed: a seed stands for a point of the iris, as in the reference
renderer's equal-area samples).

The reversed rays give the forward displacement to first order in how fast the
aberrations change across the view (a vertex at P is displaced by the map of the line of
sight that sees it, not of its own): the field varies over degrees, blurs over minutes of
arc.
"""

from __future__ import annotations

import numpy as np

from eyelab.core.sampling import equal_area_seeds

#: The highest power of the pupil coordinates fitted. Measured on the Navarro eye (4 mm
#: pupil; relaxed, a -3 D myope, the myope behind a -3 D lens; lines of sight at 0, 10,
#: 20, 30 deg; objects far: ``tests/test_aberration_field.py::test_the_fit_order``): the
#: RMS residual of the rays' displacements about the fit, as a share of their RMS spread,
#: is 34-93 % at order 1 (the relaxed eye's and the lens wearer's blur is not an ellipse;
#: 4-38 % for the naked myope, defocus dominating), 4-72 % at order 2 (coma's shape: the
#: on-axis blur is spherical aberration), 0.1-1.3 % at order 3 and 0.1-1.2 % at order 4.
#: Three it is: the cubic terms carry spherical aberration, a fourth order nothing.
ORDER = 3

#: The monomials x^i y^j (i + j <= ORDER), in the order of the coefficients' last axis:
#: constant, the two linear terms (the matrix), then the quadratic and cubic ones.
BASIS = tuple((i - j, j) for i in range(ORDER + 1) for j in range(i + 1))

#: Indices of :data:`BASIS` that are not linear: what :class:`~eyelab.blur.field.BlurField`
#: keeps beside its matrix (``aberration[..., 2, len(HIGHER)]``).
HIGHER = tuple(k for k, (i, j) in enumerate(BASIS) if i + j != 1)
LINEAR = tuple(k for k, (i, j) in enumerate(BASIS) if i + j == 1)

#: Rays per column traced to fit the map: equal-area points of the stop, 3.6 per unknown
#: (10 per component), so that a few vignetted rays leave the fit determined.
FIT_SAMPLES = 36


def basis(seeds) -> np.ndarray:
    """(n, len(BASIS)) the monomials of :data:`BASIS` at ``seeds`` (n, 2), unit-disc
    coordinates."""
    s = np.atleast_2d(np.asarray(seeds, float))
    return np.stack([s[:, 0] ** i * s[:, 1] ** j for i, j in BASIS], -1)


def higher_basis(seeds) -> np.ndarray:
    """(n, len(HIGHER)) the non-linear monomials at ``seeds`` (n, 2)."""
    return basis(seeds)[:, list(HIGHER)]


def disc_moments() -> np.ndarray:
    """(len(BASIS), len(BASIS)) E[phi_a phi_b] over the uniform unit disc: the Gram matrix
    of the basis, exact (E[x^2p y^2q] = (2p-1)!!(2q-1)!! / ((2p+2q+2)!! / 2) ... in closed
    form via the Beta function: int r^(2n+1) dr * int cos^2p sin^2q / pi)."""
    from math import gamma

    def mom(p, q):          # E[x^p y^q] over the unit disc (uniform)
        if p % 2 or q % 2:
            return 0.0
        n = p + q
        ang = 2 * gamma((p + 1) / 2) * gamma((q + 1) / 2) / gamma((n + 2) / 2)
        return ang / (n + 2) / np.pi

    k = len(BASIS)
    g = np.empty((k, k))
    for a, (i1, j1) in enumerate(BASIS):
        for b, (i2, j2) in enumerate(BASIS):
            g[a, b] = mom(i1 + i2, j1 + j2)
    return g


def disc_means() -> np.ndarray:
    """(len(BASIS),) E[phi] over the uniform unit disc."""
    return disc_moments()[0]


def map_covariance(matrix, aberration, seeds=None) -> np.ndarray:
    """(..., 2, 2) the covariance of the map whose linear part is ``matrix`` (..., 2, 2)
    and non-linear part ``aberration`` (..., 2, len(HIGHER)) (or None: then ``matrix (I/4)
    matrix^T``) over the uniform unit disc, or over the points ``seeds`` (S, 2) (what S
    passes draw: a pass set has the disc's mean and covariance, not its higher moments,
    so a cubic map's spread over 8 seeds falls short of the disc's)."""
    coef = full_coefficients(matrix, aberration)
    cov_basis = seed_moments(seeds)[1]
    return (coef @ cov_basis) @ np.swapaxes(coef, -1, -2)


def seed_moments(seeds=None) -> tuple:
    """(E[phi] (len(BASIS),), the basis's covariance (len(BASIS), len(BASIS))) over the
    uniform unit disc, or over the points ``seeds`` (S, 2)."""
    if seeds is None:
        g = disc_moments()
    else:
        phi = basis(seeds)
        g = phi.T @ phi / len(phi)
    return g[0], g - np.outer(g[0], g[0])


RANK1_RATIO = 1e-4
"""A covariance whose minor standard deviation is below this share of its major one is a
line (rank 1) to :func:`sym_power`: an exactly rank-1 product of large maps keeps round-off
of up to ~1e-6 there."""


def sym_power(cov, p: float) -> np.ndarray:
    """(..., 2, 2) cov^p, p = 1/2 or -1/2, of symmetric positive semi-definite ``cov``,
    in closed form: sqrt(C) = (C + sqrt(det) I) / sqrt(tr + 2 sqrt(det)) (the 2 x 2
    identity, exact for det = 0: a rank-1 C = l v v^T gives sqrt(l) v v^T); C^(-1/2) its
    inverse, or for a singular C the pseudo-power C / tr^(3/2) (zero for C = 0). C counts as
    singular when its axes' standard deviations differ by more than :data:`RANK1_RATIO`
    (a rank-1 C, such as a two-point seed set's, keeps round-off of up to ~1e-6 there)."""
    if p not in (0.5, -0.5):
        raise ValueError(f"sym_power takes p = 1/2 or -1/2, got {p}")
    c = np.asarray(cov, float)
    a, b, d = c[..., 0, 0], 0.5 * (c[..., 0, 1] + c[..., 1, 0]), c[..., 1, 1]
    tr = np.maximum(a + d, 0.0)
    det = np.maximum(a * d - b * b, 0.0)
    sd = np.sqrt(det)
    den = np.sqrt(tr + 2 * sd)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(den > 0, 1.0 / den, 0.0)
        ra, rb, rd = (a + sd) * inv, b * inv, (d + sd) * inv          # sqrt(C)
        if p == 0.5:
            out = np.stack([np.stack([ra, rb], -1), np.stack([rb, rd], -1)], -2)
            return out
        rdet = ra * rd - rb * rb                                          # = sqrt(det)
        regular = sd > RANK1_RATIO * np.maximum(tr, 1e-300)     # sd / tr ~ minor / major
        k = np.where(regular, 1.0 / np.where(regular, rdet, 1.0), 0.0)
        pa, pb, pd = rd * k, -rb * k, ra * k                              # inv(sqrt(C))
        q = np.where((~regular) & (tr > 0), tr ** -1.5, 0.0)              # pseudo
        pa, pb, pd = (np.where(regular, x, y * q) for x, y in ((pa, a), (pb, b), (pd, d)))
    return np.stack([np.stack([pa, pb], -1), np.stack([pb, pd], -1)], -2)


def full_coefficients(matrix, aberration) -> np.ndarray:
    """(..., 2, len(BASIS)) all the map's coefficients from its matrix and non-linear
    part (zeros for None)."""
    matrix = np.asarray(matrix, float)
    coef = np.zeros(matrix.shape[:-1] + (len(BASIS),))
    coef[..., list(LINEAR)] = matrix
    if aberration is not None:
        coef[..., list(HIGHER)] = aberration
    return coef


def cov_equivalent_matrix(cov) -> np.ndarray:
    """(..., 2, 2) the symmetric matrix B_eq whose disc B_eq (I/4) B_eq^T has the
    covariance ``cov`` (..., 2, 2): 2 cov^(1/2) (the ellipse of the same second
    moments)."""
    return 2 * sym_power(cov, 0.5)


def fit_solver(ok) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares operators of the columns' fits: ``ok`` (c, n) the rays that were
    traced (of :data:`FIT_SAMPLES` seeds); returns (ops (c, len(BASIS), n), good (c,)):
    coefficients = ops @ samples; ``good`` False where too few rays got through to fit
    (fewer than twice the unknowns)."""
    phi = basis(fit_seeds())                                   # (n, k)
    w = ok.astype(float)
    a = np.einsum("na,cn,nb->cab", phi, w, phi)
    k = len(BASIS)
    good = w.sum(axis=1) >= 2 * k
    a[~good] = np.eye(k)
    ops = np.linalg.solve(a, np.einsum("na,cn->can", phi, w))
    ops[~good] = 0.0
    return ops, good


def fit_seeds() -> np.ndarray:
    """(FIT_SAMPLES, 2) the unit-disc points the fit's rays go through (equal area)."""
    return equal_area_seeds(FIT_SAMPLES)


def schematic_ray_samples(eye, lens, rot, vertex, d_in, accommodation: float,
                          wavelength_nm: float, reference_nm: float) -> tuple:
    """Rays from the retinal points of the lines of sight ``d_in`` (c, 3, world, into the
    eye; their chief rays at ``reference_nm``) out through the :func:`fit_seeds` points of
    the stop at ``wavelength_nm``, through the eye and (when given) the spectacle lens,
    which a ray that misses passes straight: (origins (c, n, 3), directions (c, n, 3)
    scene-ward, ok (c, n))."""
    from eyelab.optics.chain.retinal_rays import (
        rays_from_retina,
        retina_points,
        stop_jacobians,
    )
    from eyelab.optics.rays.trace import FATAL

    c = len(d_in)
    seeds = fit_seeds()
    n = len(seeds)
    r_pt, v0, st = retina_points(eye, rot, vertex, d_in, accommodation, reference_nm)
    v0 = v0 / np.linalg.norm(v0, axis=1, keepdims=True)
    jac = stop_jacobians(eye, rot, vertex, r_pt, v0, accommodation, wavelength_nm)
    r_stop = eye.stop_radius(accommodation, reference_nm)
    rows = np.repeat(np.arange(c), n)
    targets = r_stop * np.tile(seeds, (c, 1))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        o, d, ok = rays_from_retina(eye, rot, vertex, r_pt[rows], v0[rows], targets,
                                    (rows, jac), accommodation, wavelength_nm)
    ok &= ((st & np.uint8(FATAL)) == 0)[rows]
    if lens is not None:
        r2 = lens.trace(o, d, wavelength_nm, reverse=True)
        through = (r2["status"] & np.uint8(FATAL)) == 0
        o = np.where(through[:, None], r2["out_points"], o)
        d = np.where(through[:, None], r2["out_dirs"], d)
    ok &= np.all(np.isfinite(o), axis=1) & np.all(np.isfinite(d), axis=1)
    return o.reshape(c, n, 3), d.reshape(c, n, 3), ok.reshape(c, n)


def fit_columns(camera, o, d, ok, depths, ref_ndc) -> tuple[np.ndarray, np.ndarray]:
    """Fit the maps of voxels: rays (c, n, 3) origins ``o`` and directions ``d`` of each
    column (``ok`` (c, n)), the voxels' camera depths ``depths`` (m,) (m), and the NDC
    each voxel's pixel shows, ``ref_ndc`` (c, m, 2). Returns (coefficients (c, m, 2,
    len(BASIS)), NDC per unit seed; good (c,): columns fitted) and the RMS residual
    share (c, 3) at the nearest, middle and farthest depths (residual RMS over the
    displacements' RMS spread).

    A ray's NDC at camera depth w is affine in 1/w: with a = (o - C).r, e = (o - C).f, b =
    d.r, g = d.f (r, f the camera's right and forward axes, C its centre), x_ndc = ((a - e
    b / g) / w + b / g) / tan_x, and y likewise; so is each least-squares coefficient. The
    fit is made once per column for the two parts and put together per depth."""
    cop = np.asarray(camera.position, float)
    right, up, fwd = (np.asarray(v, float) for v in camera.basis)
    tx, ty = camera.tan_half
    rel = o - cop
    g = d @ fwd                                                          # (c, n)
    e = rel @ fwd
    good_ray = ok & (g > 1e-9) & (e < float(np.min(depths)))
    gs = np.where(good_ray, g, 1.0)
    parts = []                                        # (c, n, 2) the 1/w and constant parts
    for axis, tan in ((right, tx), (up, ty)):
        b = (d @ axis) / gs
        parts.append(((rel @ axis) - e * b, b, tan))
    inv_w = (np.stack([p[0] / p[2] for p in parts], -1),                 # (c, n, 2)
             np.stack([p[1] / p[2] for p in parts], -1))
    ops, good = fit_solver(good_ray)
    # coefficients of the rays' NDC, its 1/w part and its constant part: (c, 2, k)
    cv = np.einsum("can,cnd->cda", ops, np.where(good_ray[..., None], inv_w[0], 0.0))
    cu = np.einsum("can,cnd->cda", ops, np.where(good_ray[..., None], inv_w[1], 0.0))
    # the displacement is the pixel's NDC less the ray's: minus the fit, plus the
    # reference in the constant term
    coef = -(cu[:, None] + cv[:, None] / depths[None, :, None, None])   # (c, m, 2, k)
    coef[..., 0] += ref_ndc
    # residuals (of the NDC, the same as of the displacement), at the nearest, middle and
    # farthest depths (a report: what the fit leaves)
    pick = np.unique([0, len(depths) // 2, len(depths) - 1])
    phi = basis(fit_seeds())                                            # (n, k)
    dp = depths[pick]
    ndc = inv_w[1][:, :, None] + inv_w[0][:, :, None] / dp[None, None, :, None]
    fit = np.einsum("na,cmda->cnmd", phi, cu[:, None] + cv[:, None] / dp[None, :, None, None])
    w = good_ray[..., None].astype(float)                               # (c, n, 1)
    cnt = np.maximum(w.sum(axis=1), 1.0)                                # (c, 1)
    res = (((ndc - fit) ** 2).sum(-1) * w).sum(axis=1) / cnt            # (c, 3)
    mean = (ndc * w[..., None]).sum(axis=1) / cnt[..., None]
    spread = ((((ndc - mean[:, None]) ** 2).sum(-1)) * w).sum(axis=1) / cnt
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(spread > 0, np.sqrt(res / spread), 0.0)
    return coef, good, share
