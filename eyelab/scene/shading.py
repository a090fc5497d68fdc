"""Lambertian shading baked into a mesh's vertex colours, in linear light (numpy only).

The model — one directional light fixed in the head (eyelab's world frame: x to the
wearer's right, y up, the wearer looking along -z), nothing else — gives each vertex the
linear radiance

    L = albedo * (AMBIENT + (1 - AMBIENT) * max(0, n . LIGHT_DIRECTION))

with ``albedo`` the vertex's own colour decoded to linear light and ``n`` its unit normal
(Lambert's cosine law plus a constant ambient term, so that no face is black). A surface
facing the light keeps its own colour; one facing away keeps ``AMBIENT`` of it. The
radiance is computed before any blur and stored as the mesh's colours (sRGB codes, the
code nearest in linear light), so every renderer blurs the same radiance.

Normals: the normal of a vertex is the sum of its faces' normals weighted by Max's weights,
(e1 x e2) / (|e1|^2 |e2|^2) for the corner's edge vectors e1, e2 (N. Max, "Weights for
computing vertex normals from facet normals", J. Graphics Tools 4(2), 1999): exact for
vertices on a sphere, where area-weighted normals (and trimesh's angle-weighted ones) are
off by up to 1.35 (0.60) deg on ``trimesh.creation.icosphere(2)`` and 0.68 (0.30) deg on
``icosphere(3)`` — first-order errors in n . l. Faces meeting at more than
:data:`CREASE_DEG` keep their own normals along that edge (the vertex is split), so a
box's faces stay flat and a sphere smooth. A closed mesh wound inside out (negative
volume) is lit from outside.

Renderers interpolate vertex colours linearly across each triangle (Gouraud), which
follows the cosine law to ``1 - cos(step / 2)`` of the diffuse term for normals ``step``
apart along an edge: edges whose normals differ by more than
:data:`MAX_NORMAL_STEP_DEG` are split at their midpoints (the normal there the normalised
mean of the two; conforming: a face has 1, 2 or 3 of its edges split), while the mesh
stays under :data:`MAX_SHADED_TRIANGLES`.

Precision: 8-bit sRGB codes hold the radiance to half a code, at most 1 % relative above
linear 0.14 (the ambient level of the default grey, sRGB 200). The raster interpolates the
codes themselves across a triangle where the reference decodes them first: on shaded
meshes the two differ by at most 1.04 % at an edge's midpoint (measured on
``icosphere(3)`` and ``trimesh.creation.torus(0.08, 0.03)``). ``tests/test_shading.py``
renders a plain sphere and finds the cosine law per pixel to 2 %.
"""

from __future__ import annotations

import math

import numpy as np

from eyelab.core.color import decode_srgb

#: ``[render] scene`` ``shading`` values: "auto" shades meshes without colours or texture
#: (a plain STL) and keeps coloured ones flat; "lambert" shades coloured ones too (textured
#: parts stay flat: a texture has no per-vertex radiance to scale); "none" keeps all flat.
SHADINGS = ("auto", "lambert", "none")
#: Fraction of the albedo a surface facing away from the light keeps.
AMBIENT = 0.25
#: Unit vector toward the light (world frame): from the wearer's upper left, behind the
#: head, 35.3 deg off the line of sight — a sphere straight ahead shows its terminator at
#: the lower right.
LIGHT_DIRECTION = np.array([-1.0, 1.0, 2.0]) / math.sqrt(6.0)
#: Faces whose normals differ by more than this (deg) meet at a crease (Blender's
#: auto-smooth default): a CAD part's flat faces stay flat, a tessellated curve smooth.
CREASE_DEG = 30.0
#: Edges whose vertex normals differ by more (deg) are split: Gouraud then follows the
#: cosine law to 1 - cos(5 deg) = 0.4 % of the diffuse term along edges.
MAX_NORMAL_STEP_DEG = 10.0
#: Splitting stops before a mesh would pass this many triangles (the steps left are in
#: :func:`shade`'s ``info``): the memory estimate counts a file's own triangles, so what
#: splitting adds stays small (a coarse mesh's few thousand, never a scan's millions).
MAX_SHADED_TRIANGLES = 1 << 18
#: Splitting rounds at most (each halves the steps: 10 deg from 180 in 5).
MAX_ROUNDS = 8

# sRGB code -> linear light, and the midpoints between successive codes' linear values
_CODES_LINEAR = decode_srgb(np.arange(256, dtype=np.uint8)).astype(float)
_MIDPOINTS = 0.5 * (_CODES_LINEAR[1:] + _CODES_LINEAR[:-1])


def encode_nearest(linear) -> np.ndarray:
    """Linear light (any shape) -> the uint8 sRGB codes nearest to it in linear light."""
    return np.searchsorted(_MIDPOINTS, np.asarray(linear, float)).astype(np.uint8)


