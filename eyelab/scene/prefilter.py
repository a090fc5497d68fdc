"""Textures prefiltered to the resolution they are seen at (box filter in linear light).

A texture seen at M texels per pixel is sampled by the raster renderer's S jittered passes
at S points per pixel: for M much larger than 1 those few point samples alias, while GL
mip-maps (a box of the pixel's size, then a bilinear tent of the same size) blur twice the
pixel. Reducing the texture by an integer factor f ~ M / 2 first (each new texel the mean
light of f x f old ones) leaves about two texels per pixel, which the passes resolve
without the mip-maps' extra blur. Pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.color import decode_srgb, encode_srgb
from eyelab.scene.scene import SceneMesh


def world_per_texel(mesh: SceneMesh) -> float:
    """Median size (m) of one texel on the mesh surface (from edge lengths in the world and
    in texels)."""
    f = mesh.faces
    h, w = mesh.texture.shape[:2]
    scale = np.array([w, h], float)
    ratios = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        dw = np.linalg.norm(mesh.vertices[f[:, a]] - mesh.vertices[f[:, b]], axis=1)
        dt = np.linalg.norm((mesh.uv[f[:, a]] - mesh.uv[f[:, b]]) * scale, axis=1)
        ok = dt > 1e-9
        ratios.append(dw[ok] / dt[ok])
    r = np.concatenate(ratios)
    return float(np.median(r)) if len(r) else math.inf


def texels_per_pixel(mesh: SceneMesh, cam, height_px: int) -> float:
    """Texels per pixel where the mesh is nearest the camera (in front of its near plane):
    the least minification over the mesh."""
    w = cam.depth(mesh.vertices)
    w = w[w > cam.near]
    if not len(w):
        return 1.0
    pixel = 2.0 * float(w.min()) * math.tan(math.radians(cam.fov_y_deg) / 2) / height_px
    return pixel / world_per_texel(mesh)


def reduction_factor(mesh: SceneMesh, cam, height_px: int) -> int:
    """The integer f ~ M / 2 (M texels per pixel, nearest part) that leaves about two texels
    per pixel; 1 when the texture is not minified that much."""
    if mesh.texture is None:
        return 1
    m = texels_per_pixel(mesh, cam, height_px)
    return max(1, int(m // 2))


def reduce_texture(tex: np.ndarray, f: int) -> np.ndarray:
    """(h, w, 3) uint8 sRGB -> (ceil(h/f), ceil(w/f), 3): each new texel the mean linear
    light of an f x f block (edge blocks padded by repeating the edge), re-encoded."""
    if f <= 1:
        return tex
    h, w = tex.shape[:2]
    hh, ww = -(-h // f) * f, -(-w // f) * f
    lin = decode_srgb(np.pad(tex, ((0, hh - h), (0, ww - w), (0, 0)), mode="edge"))
    mean = lin.reshape(hh // f, f, ww // f, f, 3).mean(axis=(1, 3))
    return encode_srgb(mean)


def prefiltered(mesh: SceneMesh, f: int) -> SceneMesh:
    """The mesh with its texture reduced by ``f`` (the same uv: they are fractions of the
    image); the mesh itself when f is 1 or it has no texture."""
    if f <= 1 or mesh.texture is None:
        return mesh
    return SceneMesh(mesh.name, mesh.vertices, mesh.faces, None,
                     reduce_texture(mesh.texture, f), mesh.uv)
