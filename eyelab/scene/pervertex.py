"""Per-vertex ray tracing through the lens (Kakimoto 2007, §3): for every lens vertex, the
ray from the pupil centre through it is refracted exactly at both lens surfaces (per
wavelength), cast into the scene, and its hit is projected into the virtual camera: the
texture coordinate of that vertex into the environment image.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.optics.rays.trace import FATAL


@dataclass
class LensTexcoords:
    """uv : (channels, n, 2) texture coordinates (v = 0 at the image bottom);
    hits : (channels, n, 3) world points seen (far points along the ray on a miss);
    scene_hit : (channels, n) bool; lens_ok : (channels, n) bool (False: the ray misses the
    lens or is totally reflected: the vertex gets the defined 'invalid' colour);
    wavelengths : tuple of nm; transmittance : (channels, n) Fresnel transmission of the
    two lens surfaces along each vertex's ray (0 where the ray fails)."""

    uv: np.ndarray
    hits: np.ndarray
    scene_hit: np.ndarray
    lens_ok: np.ndarray
    wavelengths: tuple
    transmittance: np.ndarray


def lens_texcoords(lens, points, camera, intersector, *, wavelengths=(587.56,),
                   pupil=(0.0, 0.0, 0.0), miss_distance=None) -> LensTexcoords:
    """Texture coordinates into ``camera``'s image for lens vertices ``points`` (n, 3) (on
    the back surface, as the eye sees it). A ray that misses the scene is followed to
    ``miss_distance`` (default the camera's far plane): it then shows the background,
    exactly where the environment image shows it."""
    pupil = np.asarray(pupil, float)
    d = np.asarray(points, float) - pupil
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return ray_texcoords(lens, np.broadcast_to(pupil, d.shape), d, camera, intersector,
                         wavelengths=wavelengths, miss_distance=miss_distance)


def ray_texcoords(lens, origins, directions, camera, intersector, *,
                  wavelengths=(587.56,), miss_distance=None) -> LensTexcoords:
    """:func:`lens_texcoords` of rays from the eye side: ``origins`` and unit
    ``directions`` (n, 3), each traced back through the lens into the scene."""
    far = miss_distance or camera.far * 0.999
    uvs, hits, shit, lok, trans = [], [], [], [], []
    for res in lens.trace_wavelengths(origins, directions, wavelengths, reverse=True):
        ok = (res["status"] & np.uint8(FATAL)) == 0
        q, dd = res["out_points"], res["out_dirs"]
        h = intersector.intersect(q + 1e-6 * dd, dd)
        t = np.where(h.hit, h.t + 1e-6, np.nan)
        # a miss: the point on the ray at the camera's far depth
        w_q = camera.depth(q)
        s_far = (far - w_q) / (dd @ camera.basis[2])
        t = np.where(h.hit, t, s_far)
        p = q + t[:, None] * dd
        ndc = camera.world_to_ndc(p)
        uvs.append(np.stack([0.5 * ndc[:, 0] + 0.5, 0.5 * ndc[:, 1] + 0.5], 1))
        hits.append(p)
        shit.append(h.hit & ok)
        lok.append(ok)
        trans.append(res["transmittance"])
    return LensTexcoords(np.array(uvs), np.array(hits), np.array(shit), np.array(lok),
                         tuple(wavelengths), np.array(trans))
