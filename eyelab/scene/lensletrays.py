"""The view through a lenslet lens per pupil sample: the raster's multi-image method.

A smooth lens sends every ray of a pixel's pencil to one scene point, blurred: the seed's
blur fields (Kakimoto 2007, §3) carry that. A lenslet lens (:mod:`eyelab.optics.lens.
lenslets`) splits the pencil: the part of the pupil that looks through the carrier and the
parts that look through lenslets see different scene points at once. So the raster draws
the carrier's view as for any lens (its environment image, blur fields and per-vertex
texture coordinates, the eye focusing the carrier's image) and then, per pupil sample k,
moves each lens-grid vertex's texture coordinate by where that sample's ray lands through
the lenslets instead of through the carrier:

    uv_k(v) = uv_carrier(v) + [uv(ray_k(v) through the lens) - uv(ray_k(v) through the
    carrier)],

ray_k(v) leaving the pupil point rho_k of the eye's pencil for vertex v's pixel (the pencil
of the pixel's retinal point: slope -G rho relative to the chief ray, G the eye's power
error for its accommodation there, as the reference renderer's rays; a schematic eye takes
its refraction need along the line of sight). The bracket is zero wherever the sample's
ray misses every lenslet (the carrier's own blur stays in the environment image); inside a
lenslet it is the lenslet's deviation of that very ray, traced exactly through both
surfaces and cast into the scene (embree). The K views are averaged in linear light: a
pixel's light through the lenslets is the share of its pencil that meets them, at the
scene points those rays see — both images at once.

The pupil samples are :func:`~eyelab.core.sampling.equal_area_seeds` (each standing for
an equal share of the pupil's area, the share through lenslets being their count; mean 0
and the disc's covariance for every K >= 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.core.sampling import equal_area_seeds
from eyelab.core.vecmath import UP, cross, unit
from eyelab.optics.eye.thin import EYE_REFERENCE_NM
from eyelab.optics.rays.trace import FATAL
from eyelab.scene.pervertex import ray_texcoords


@dataclass
class LensletOffsets:
    """Per pupil sample, the lens grid's texture-coordinate offsets through the lenslets.

    offsets : (K, channels, n, 2) float32, uv units (0 where sample k's ray of vertex i
    meets no lenslet); through : (K, n) bool, the ray meets a lenslet; failed : rays that
    pass the carrier but fail in the lenslet lens (their offset is 0); seeds : (K, 2) the
    pupil samples in the unit disc; cell_sigma_rad : the spread (rad, per axis) of the
    lenslet rays of one sample's share of the pupil (:func:`cell_sigma`)."""

    offsets: np.ndarray
    through: np.ndarray
    failed: int
    seeds: np.ndarray
    cell_sigma_rad: float

    @property
    def share(self) -> np.ndarray:
        """(n,) the fraction of each vertex's pupil samples that meet a lenslet."""
        return self.through.mean(0)

    @property
    def active(self) -> np.ndarray:
        """(K,) whether sample k's view differs from the carrier's anywhere."""
        return self.through.any(1)


def cell_sigma(add_d: float, pupil_radius: float, samples: int) -> float:
    """The per-axis standard deviation (rad) of the directions, through a lenslet of add
    ``add_d`` (D = rad/m: a ray's turn changes by the add per metre across the lenslet,
    Prentice's rule), of the rays of one pupil sample's share of a pupil of radius
    ``pupil_radius`` (m): a disc of 1/K of its area, radius a = r / sqrt(K), variance a^2 / 4
    per axis. Spreading each sample's lenslet light by it gives the K point samples the
    second moments of the whole pupil's (as the raster's variance-compensated blur)."""
    return abs(add_d) * pupil_radius / (2.0 * np.sqrt(samples))