def lambert(normals, albedo) -> np.ndarray:
    """Linear radiance (n, 3) of surfaces with unit ``normals`` (n, 3) (zero rows: ambient
    only) and linear ``albedo`` (n, 3) under the module's light (see the module's notes)."""
    cos = np.maximum(np.asarray(normals, float) @ LIGHT_DIRECTION, 0.0)
    return np.asarray(albedo, float) * (AMBIENT + (1.0 - AMBIENT) * cos)[:, None]


def _unit_rows(v) -> np.ndarray:
    """Rows of ``v`` (n, 3) scaled to unit length; zero rows stay zero."""
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def corner_normals(vertices, faces) -> np.ndarray:
    """(m, 3, 3) Max-weighted normal contribution of each face corner: (e1 x e2) /
    (|e1|^2 |e2|^2), e1 and e2 the edges leaving the corner (zero at a zero-length
    edge)."""
    p = vertices[faces]                                           # (m, 3, 3)
    e1 = np.roll(p, -1, axis=1) - p
    e2 = np.roll(p, -2, axis=1) - p
    w = (e1 * e1).sum(-1) * (e2 * e2).sum(-1)
    c = np.cross(e1, e2)
    return np.divide(c, w[..., None], out=np.zeros_like(c), where=w[..., None] > 0)


def _sum_by(index, values, n) -> np.ndarray:
    """(n, 3) sums of the rows of ``values`` (k, 3) by ``index`` (k,)."""
    # (bincount of no values is int: the sums are floats whatever the count)
    return np.stack([np.bincount(index, values[:, j], minlength=n) for j in range(3)],
                    1).astype(float, copy=False)


def _half_edges(faces):
    """Half-edges of ``faces`` (m, 3) in corner order: (from, to) vertex ids, each (3m,)
    (half-edge 3f + k runs from corner k of face f to corner k + 1)."""
    return faces.ravel(), np.roll(faces, -1, axis=1).ravel()


