"""Procedural scenes with known geometry (world frame of eyelab: eye at the origin looking
along -z, x right, y up, metres).

* :func:`chart_scene` — a tumbling-E acuity chart (ETDRS layout: 5 letters per row, rows
  0.1 logMAR apart, letter height 5 MAR, spacing one letter width, row gap the next row's
  height) at a chosen distance, letters of the correct angular size;
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


ETDRS_ROWS = tuple(np.round(np.arange(1.0, -0.31, -0.1), 1))


def chart_texture(distance_m: float, rows=ETDRS_ROWS, px_per_mm: float = 1.0, seed: int = 0):
    """Chart image (uint8 RGB, black on white) and its physical size (w, h) in metres."""
    rng = np.random.default_rng(seed)
    mm = [distance_m * 1e3 * math.tan(math.radians(5 * 10 ** lm / 60.0)) for lm in rows]
    width_mm = 10 * mm[0]
    height_mm = sum(mm) * 2 + mm[0]
    w = int(math.ceil(width_mm * px_per_mm))
    h = int(math.ceil(height_mm * px_per_mm))
    img = np.full((h, w, 3), 255, np.uint8)
    y = int(mm[0] * 0.5 * px_per_mm)
    for size in mm:
        s = max(5, int(round(size * px_per_mm / 5)) * 5)
        row_w = 9 * s
        x = (w - row_w) // 2
        for _ in range(5):
            e = tumbling_e(s, int(rng.integers(4)))
            img[y:y + s, x:x + s][e] = 0
            x += 2 * s
        y += 2 * s
        if y + s > h:
            break
    return img, (w / px_per_mm / 1e3, h / px_per_mm / 1e3)


def chart_scene(distance_m: float = 6.0, *, px_per_mm: float | None = None) -> Scene:
    """An acuity chart centred on the line of sight at ``distance_m``."""
    ppm = px_per_mm or max(0.2, 12.0 / distance_m)
    img, (w, h) = chart_texture(distance_m, px_per_mm=ppm)
    quad = grid_quad("chart", (0, 0, -distance_m), (1, 0, 0), (0, 1, 0), w, h, texture=img)
    return Scene([quad], name=f"chart_{distance_m:g}m")


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
    img, (w, h) = chart_texture(6.0, px_per_mm=2.0)
    meshes = [
        grid_quad("floor", (0, -1.2, -3.2), (1, 0, 0), (0, 0, -1), 4.0, 6.4, nu=16, nv=48,
                  texture=checker_texture(8, 16, 90, 200)),
        grid_quad("wall", (0, 0.0, -6.4), (1, 0, 0), (0, 1, 0), 4.0, 2.4, nu=16, nv=12,
                  colors=np.array([225, 220, 205], np.uint8)),
        grid_quad("chart", (0, 0.0, -6.0), (1, 0, 0), (0, 1, 0), w, h, nu=12, nv=12,
                  texture=img),
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
SCENE_NAMES = tuple(SCENES)