def pencil_slopes(eye, d, acc, pupil) -> np.ndarray:
    """(n, 2, 2) the slope matrix G of each pixel's pencil (chief directions ``d`` (n, 3)
    from the pupil centre ``pupil``, accommodation ``acc`` (n,) D): a ray through pupil
    point rho (m, in the frame of :func:`pupil_frame`) leaves with slope -G rho relative to
    the chief ray. A thin eye: its power error, G = P(acc) - n2/z_r (the reference
    renderer's pencil); a schematic eye: -(its needed wave's mean) along its line of sight
    (:func:`~eyelab.optics.chain.retinal_rays.needed_wave`, the fixation's
    accommodation)."""
    n = len(d)
    if hasattr(eye, "power_matrix"):
        pxx, pxy, pyy = eye.power_matrix(acc)
        e = eye.emmetropic_power
        g = np.empty((n, 2, 2))
        g[:, 0, 0], g[:, 0, 1] = pxx - e, pxy
        g[:, 1, 0], g[:, 1, 1] = pxy, pyy - e
        return g
    from eyelab.blur.schematic import eye_frame
    from eyelab.optics.chain.retinal_rays import needed_wave

    rot, vertex = eye_frame(eye, pupil)
    axis = rot[:, 2][None]
    (kxx, _, kyy), _ = needed_wave(eye, rot, vertex, axis, rot[:, 0][None],
                                   float(np.mean(acc)), EYE_REFERENCE_NM)
    g = -0.5 * float(kxx[0] + kyy[0])
    return np.broadcast_to(g * np.eye(2), (n, 2, 2)).copy()


def pupil_frame(d) -> tuple:
    """(x_e, y_e) (n, 3): the pupil's axes across each chief direction ``d`` (n, 3), as the
    reference renderer lays its pupil samples."""
    n_in = -np.asarray(d, float)
    x_e = unit(cross(np.broadcast_to(UP, n_in.shape), n_in))
    return x_e, cross(n_in, x_e)


def lenslet_offsets(lens, grid_v, cam, vcam, intersector, eye, acc, *, samples: int,
                    wavelengths=(EYE_REFERENCE_NM,)) -> LensletOffsets:
    """The lens grid's per-sample offsets (module doc) of lenslet ``lens`` (its carrier:
    :func:`~eyelab.optics.lens.lenslets.carrier`): vertices ``grid_v`` (n, 3) on the lens's
    back, seen from the eye camera ``cam``; texture coordinates into ``vcam``'s image;
    ``acc`` (n,) the eye's accommodation per vertex; ``samples`` K pupil samples of the
    eye's pupil (radius ``eye.pupil_diameter / 2``)."""
    from eyelab.optics.lens.lenslets import carrier

    base = carrier(lens)
    pupil = np.asarray(cam.position, float)
    d = unit(np.asarray(grid_v, float) - pupil)
    n = len(d)
    x_e, y_e = pupil_frame(d)
    g = pencil_slopes(eye, d, np.broadcast_to(np.asarray(acc, float), (n,)), pupil)
    seeds = equal_area_seeds(samples)
    rp = eye.pupil_diameter / 2
    front = base.placed_surfaces()[0]
    surf = lens.front
    k_all = len(seeds)
    # every sample's rays at once: (K, n) flattened
    rho = rp * seeds                                                   # (K, 2) m
    o = pupil + rho[:, None, :1] * x_e + rho[:, None, 1:] * y_e        # (K, n, 3)
    slope = np.einsum("nij,kj->kni", g, rho)                           # (K, n, 2)
    dirs = unit(d - slope[..., :1] * x_e - slope[..., 1:] * y_e).reshape(-1, 3)
    o = o.reshape(-1, 3)
    res = base.trace(o, dirs, EYE_REFERENCE_NM, reverse=True)
    ok = (res["status"] & np.uint8(FATAL)) == 0
    local = front.to_local(res["hit2"].points)
    idx = np.flatnonzero(ok & (surf.which(local[:, 0], local[:, 1]) >= 0))
    offsets = np.zeros((len(wavelengths), k_all * n, 2), np.float32)
    through = np.zeros(k_all * n, bool)
    failed = 0
    if len(idx):            # the rays that meet a lenslet: through it and the carrier
        on = ray_texcoords(lens, o[idx], dirs[idx], vcam, intersector,
                           wavelengths=wavelengths)
        off = ray_texcoords(base, o[idx], dirs[idx], vcam, intersector,
                            wavelengths=wavelengths)
        good = on.lens_ok.all(0) & off.lens_ok.all(0)
        failed = int((~good).sum())
        offsets[:, idx[good]] = (on.uv - off.uv)[:, good]
        through[idx[good]] = True
    offsets = offsets.reshape(len(wavelengths), k_all, n, 2).transpose(1, 0, 2, 3)
    return LensletOffsets(np.ascontiguousarray(offsets), through.reshape(k_all, n), failed,
                          seeds, cell_sigma(surf.add_d, rp, k_all))
