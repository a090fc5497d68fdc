"""Scene meshes: triangles with per-vertex colours or a texture, in world metres.

Colours are sRGB-encoded uint8, shown unlit (the raster and the reference renderers use
the same unlit shading, so that their differences measure optics, not lighting). A mesh
that should look lit carries its lighting in its colours: :meth:`SceneMesh.shaded` bakes
Lambertian shading into them (:mod:`eyelab.scene.shading`), as a mesh file's parts
without colours get by default (``[render] scene`` ``shading``).
"""

from __future__ import annotations

import gc
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.checks import check_choice
from eyelab.core.color import decode_srgb
from eyelab.core.errors import SpecError
from eyelab.scene.shading import SHADINGS, shade


@dataclass
class SceneMesh:
    """vertices (n, 3) float m; faces (m, 3) int; colors (n, 3) uint8 or None;
    texture (h, w, 3) uint8 or None with uv (n, 2) in [0, 1] (v = 0 at the image's bottom
    row, the OpenGL convention: texture row 0 is the top of the image).

    The arrays are private read-only copies, so a mesh cannot change behind a renderer's
    back: edit one by assigning new arrays (or :meth:`transformed`), which renews
    :attr:`content_key`, the digest that every cache depending on the mesh is keyed by.

    ``plain``: made with neither colours nor texture (its colours are then
    :data:`PLAIN_GREY`): what ``shading = "auto"`` shades.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray | None = None
    texture: np.ndarray | None = None
    uv: np.ndarray | None = None
    plain: bool = field(default=False, init=False, repr=False, compare=False)

    def __post_init__(self):
        self.vertices = np.ascontiguousarray(self.vertices, dtype=float)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int64)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise SpecError(f"scene.{self.name}.vertices", "must be (n, 3)")
        if self.faces.ndim != 2 or self.faces.shape[1] != 3 or (
                len(self.faces) and (self.faces.min() < 0 or
                                     self.faces.max() >= len(self.vertices))):
            raise SpecError(f"scene.{self.name}.faces", "must be (m, 3) indices into vertices")
        if self.texture is not None:
            if self.uv is None or len(self.uv) != len(self.vertices):
                raise SpecError(f"scene.{self.name}.uv", "a textured mesh needs (n, 2) uv")
            self.texture = np.ascontiguousarray(self.texture[..., :3], dtype=np.uint8)
            self.uv = np.ascontiguousarray(self.uv, dtype=float)
        elif self.colors is None:
            self.plain = True
            self.colors = np.full((len(self.vertices), 3), PLAIN_GREY, np.uint8)
        if self.colors is not None:
            self.colors = np.ascontiguousarray(
                np.broadcast_to(self.colors, (len(self.vertices), 3)), dtype=np.uint8)

    _ARRAYS = ("vertices", "faces", "colors", "texture", "uv")

    def __setattr__(self, name, value):
        if name in self._ARRAYS and value is not None:
            value = np.array(value, copy=True)
            value.flags.writeable = False
        if name in self._ARRAYS or name == "name":
            self.__dict__.pop("_key", None)
            self.__dict__.pop("_tex_key", None)
            self.__dict__.pop("_linear_tex", None)
        super().__setattr__(name, value)

    @property
    def content_key(self) -> str:
        """Digest (hex) of the name and every array: equal keys, equal meshes."""
        key = self.__dict__.get("_key")
        if key is None:
            from eyelab.core.cache import array_digest

            parts = [self.name] + [
                self.texture_key or "-" if a == "texture" else
                "-" if getattr(self, a) is None else array_digest(getattr(self, a))
                for a in self._ARRAYS]
            key = array_digest(np.frombuffer("|".join(parts).encode(), np.uint8))
            self.__dict__["_key"] = key
        return key

    @property
    def texture_key(self) -> str | None:
        """Digest (hex) of the texture's texels alone, None without one: what a texture made
        from them (a prefiltered one) is keyed by, shared by meshes that differ only in
        geometry (a refined mesh). Computed once, with :attr:`content_key`."""
        if self.texture is None:
            return None
        key = self.__dict__.get("_tex_key")
        if key is None:
            from eyelab.core.cache import array_digest

            key = self.__dict__["_tex_key"] = array_digest(self.texture)
        return key

    def transformed(self, matrix) -> SceneMesh:
        """A copy moved by the (4, 4) homogeneous ``matrix`` (metres)."""
        m = np.asarray(matrix, float)
        v = self.vertices @ m[:3, :3].T + m[:3, 3]
        return SceneMesh(self.name, v, self.faces, None if self.plain else self.colors,
                         self.texture, self.uv)

    def shaded(self) -> SceneMesh:
        """A copy with Lambertian shading baked into its colours, in linear light
        (:func:`eyelab.scene.shading.shade`: its colours the albedo, vertices split at
        creases and edges where the normals turn fast); a textured mesh as it is (a texture
        has no per-vertex radiance to scale)."""
        if self.texture is not None:
            return self
        v, f, c, _ = shade(self.vertices, self.faces, self.colors)
        return SceneMesh(self.name, v, f, c)

    @property
    def n_triangles(self):
        return len(self.faces)

    def color_at(self, face_ids, bary_uv):
        """Colours (k, 3) float in [0, 255] at points given by triangle ids and barycentric
        (u, v) (weights 1-u-v, u, v of the triangle's vertices 0, 1, 2): bilinear texture
        look-up (clamped) or interpolated vertex colours, as the rasteriser shades them."""
        f = self.faces[face_ids]
        u, v = bary_uv[:, 0:1], bary_uv[:, 1:2]
        w0 = 1.0 - u - v
        if self.texture is not None:
            uv = w0 * self.uv[f[:, 0]] + u * self.uv[f[:, 1]] + v * self.uv[f[:, 2]]
            return sample_texture(self.texture, uv)
        c = self.colors
        return w0 * c[f[:, 0]] + u * c[f[:, 1]] + v * c[f[:, 2]]

    def linear_color_at(self, face_ids, bary_uv):
        """Linear-light colours (k, 3) float in [0, 1] at points given by triangle ids and
        barycentric (u, v): texels decoded to linear light, then filtered bilinearly (as the
        raster renderer's sRGB textures are); vertex colours decoded, then interpolated."""
        f = self.faces[face_ids]
        u, v = bary_uv[:, 0:1], bary_uv[:, 1:2]
        w0 = 1.0 - u - v
        if self.texture is not None:
            uv = w0 * self.uv[f[:, 0]] + u * self.uv[f[:, 1]] + v * self.uv[f[:, 2]]
            return sample_texture(self._linear_texture(), uv)
        c = decode_srgb(self.colors)
        return w0 * c[f[:, 0]] + u * c[f[:, 1]] + v * c[f[:, 2]]

    def _linear_texture(self):
        tex = self.__dict__.get("_linear_tex")
        if tex is None:
            tex = decode_srgb(self.texture)
            self.__dict__["_linear_tex"] = tex
        return tex

    def bounds(self):
        return self.vertices.min(0), self.vertices.max(0)


def sample_texture(tex, uv):
    """Bilinear sample of an (h, w, 3) texture (uint8 or float) at uv (k, 2) (texel centres
    at (i + 0.5)/w, clamped to the edge, v = 0 at the bottom row) -> (k, 3) float."""
    h, w = tex.shape[:2]
    x = np.clip(uv[:, 0] * w - 0.5, 0, w - 1)
    y = np.clip((1.0 - uv[:, 1]) * h - 0.5, 0, h - 1)
    x0 = np.minimum(np.floor(x).astype(int), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(int), max(h - 2, 0))
    tx = (x - x0)[:, None]
    ty = (y - y0)[:, None]
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    # gather the four texels first (converting the whole texture per call is the slow way)
    return ((1 - ty) * ((1 - tx) * tex[y0, x0] + tx * tex[y0, x1])
            + ty * ((1 - tx) * tex[y1, x0] + tx * tex[y1, x1]))


def apply_shading(meshes, shading: str = "auto") -> list:
    """``meshes`` lit as ``shading`` says (:data:`~eyelab.scene.shading.SHADINGS`):
    "auto" shades the plain ones (:attr:`SceneMesh.plain`), "lambert" every one not
    textured, "none" none (see :meth:`SceneMesh.shaded`)."""
    check_choice("render.scene.shading", shading, SHADINGS)
    return [m.shaded() if shading == "lambert" or (shading == "auto" and m.plain) else m
            for m in meshes]


@dataclass
class Scene:
    """A list of meshes plus a background colour (sRGB uint8).

    ``meshes``: :class:`SceneMesh` objects, their vertices in metres in eyelab's frame (the
    eye's pupil at the origin, looking along -z, y up); ``background``: the (r, g, b) seen
    where no mesh is; ``name``: what reports call it. :func:`eyelab.builtin_scene` makes
    the built-in scenes; a spec's ``[render] scene`` names one of them or a mesh file; a
    renderer made by :func:`eyelab.make_renderer` renders a Scene.

    Examples
    --------
    >>> import eyelab
    >>> room = eyelab.builtin_scene("room")
    >>> room.name, len(room.meshes), room.n_triangles
    ('room', 21, 2736)
    >>> lo, hi = room.bounds()                 # (x, y, z) m: all in front of the eye
    >>> lo.tolist(), hi.tolist()
    ([-2.0, -1.2, -6.4], [2.0, 1.2, 0.0])
    >>> boxes = eyelab.Scene([m for m in room.meshes if m.name.startswith("box")],
    ...                      background=(0, 0, 0), name="boxes")
    >>> boxes.n_triangles
    36
    """

    meshes: list = field(default_factory=list)
    background: tuple = (255, 255, 255)
    name: str = "scene"

    @property
    def n_triangles(self):
        return sum(m.n_triangles for m in self.meshes)

    @property
    def content_key(self) -> str:
        """Digest of the meshes' keys (in order), the background and the name."""
        from eyelab.core.cache import content_key

        return content_key(meshes=[m.content_key for m in self.meshes],
                           background=list(self.background), name=self.name)

    @property
    def n_vertices(self):
        return sum(len(m.vertices) for m in self.meshes)

    def bounds(self):
        lo = np.min([m.bounds()[0] for m in self.meshes], axis=0)
        hi = np.max([m.bounds()[1] for m in self.meshes], axis=0)
        return lo, hi


#: A mesh file of at least this many triangles is followed by a garbage collection (the
#: loader's own copies freed before the render starts).
COLLECT_AFTER_TRIANGLES = 1 << 18

#: Length units a mesh file may be written in -> metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 1e-3, "in": 0.0254}
#: The sRGB grey of a mesh made without colours or texture (its albedo when shaded: linear
#: 0.58).
PLAIN_GREY = 200


@dataclass(frozen=True)
class SceneSource:
    """What ``[render] scene`` names: a built-in scene or a mesh file, and where it goes.

    name : a built-in scene's name or a mesh file path; units : the file's length unit
    ("m", "cm", "mm", "in"); scale : a further factor; rotation_deg : (x, y, z) rotations in
    degrees, applied about the world axes in that order (x first); position_m : where the
    file's origin goes (m, eyelab's frame: the pupil at the origin, looking along -z, y
    up); background : sRGB (r, g, b) of what no mesh covers (None: the built-in scene's
    own, white for a mesh file); chart_distance_m / chart_contrast : the built-in chart's
    distance (m, default 6) and Weber contrast (default 1); shading : how the meshes are lit
    (:func:`apply_shading`: "auto", "lambert" or "none"), once placed.

    A vertex v of the file goes to ``R_z R_y R_x (units * scale * v) + position_m``.
    """

    name: str
    position_m: tuple = (0.0, 0.0, 0.0)
    scale: float = 1.0
    rotation_deg: tuple = (0.0, 0.0, 0.0)
    units: str = "m"
    background: tuple | None = None
    chart_distance_m: float | None = None
    chart_contrast: float | None = None
    shading: str = "auto"

    def __str__(self):
        return self.name

    @property
    def placed(self) -> bool:
        return (tuple(self.position_m) != (0.0, 0.0, 0.0) or self.scale != 1.0
                or tuple(self.rotation_deg) != (0.0, 0.0, 0.0) or self.units != "m")

    def matrix(self) -> np.ndarray:
        """(4, 4) homogeneous transform from the file's coordinates to eyelab's (m)."""
        rx, ry, rz = np.radians(np.asarray(self.rotation_deg, float))
        cx, sx, cy, sy, cz, sz = (np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry),
                                  np.cos(rz), np.sin(rz))
        r_x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        r_y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        r_z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = r_z @ r_y @ r_x * (UNITS[self.units] * self.scale)
        m[:3, 3] = self.position_m
        return m


def load_mesh(path, *, name=None, transform=None) -> SceneMesh:
    """One :class:`SceneMesh` from a mesh file (all of its parts in one): see
    :func:`load_meshes`, which keeps a multi-part file's parts (and their textures)
    apart."""
    parts = load_meshes(path, transform=transform)
    if len(parts) == 1:
        return parts[0] if name is None else SceneMesh(name, *_arrays(parts[0]))
    if any(p.texture is not None for p in parts):
        raise SpecError("render.scene", f"{str(path)!r} has several textured parts: load "
                                        "it with load_meshes")
    offs = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    return SceneMesh(name or str(path), np.concatenate([p.vertices for p in parts]),
                     np.concatenate([p.faces + o for p, o in zip(parts, offs, strict=True)]),
                     np.concatenate([p.colors for p in parts]))


def _arrays(m):
    return m.vertices, m.faces, m.colors, m.texture, m.uv


def load_meshes(path, *, transform=None, shading: str = "auto") -> list:
    """Every part of a mesh file trimesh reads (OBJ+MTL, PLY, STL, GLB/glTF, ...) as
    :class:`SceneMesh` es, with its look: a texture with its uv (a simple material's
    image or a PBR base-colour texture), per-vertex colours, per-face colours (kept flat:
    each face gets its own vertices), a PBR base-colour factor, or grey (a plain part).
    ``transform``: (4, 4) applied to every part (after the file's own node transforms);
    ``shading``: how the placed parts are lit (:func:`apply_shading`; by default the plain
    ones are shaded).

    Unreadable, empty, point-cloud or non-finite meshes are a :class:`SpecError` naming
    ``render.scene``; zero-area triangles are dropped (all of them: an error)."""
    import trimesh

    try:
        loaded = trimesh.load(path, process=False)
    except Exception as e:  # trimesh raises many types for unreadable files
        raise SpecError("render.scene", f"cannot read {str(path)!r} as a mesh: {e}") from None
    if isinstance(loaded, trimesh.Scene):
        geoms = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
    else:
        geoms = [loaded] if isinstance(loaded, trimesh.Trimesh) else []
    geoms = [g for g in geoms if len(g.faces)]
    if not geoms:
        raise SpecError("render.scene", f"{str(path)!r} has no triangles (an empty file, a "
                                        "point cloud or lines only)")
    _check_coordinates(geoms, path)
    if transform is not None:
        for g in geoms:
            g.apply_transform(np.asarray(transform, float))
    parts = _parts(geoms, path)
    if sum(len(p.faces) for p in parts) >= COLLECT_AFTER_TRIANGLES:
        # trimesh's geometry holds reference cycles: free it now, not at the next
        # collection (measured: 0.4 GiB still held after an 8 M-triangle file)
        del loaded, geoms
        gc.collect()
    if not parts:
        raise SpecError("render.scene", f"{str(path)!r}: every triangle is degenerate "
                                        "(zero area)")
    return apply_shading(parts, shading)


def _parts(geoms, path) -> list:
    """The :class:`SceneMesh` of each trimesh geometry with a face of non-zero area (its
    zero-area faces dropped), named ``path`` (one geometry) or ``path#k``."""
    parts = []
    lo = np.min([np.asarray(g.vertices).min(axis=0) for g in geoms], axis=0)
    hi = np.max([np.asarray(g.vertices).max(axis=0) for g in geoms], axis=0)
    extent = max(float((hi - lo).max()), 1e-300)
    for k, g in enumerate(geoms):
        keep = _nondegenerate(np.asarray(g.vertices, float), np.asarray(g.faces),
                              1e-12 * extent ** 2)
        if keep.any():
            parts.append(_part(g, keep, f"{path}" if len(geoms) == 1 else f"{path}#{k}"))
    return parts


def _check_coordinates(geoms, path) -> None:
    """Refuse (:class:`SpecError`) geometry with non-finite or absurdly large (> 1000 km)
    vertex coordinates."""
    for g in geoms:
        v = np.asarray(g.vertices, float)
        if not np.all(np.isfinite(v)):
            raise SpecError("render.scene", f"{str(path)!r} has "
                                            f"{int((~np.isfinite(v)).any(1).sum())} vertices "
                                            "with non-finite coordinates")
        if np.abs(v).max() > 1e6:
            raise SpecError("render.scene", f"{str(path)!r} has coordinates beyond 1000 km "
                                            f"({np.abs(v).max():.3g} m): wrong units?")


def _nondegenerate(v, f, min_area2: float) -> np.ndarray:
    """(m,) bool: the faces ``f`` (m, 3) of vertices ``v`` (n, 3) m whose doubled area
    (m^2) exceeds ``min_area2``, in blocks of 2^16 faces (bounded temporaries)."""
    keep = np.empty(len(f), bool)
    for s in range(0, len(f), 1 << 16):
        b = f[s:s + (1 << 16)]
        a = v[b[:, 0]]
        keep[s:s + len(b)] = np.linalg.norm(np.cross(v[b[:, 1]] - a, v[b[:, 2]] - a),
                                            axis=1) > min_area2
    return keep


def _part(g, keep, name) -> SceneMesh:
    """One trimesh geometry -> SceneMesh, its faces ``keep`` only, with its look."""
    vis = g.visual
    kind = getattr(vis, "kind", None)
    if kind is None:
        g.merge_vertices()      # an STL's triangle soup shares its vertices again
    v = np.asarray(g.vertices, float)
    f = np.asarray(g.faces)[keep]
    if kind == "texture":
        mat = getattr(vis, "material", None)
        image = getattr(mat, "image", None)
        if image is None:
            image = getattr(mat, "baseColorTexture", None)
        uv = getattr(vis, "uv", None)
        if image is not None and uv is not None and len(uv) == len(v):
            return SceneMesh(name, v, f, texture=np.asarray(image.convert("RGB")),
                             uv=np.asarray(uv, float))
        factor = getattr(mat, "baseColorFactor", None)
        if factor is None:
            factor = getattr(mat, "main_color", None)
        if factor is not None:
            return SceneMesh(name, v, f, colors=np.asarray(factor, np.uint8)[:3])
    elif kind == "face":
        fc = np.asarray(vis.face_colors)[keep][:, :3]
        # flat faces: three vertices of their own per face, all of the face's colour
        return SceneMesh(name, v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3),
                         colors=np.repeat(fc, 3, axis=0))
    elif kind == "vertex":
        return SceneMesh(name, v, f, colors=np.asarray(vis.vertex_colors)[:, :3])
    return SceneMesh(name, v, f)
