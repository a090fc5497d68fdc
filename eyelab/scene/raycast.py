"""Ray casting against a scene: embree (embreex) fast path and a pure-numpy twin.

Both return, per ray: hit distance (inf on a miss), mesh index, triangle index and the
barycentric (u, v); the numpy twin exists to test the embree path (parity test).
"""

from __future__ import annotations

import numpy as np

from eyelab.core.cache import LRUCache
from eyelab.scene.scene import Scene


class Hits:
    def __init__(self, t, mesh, tri, uv):
        self.t, self.mesh, self.tri, self.uv = t, mesh, tri, uv

    @property
    def hit(self):
        return np.isfinite(self.t)

    def linear_colors(self, scene: Scene):
        """(n, 3) linear-light colours at the hits (:meth:`SceneMesh.linear_color_at`); the
        background's on misses."""
        from eyelab.core.color import srgb_to_linear

        bg = srgb_to_linear(np.asarray(scene.background, float) / 255.0)
        out = np.broadcast_to(bg, (len(self.t), 3)).copy()
        for k, m in enumerate(scene.meshes):
            sel = self.hit & (self.mesh == k)
            if sel.any():
                out[sel] = m.linear_color_at(self.tri[sel], self.uv[sel])
        return out

    def colors(self, scene: Scene):
        """(n, 3) float colours at the hits; the background colour on misses."""
        out = np.broadcast_to(np.asarray(scene.background, float), (len(self.t), 3)).copy()
        for k, m in enumerate(scene.meshes):
            sel = self.hit & (self.mesh == k)
            if sel.any():
                out[sel] = m.color_at(self.tri[sel], self.uv[sel])
        return out


class EmbreeIntersector:
    """Embree scene of all meshes (float32 geometry, as embree requires)."""

    def __init__(self, scene: Scene):
        from eyelab.core.interrupt import deferred

        with deferred():        # native module initialisation: not to be interrupted
            from embreex import mesh_construction, rtcore_scene

        self._scene = rtcore_scene.EmbreeScene()
        self._meshes = []
        for m in scene.meshes:
            self._meshes.append(mesh_construction.TriangleMesh(
                self._scene, m.vertices.astype(np.float32), m.faces.astype(np.int32)))

    def intersect(self, origins, directions) -> Hits:
        """Nearest hits of rays (n, 3) (directions unit); float32 inside embree, so callers
        offset secondary rays' origins by a scale-aware epsilon."""
        o = np.ascontiguousarray(origins, dtype=np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        r = self._scene.run(o, d, output=1)
        hit = r["geomID"] >= 0
        t = np.where(hit, r["tfar"].astype(float), np.inf)
        uv = np.stack([r["u"], r["v"]], 1).astype(float)
        return Hits(t, np.where(hit, r["geomID"], -1), np.where(hit, r["primID"], -1), uv)


#: The embree scenes of the scenes last asked for (:func:`scene_intersector`).
_SHARED = LRUCache(4, "embree scenes")


def scene_intersector(scene: Scene) -> EmbreeIntersector:
    """``scene``'s :class:`EmbreeIntersector`, built once per scene content (the last 4
    kept) and shared — between threads too: it is committed (one ray cast) before it is
    handed out, and a committed embree scene answers concurrent queries. Building one
    costs ~4 ms for the built-in room, and a frame's set-up asked for three."""

    def build():
        inter = EmbreeIntersector(scene)
        inter.intersect(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]))      # commit
        return inter

    return _SHARED.get_or_create(scene.content_key, build)[0]