def _pairs(a, b):
    """Half-edges paired with their opposite: (i, j) index arrays of the half-edges (from
    ``a`` to ``b``, ids (k,)) whose undirected edge has exactly two half-edges, running in
    opposite directions; and whether every edge is paired so (a closed, consistently
    wound mesh)."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * (int(max(a.max(initial=0), b.max(initial=0))) + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.r_[True, ks[1:] != ks[:-1]]
    counts = np.diff(np.r_[np.flatnonzero(first), len(ks)])
    start = np.flatnonzero(first)[counts == 2]
    i, j = order[start], order[start + 1]
    opposite = a[i] == b[j]
    closed = bool(len(ks)) and bool((counts == 2).all()) and bool(opposite.all())
    return i[opposite], j[opposite], closed


def _end(h):
    """The corner a half-edge ``h`` (ids, :func:`_half_edges`) runs to."""
    return 3 * (h // 3) + (h % 3 + 1) % 3


def smooth_vertices(vertices, faces, crease_deg: float = CREASE_DEG):
    """Split a mesh's vertices at creases: (faces (m, 3) into the new vertices, source (k,)
    the old vertex each new one copies, normals (k, 3) unit). Corners at one position share
    a normal where their faces meet at an edge within ``crease_deg`` (followed from face to
    face around the vertex); vertices at one position are one for this (a flat mesh's
    per-face copies too), but copies of different vertices stay apart (their colours)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    _, pos = np.unique(vertices, axis=0, return_inverse=True)
    pos = pos.ravel()
    m = len(faces)
    contrib = corner_normals(vertices, faces).reshape(-1, 3)
    fn = _unit_rows(contrib.reshape(m, 3, 3).sum(axis=1))   # each corner's is along it
    a, b = _half_edges(pos[faces])
    i, j, closed = _pairs(a, b)
    smooth = (fn[i // 3] * fn[j // 3]).sum(1) >= math.cos(math.radians(crease_deg))
    i, j = i[smooth], j[smooth]
    # half-edge i runs a -> b from corner i to corner _end(i), its partner j b -> a: i's
    # start corner and j's end corner are at a, i's end corner and j's start corner at b
    u = np.r_[i, _end(i)]
    v = np.r_[_end(j), j]
    graph = coo_matrix((np.ones(len(u), np.int8), (u, v)), shape=(3 * m, 3 * m))
    _, label = connected_components(graph, directed=False)
    source_of_corner = faces.ravel()
    pair = label.astype(np.int64) * len(vertices) + source_of_corner
    _, first, new = np.unique(pair, return_index=True, return_inverse=True)
    normals = _unit_rows(_sum_by(label, contrib, label.max() + 1 if m else 0))
    n_out = normals[label[first]]
    volume = np.einsum("ij,ij->i", vertices[faces[:, 0]],
                       np.cross(vertices[faces[:, 1]], vertices[faces[:, 2]])).sum()
    if closed and volume < 0:                     # wound inside out: lit from outside
        n_out = -n_out
    return new.reshape(m, 3), source_of_corner[first], n_out


def subdivide(vertices, faces, normals, albedo, *, max_step_deg: float = MAX_NORMAL_STEP_DEG,
              max_triangles: int = MAX_SHADED_TRIANGLES):
    """Split the edges whose vertex normals differ by more than ``max_step_deg`` at their
    midpoints, repeatedly (at most :data:`MAX_ROUNDS`), conformingly (a face splits into
    2, 3 or 4 along its split edges; coincident copies of an edge split together) while
    the mesh stays within ``max_triangles``. ``vertices`` (n, 3), ``normals`` (n, 3)
    unit, ``albedo`` (n, 3) linear. Returns (vertices, faces, normals, albedo, info)
    with ``info`` {"rounds", "max_step_deg"} (the largest step left)."""
    cos_max = math.cos(math.radians(max_step_deg))
    rounds = 0
    while True:
        a, b = _half_edges(faces)
        # a zero normal (a vertex of zero-area faces only) has no direction to follow
        valid = (np.abs(normals[a]).sum(1) > 0) & (np.abs(normals[b]).sum(1) > 0)
        dots = np.where(valid, (normals[a] * normals[b]).sum(1), 1.0)
        step = float(np.degrees(np.arccos(np.clip(dots.min(initial=1.0), -1.0, 1.0))))
        bad = dots < cos_max
        if not bad.any() or rounds == MAX_ROUNDS:
            break
        _, pos = np.unique(vertices, axis=0, return_inverse=True)
        pa, pb = pos.ravel()[a], pos.ravel()[b]
        pkey = np.minimum(pa, pb).astype(np.int64) * (pos.max() + 1) + np.maximum(pa, pb)
        split = np.isin(pkey, pkey[bad]).reshape(-1, 3)
        if len(faces) + int(split.sum()) > max_triangles:
            break
        vertices, faces, normals, albedo = _split(vertices, faces, normals, albedo, split)
        rounds += 1
    return vertices, faces, normals, albedo, {"rounds": rounds, "max_step_deg": step}


def _split(vertices, faces, normals, albedo, split):
    """One round of :func:`subdivide`: the edges ``split`` (m, 3) bool (edge k of a face:
    corner k to k + 1) cut at their midpoints."""
    a, b = _half_edges(faces)
    s = split.ravel()
    key = np.minimum(a, b).astype(np.int64) * len(vertices) + np.maximum(a, b)
    uniq, inv = np.unique(key[s], return_inverse=True)
    ea, eb = uniq // len(vertices), uniq % len(vertices)
    mid = np.full(len(a), -1, np.int64)
    mid[s] = len(vertices) + inv.ravel()
    mid = mid.reshape(-1, 3)
    vertices = np.concatenate([vertices, 0.5 * (vertices[ea] + vertices[eb])])
    normals = np.concatenate([normals, _unit_rows(normals[ea] + normals[eb])])
    albedo = np.concatenate([albedo, 0.5 * (albedo[ea] + albedo[eb])])
    n_split = split.sum(1)
    # turn each face so that its pattern is canonical: one split edge -> edge 0; two ->
    # the unsplit one is edge 2; none or three: as it is
    r = np.where(n_split == 1, np.argmax(split, 1),
                 np.where(n_split == 2, (np.argmin(split, 1) + 1) % 3, 0))
    idx = (r[:, None] + np.arange(3)) % 3
    w = np.take_along_axis(faces, idx, 1)
    mm = np.take_along_axis(mid, idx, 1)
    c0, c1, c2, m0, m1, m2 = w[:, 0], w[:, 1], w[:, 2], mm[:, 0], mm[:, 1], mm[:, 2]
    out = [np.stack(t, 1)[sel] for sel, tris in (
        (n_split == 0, [(c0, c1, c2)]),
        (n_split == 1, [(c0, m0, c2), (m0, c1, c2)]),
        (n_split == 2, [(m0, c1, m1), (c0, m0, m1), (c0, m1, c2)]),
        (n_split == 3, [(c0, m0, m2), (m0, c1, m1), (m2, m1, c2), (m0, m1, m2)]))
        for t in tris]
    return vertices, np.concatenate(out), normals, albedo


def shade(vertices, faces, colors, **split):
    """Bake the Lambertian model (module notes) into a mesh: ``vertices`` (n, 3) m,
    ``faces`` (m, 3), ``colors`` (n, 3) uint8 sRGB albedo -> (vertices (k, 3), faces
    (m', 3), colors (k, 3) uint8 sRGB radiance, info) — vertices split at creases and
    edges split where the normals turn fast (:func:`smooth_vertices`; :func:`subdivide`,
    which takes ``split``'s keywords); ``info`` says how."""
    vertices = np.asarray(vertices, float)
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return vertices, faces, np.asarray(colors, np.uint8), {"rounds": 0,
                                                                "max_step_deg": 0.0}
    f, source, normals = smooth_vertices(vertices, faces)
    v, f, n, alb, info = subdivide(vertices[source], f, normals,
                                   decode_srgb(np.asarray(colors, np.uint8)[source])
                                   .astype(float), **split)
    return v, f, encode_nearest(lambert(n, alb)), info
