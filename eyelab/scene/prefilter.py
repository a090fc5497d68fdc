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
    if (hh, ww) != (h, w):
        tex = np.pad(tex, ((0, hh - h), (0, ww - w), (0, 0)), mode="edge")
    rows = decode_srgb(tex).reshape(hh // f, f, ww, 3).sum(axis=1)   # float32, one axis
    blocks = rows.reshape(hh // f, ww // f, f, 3).sum(axis=2)          # at a time: contiguous
    return encode_srgb(blocks * np.float32(1.0 / (f * f)))


#: A drawn texture is padded to power-of-two sides (:func:`drawn_texture`) while that adds
#: at most this many texels (4 Mi: 12 MiB of sRGB); larger ones are drawn at their own size.
POT_PAD_MAX_TEXELS = 1 << 22


def drawn_texture(texture: np.ndarray, f: int) -> tuple:
    """(texels (H, W, 3) uint8, hh, ww): ``texture`` (h, w, 3) reduced by ``f``
    (:func:`reduce_texture`, the last blocks padded) and then padded, edge texels
    repeated below and to the right, to power-of-two sides; the image fills the top-left
    h x w of the hh x ww original texels the result spans (hh = H f). Power-of-two sides:
    the software GL (llvmpipe) compiles a fragment-shader variant per combination of
    power-of-two or not in each side, 0.13-0.21 s each at its first draw (measured: four
    of them held the built-in view's first frame at S = 4 for 0.6 s); padded, all
    textures share one. Depends on the texels and f only: a refined mesh shares it."""
    tex = reduce_texture(texture, f) if f > 1 else texture
    th, tw = tex.shape[:2]
    ph, pw = 1 << (th - 1).bit_length(), 1 << (tw - 1).bit_length()
    if (ph, pw) != (th, tw) and ph * pw - th * tw <= POT_PAD_MAX_TEXELS:
        tex = np.pad(tex, ((0, ph - th), (0, pw - tw), (0, 0)), mode="edge")
    return tex, tex.shape[0] * f, tex.shape[1] * f


def with_texture(mesh: SceneMesh, drawn: tuple) -> SceneMesh:
    """``mesh`` drawing a :func:`drawn_texture` of its texture, its uv rescaled onto the
    part that holds the image (the same uv would stretch it by the padding: up to 10 %
    for a 2160-texel chart row reduced 264 times)."""
    tex, hh, ww = drawn
    h, w = mesh.texture.shape[:2]
    if (hh, ww) == (h, w):
        return mesh
    uv = np.column_stack([mesh.uv[:, 0] * (w / ww), 1.0 - (1.0 - mesh.uv[:, 1]) * (h / hh)])
    return SceneMesh(mesh.name, mesh.vertices, mesh.faces, None, tex, uv)


def prefiltered(mesh: SceneMesh, f: int) -> SceneMesh:
    """The mesh drawing its texture reduced by ``f`` and padded to power-of-two sides
    (:func:`drawn_texture`, :func:`with_texture`); the mesh itself when it has no
    texture or nothing changes."""
    if mesh.texture is None:
        return mesh
    return with_texture(mesh, drawn_texture(mesh.texture, f))
