"""Procedural scenes with known geometry (world frame of eyelab: eye at the origin looking
along -z, x right, y up, metres).

* :func:`chart_scene` — an ETDRS acuity chart of Sloan letters (5 per row, rows 0.1 logMAR
  apart from 1.0 to -0.3, letter height 5 MAR, spacing one letter width, row gap the next
  row's height) at a chosen distance and contrast, each letter a quad of its exact size;
* :func:`page_scene` — a page of text-like lines at reading distance;
* :func:`tilted_page_scene` — a page from 6 to 11 cm, tilted (Kakimoto Fig. 12);
* :func:`depth_ramp_scene` — a checkerboard floor receding from 0.3 m to 10 m;
* :func:`room_scene` — a room: checker floor, a chart on the back wall at 6 m, boxes at
  0.3-4 m, a page at 0.4 m (the built-in default scene);
* :func:`dot_scene` — one small bright square on black, for blur measurements.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.scene.scene import Scene, SceneMesh


def grid_quad(name, centre, right, up, width, height, *, nu=16, nv=16, texture=None,
              colors=None):
    """A rectangle tessellated into nu x nv cells: centre (3,), unit right/up axes."""
    centre, right, up = (np.asarray(v, float) for v in (centre, right, up))
    u = np.linspace(0.0, 1.0, nu + 1)
    v = np.linspace(0.0, 1.0, nv + 1)
    uu, vv = np.meshgrid(u, v)
    pts = (centre + ((uu - 0.5) * width)[..., None] * right
           + ((vv - 0.5) * height)[..., None] * up).reshape(-1, 3)
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    uv = np.stack([uu.ravel(), vv.ravel()], 1)
    return SceneMesh(name, pts, faces, colors=colors, texture=texture,
                     uv=uv if texture is not None else None)


def tumbling_e(size_px: int, orientation: int) -> np.ndarray:
    """A 5x5-stroke tumbling E (True = ink), opening right (0), up (1), left (2), down (3)."""
    e = np.zeros((5, 5), bool)
    e[:, 0] = True
    e[0, :] = e[2, :] = e[4, :] = True
    e = np.rot90(e, orientation)
    return np.kron(e, np.ones((size_px // 5, size_px // 5), bool))


#: logMAR of the ETDRS rows, largest first (1.0 = 20/200 ... -0.3 = 20/10).
ETDRS_ROWS = tuple(np.round(np.arange(1.0, -0.31, -0.1), 1))
#: The ten Sloan letters of ETDRS charts.
SLOAN = "CDHKNORSVZ"


#: Each Sloan letter's strokes on the 5 x 5 design grid, drawn in this order: ("bar", x0,
#: y0, x1, y1) a filled rectangle, ("poly", (x, y), ...) a filled polygon, ("ring", x0, y0,
#: x1, y1[, start, end]) a stroke-wide circular arc (deg, PIL's clockwise-from-+x angles)
#: in that box.
SLOAN_STROKES = {
    "H": (("bar", 0, 0, 1, 5), ("bar", 4, 0, 5, 5), ("bar", 0, 2, 5, 3)),
    "Z": (("bar", 0, 0, 5, 1), ("bar", 0, 4, 5, 5),
          ("poly", (3.75, 1), (5, 1), (1.25, 4), (0, 4))),
    "N": (("bar", 0, 0, 1, 5), ("bar", 4, 0, 5, 5),
          ("poly", (0, 0), (1.25, 0), (5, 5), (3.75, 5))),
    "V": (("poly", (0, 0), (1.1, 0), (2.5, 3.9), (3.9, 0), (5, 0), (3.1, 5), (1.9, 5)),),
    "K": (("bar", 0, 0, 1, 5), ("poly", (3.6, 0), (5, 0), (1, 3.2), (1, 2.0)),
          ("poly", (2.0, 2.2), (3.0, 1.6), (5, 5), (3.6, 5))),
    "O": (("ring", 0, 0, 5, 5),),
    "C": (("ring", 0, 0, 5, 5, 40, 320),),
    "D": (("bar", 0, 0, 1, 5), ("bar", 0, 0, 2.5, 1), ("bar", 0, 4, 2.5, 5),
          ("ring", 0, 0, 5, 5, 270, 90), ("bar", 4, 2, 5, 3)),
    "R": (("bar", 0, 0, 1, 5), ("bar", 0, 0, 3.5, 1), ("bar", 0, 2, 3.5, 3),
          ("ring", 2, 0, 5, 3, 270, 90), ("poly", (2.4, 3), (3.6, 3), (5, 5), (3.8, 5))),
    "S": (("ring", 0, 0, 5, 3, 90, 360), ("ring", 0, 2, 5, 5, 270, 180),
          ("bar", 1.5, 2, 3.5, 3)),
}


def _sloan_strokes(letter) -> tuple:
    """The strokes of ``letter`` (:data:`SLOAN_STROKES`); ValueError if it is none of the
    ten."""
    for name, strokes in SLOAN_STROKES.items():
        if letter == name:
            return strokes
    raise ValueError(f"not a Sloan letter: {letter!r}")


def sloan_letter(letter: str, px: int = 200) -> np.ndarray:
    """A Sloan-style letter (True = ink) on a px x px image whose edges are the letter's
    5 x 5 stroke box: strokes one fifth of the height wide, every letter touching all four
    sides of the box (as Sloan's do), drawn with PIL at ``px`` pixels (anti-aliasing off:
    an exact bilevel glyph). Letter shapes: bars, diagonals and rings of the 5 x 5 grid
    (Sloan 1959's design grid, :data:`SLOAN_STROKES`); the curves are circular arcs."""
    from PIL import Image, ImageDraw

    strokes = _sloan_strokes(letter)
    u = px / 5.0
    img = Image.new("1", (px, px), 0)
    d = ImageDraw.Draw(img)

    def bar(x0, y0, x1, y1):
        d.rectangle([x0 * u, y0 * u, x1 * u - 1, y1 * u - 1], fill=1)

    def poly(*pts):
        d.polygon([(x * u, y * u) for x, y in pts], fill=1)

    def ring(x0, y0, x1, y1, start=0, end=360):
        d.arc([x0 * u, y0 * u, x1 * u - 1, y1 * u - 1], start, end, fill=1, width=int(u))

    draw = {"bar": bar, "poly": poly, "ring": ring}
    for shape, *args in strokes:
        draw[shape](*args)
    return np.asarray(img, bool)


def etdrs_layout(distance_m: float, rows=ETDRS_ROWS, seed: int = 0) -> list:
    """The letters of an ETDRS chart at ``distance_m``: [(letter, logMAR, x, y, size)] in
    metres (centre of each letter box, on the chart plane; y up from the chart's centre).
    Letter height 5 MAR (MAR = 10^logMAR arcmin) at the chart distance, 5 letters per row,
    one letter width between letters, the gap below a row the next row's letter height
    (Ferris et al. 1982)."""
    rng = np.random.default_rng(seed)
    sizes = [distance_m * math.tan(math.radians(5 * 10 ** lm / 60.0)) for lm in rows]
    gaps = [sizes[i + 1] if i + 1 < len(sizes) else sizes[i] for i in range(len(sizes))]
    total = sum(sizes) + sum(gaps[:-1])
    y = total / 2
    out = []
    for lm, size, gap in zip(rows, sizes, gaps, strict=True):
        letters = rng.choice(list(SLOAN), 5, replace=False)
        for k, letter in enumerate(letters):
            out.append((str(letter), float(lm), (k - 2) * 2 * size, y - size / 2, size))
        y -= size + gap
    return out


#: Pixels per letter of the glyph atlas, and the white margin around each glyph.
GLYPH_PX = 200
GLYPH_PAD = 8


def chart_scene(distance_m: float = 6.0, *, contrast: float = 1.0, seed: int = 0,
                rows=ETDRS_ROWS) -> Scene:
    """An ETDRS chart centred on the line of sight at ``distance_m``: each letter a quad of
    exactly its angular size (:func:`etdrs_layout`), textured from one atlas of the ten
    Sloan letters (:data:`GLYPH_PX` texels per letter height), in front of a white board
    (1e-4 of the distance behind the letters, so the letters' size is exact); one mesh per
    row, so that a renderer filters each row's texture for its own size. ``contrast``:
    Weber contrast of the letters (1: black; 0.1: a 10 % low-contrast chart), in linear
    light."""
    from eyelab.core.color import encode_srgb

    ink = int(encode_srgb(np.array([1.0 - float(contrast)]))[0]) if contrast < 1 else 0
    cell = GLYPH_PX + 2 * GLYPH_PAD
    atlas = np.full((cell, cell * len(SLOAN), 3), 255, np.uint8)
    for j, letter in enumerate(SLOAN):
        glyph = sloan_letter(letter, GLYPH_PX)
        view = atlas[GLYPH_PAD:GLYPH_PAD + GLYPH_PX,
                     j * cell + GLYPH_PAD:j * cell + GLYPH_PAD + GLYPH_PX]
        view[glyph] = ink
    layout = etdrs_layout(distance_m, rows, seed)
    rows_meshes, every = [], []
    for r in range(0, len(layout), 5):    # one mesh per row: one texel density each
        verts, faces, uvs = [], [], []
        for n, (letter, _lm, x, y, s) in enumerate(layout[r:r + 5]):
            j = SLOAN.index(letter)
            u0 = (j * cell + GLYPH_PAD) / atlas.shape[1]
            u1 = (j * cell + GLYPH_PAD + GLYPH_PX) / atlas.shape[1]
            v0, v1 = GLYPH_PAD / cell, (GLYPH_PAD + GLYPH_PX) / cell
            verts += [(x - s / 2, y - s / 2, -distance_m), (x + s / 2, y - s / 2, -distance_m),
                      (x + s / 2, y + s / 2, -distance_m), (x - s / 2, y + s / 2, -distance_m)]
            uvs += [(u0, 1 - v1), (u1, 1 - v1), (u1, 1 - v0), (u0, 1 - v0)]
            faces += [(4 * n, 4 * n + 1, 4 * n + 2), (4 * n, 4 * n + 2, 4 * n + 3)]
        rows_meshes.append(SceneMesh(f"chart_row_{layout[r][1]:+.1f}", np.array(verts),
                                     np.array(faces), texture=atlas, uv=np.array(uvs)))
        every += verts
    xs, ys = np.array(every)[:, 0], np.array(every)[:, 1]
    margin = layout[0][4]
    board = grid_quad("chart_board", (0, (ys.max() + ys.min()) / 2, -distance_m * (1 + 1e-4)),
                      (1, 0, 0), (0, 1, 0), xs.max() - xs.min() + 2 * margin,
                      ys.max() - ys.min() + 2 * margin, nu=8, nv=8,
                      colors=np.array([255, 255, 255], np.uint8))
    return Scene([board, *rows_meshes], name=f"chart_{distance_m:g}m")


def text_texture(w_px=512, h_px=700, seed=1):
    """A page of dark 'word' blocks on light paper."""
    rng = np.random.default_rng(seed)
    img = np.full((h_px, w_px, 3), 245, np.uint8)
    line_h = 12
    for y in range(30, h_px - 30, 2 * line_h):
        x = 30
        while x < w_px - 60:
            wl = int(rng.integers(12, 60))
            img[y:y + line_h - 3, x:x + wl] = 30
            x += wl + 8
    return img


def page_scene(distance_m: float = 0.4, *, below_deg: float = 20.0) -> Scene:
    """An A5-ish page (0.15 x 0.2 m) at ``distance_m``, ``below_deg`` below straight ahead,
    facing the eye."""
    a = math.radians(below_deg)
    centre = np.array([0.0, -math.sin(a), -math.cos(a)]) * distance_m
    normal = -centre / distance_m
    up = np.cross(normal, (1.0, 0.0, 0.0))
    up = -up / np.linalg.norm(up) if up[1] < 0 else up / np.linalg.norm(up)
    right = np.cross(up, normal)
    quad = grid_quad("page", centre, right, up, 0.15, 0.20, texture=text_texture())
    return Scene([quad], name="page")


def tilted_page_scene(near_m: float = 0.061, far_m: float = 0.107) -> Scene:
    """A page whose corners span near_m..far_m from the eye (Kakimoto Fig. 12)."""
    w, h = 0.06, 0.045
    p0 = np.array([-w / 2, -h / 2, -near_m])
    p1 = np.array([w / 2, h / 2, -far_m])
    centre = 0.5 * (p0 + p1)
    right = np.array([w, 0.0, -(far_m - near_m) / 2])
    right /= np.linalg.norm(right)
    up = np.array([0.0, h, -(far_m - near_m) / 2])
    up -= right * (up @ right)
    up /= np.linalg.norm(up)
    quad = grid_quad("tilted_page", centre, right, up, float(np.linalg.norm(p1 - p0) * 0.8),
                     float(np.linalg.norm(p1 - p0) * 0.6), nu=24, nv=24,
                     texture=text_texture(400, 300))
    return Scene([quad], name="tilted_page")


def checker_texture(n=16, px=16, dark=40, light=220):
    c = (np.add.outer(np.arange(n), np.arange(n)) % 2).astype(bool)
    img = np.where(np.kron(c, np.ones((px, px), bool))[..., None], light, dark)
    return np.repeat(img, 3, axis=2).astype(np.uint8)


def depth_ramp_scene(near_m=0.3, far_m=10.0, height_m=-0.4) -> Scene:
    length = far_m - near_m
    quad = grid_quad("floor", (0, height_m, -(near_m + far_m) / 2), (1, 0, 0), (0, 0, -1),
                     2.0, length, nu=16, nv=64, texture=checker_texture(16, 16))
    return Scene([quad], name="depth_ramp")


def box(name, centre, size, color):
    import trimesh

    b = trimesh.creation.box(extents=size)
    return SceneMesh(name, b.vertices + np.asarray(centre, float), b.faces,
                     colors=np.asarray(color, np.uint8))


def room_scene() -> Scene:
    """Floor, a chart on the back wall at 6 m, boxes from 0.3 to 4 m, a page at 0.4 m."""
    meshes = [
        grid_quad("floor", (0, -1.2, -3.2), (1, 0, 0), (0, 0, -1), 4.0, 6.4, nu=16, nv=48,
                  texture=checker_texture(8, 16, 90, 200)),
        grid_quad("wall", (0, 0.0, -6.4), (1, 0, 0), (0, 1, 0), 4.0, 2.4, nu=16, nv=12,
                  colors=np.array([225, 220, 205], np.uint8)),
        *chart_scene(6.0).meshes,
        box("box_near", (0.25, -0.35, -0.6), (0.12, 0.12, 0.12), (200, 40, 40)),
        box("box_mid", (-0.5, -0.6, -1.5), (0.3, 0.3, 0.3), (40, 90, 200)),
        box("box_far", (0.8, -0.8, -4.0), (0.6, 0.6, 0.6), (40, 160, 60)),
    ]
    page = page_scene(0.4, below_deg=30.0).meshes[0]
    meshes.append(page)
    return Scene(meshes, background=(235, 240, 250), name="room")


def dot_scene(distance_m: float, size_m: float) -> Scene:
    """A white square of side ``size_m`` on a black background, centred at ``distance_m``."""
    quad = grid_quad("dot", (0, 0, -distance_m), (1, 0, 0), (0, 1, 0), size_m, size_m,
                     nu=1, nv=1, colors=np.array([255, 255, 255], np.uint8))
    return Scene([quad], background=(0, 0, 0), name="dot")


SCENES = {"room": room_scene, "chart": chart_scene, "page": page_scene,
          "tilted_page": tilted_page_scene, "depth_ramp": depth_ramp_scene}
#: The built-in scenes' names, which ``[render] scene`` and :func:`eyelab.builtin_scene`
#: take.
#:
#: Examples
#: --------
#: >>> import eyelab
#: >>> eyelab.SCENE_NAMES
#: ('room', 'chart', 'page', 'tilted_page', 'depth_ramp')
SCENE_NAMES = tuple(SCENES)