class NumpyIntersector:
    """Brute-force Moeller-Trumbore over all triangles (float64), for tests and tiny scenes."""

    def __init__(self, scene: Scene):
        self._tris = [(m.vertices[m.faces[:, 0]], m.vertices[m.faces[:, 1]],
                       m.vertices[m.faces[:, 2]]) for m in scene.meshes]

    def intersect(self, origins, directions, *, t_min: float = 0.0, chunk: int = 4096
                  ) -> Hits:
        o = np.asarray(origins, float)
        d = np.asarray(directions, float)
        n = len(o)
        best_t = np.full(n, np.inf)
        best_m = np.full(n, -1)
        best_f = np.full(n, -1)
        best_uv = np.zeros((n, 2))
        for k, (a, b, c) in enumerate(self._tris):
            e1, e2 = b - a, c - a
            for s in range(0, len(a), chunk):
                sl = slice(s, s + chunk)
                p = np.cross(d[:, None], e2[None, sl])
                det = np.einsum("nti,ti->nt", p, e1[sl])
                with np.errstate(divide="ignore", invalid="ignore"):
                    inv = 1.0 / det
                    tv = o[:, None] - a[None, sl]
                    u = np.einsum("nti,nti->nt", tv, p) * inv
                    q = np.cross(tv, e1[None, sl])
                    v = np.einsum("ni,nti->nt", d, q) * inv
                    t = np.einsum("nti,ti->nt", q, e2[sl]) * inv
                    # rays parallel to a triangle (det = 0) give inf/nan here; masked next
                    ok = (np.abs(det) > 1e-18) & (u >= 0) & (v >= 0) & (u + v <= 1) \
                        & (t > t_min)
                t = np.where(ok, t, np.inf)
                j = np.argmin(t, axis=1)
                tj = t[np.arange(n), j]
                better = tj < best_t
                best_t[better] = tj[better]
                best_m[better] = k
                best_f[better] = s + j[better]
                best_uv[better] = np.stack([u[np.arange(n), j], v[np.arange(n), j]], 1)[better]
        return Hits(best_t, best_m, best_f, best_uv)


def _mesh_in_view(mesh, camera) -> bool:
    """Whether any of ``mesh``'s triangles may show in ``camera``'s view: a vertex inside
    the view volume, or a triangle whose box in NDC overlaps the view's (between the near
    and far planes: triangles larger than the view, or small ones between the probe rays,
    count). Triangles crossing the camera's plane count when they reach the depth
    range."""
    v = np.asarray(mesh.vertices, float)
    f = np.asarray(mesh.faces)
    if len(v) == 0 or len(f) == 0:
        return False
    b = camera.basis
    rel = v - np.asarray(camera.position, float)
    w = rel @ np.asarray(b[2], float)
    tx, ty = camera.tan_half
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (rel @ np.asarray(b[0], float)) / (w * tx)
        y = (rel @ np.asarray(b[1], float)) / (w * ty)
    wt = w[f]
    in_depth = (wt.max(1) >= camera.near) & (wt.min(1) <= camera.far)
    front = (wt > 0).all(1)
    xt, yt = x[f], y[f]
    overlap = front & (xt.max(1) >= -1) & (xt.min(1) <= 1) & (yt.max(1) >= -1) & \
        (yt.min(1) <= 1)
    return bool((in_depth & (overlap | ~front & (wt.max(1) > 0))).any())


def scene_warnings(scene: Scene, camera, intersector=None) -> list:
    """What a user would want to know before trusting the image (strings, empty when all
    is well): the eye inside a mesh (most of 26 rays from the camera's centre of
    projection in every direction hit a triangle from behind: a room model around the
    eye, or a model centred on the origin), or nothing in view (none of a 32 x 24 grid of
    rays through the view meets a mesh between the near and far planes, and no triangle's
    box falls in the view volume: the image is the background; small objects between
    the probe rays are in view). ``camera``: :class:`eyelab.optics.rays.camera.Camera`."""
    inter = intersector or scene_intersector(scene)
    o = np.asarray(camera.position, float)
    g = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)
                  if (x, y, z) != (0, 0, 0)], float)
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    hits = inter.intersect(np.broadcast_to(o, g.shape), g)
    inside = []
    for k, m in enumerate(scene.meshes):
        sel = hits.hit & (hits.mesh == k)
        if not sel.any():
            continue
        f = m.faces[hits.tri[sel]]
        v = m.vertices
        nrm = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        back = int((np.einsum("ij,ij->i", nrm, g[sel]) > 0).sum())
        if back >= 0.75 * len(g):
            inside.append(m.name)
    out = [f"the eye is inside mesh {name!r} ({len(g)} rays from the pupil meet it from "
           "behind): place the scene with [render] scene = {path, position_m, ...}"
           for name in inside]
    x, y = np.meshgrid(np.linspace(-1, 1, 32), np.linspace(-1, 1, 24))
    d = camera.ray_directions(x.ravel(), y.ravel())
    h = inter.intersect(np.broadcast_to(o, d.shape), d)
    depth = h.t * (d @ np.asarray(camera.basis[2], float))
    if not (h.hit & (depth >= camera.near) & (depth <= camera.far)).any() \
            and not any(_mesh_in_view(m, camera) for m in scene.meshes):
        out.append(f"nothing in view: no mesh between near_m {camera.near:g} and far_m "
                   f"{camera.far:g} m in the view (the image is the background)")
    return out
