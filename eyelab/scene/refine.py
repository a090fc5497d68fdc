"""Adaptive tessellation (pymeshlab) driven by the blur field.

A vertex is displaced by the matrix at the vertex and the displacement is interpolated
linearly across each triangle, so a mesh follows the field only where the field is nearly
linear along its edges (Kakimoto 2007, §6: 'tessellated with sufficient granularity'). Faces
whose edges interpolate the field worse than a tolerance in pixels are subdivided
(pymeshlab midpoint subdivision of the selected faces), repeatedly; meshes at depths where
no field blurs, or where the field is already linear enough, are left untouched. Colours
and uv are interpolated by the subdivision.
"""

from __future__ import annotations

import functools

import numpy as np

from eyelab.scene.scene import SceneMesh

#: Refinement stops before a mesh would exceed this many vertices (reported).
MAX_VERTICES = 100_000
#: Faces (vertices) measured per block: the field look-ups' temporaries of a block (~300 B
#: per face) stay a few tens of MB, whatever the mesh's size (a whole 8 M-triangle mesh at
#: once: 2.2 GiB).
FACE_BLOCK = 1 << 16


def _blocks(n: int):
    """Slices of ``range(n)`` in :data:`FACE_BLOCK` steps."""
    return (slice(s, min(s + FACE_BLOCK, n)) for s in range(0, n, FACE_BLOCK))


def _longest_edge(mesh: SceneMesh) -> float:
    """Length (m) of the mesh's longest edge (0 without faces)."""
    v, longest = mesh.vertices, 0.0
    for sl in _blocks(len(mesh.faces)):
        f = mesh.faces[sl]
        for a, b in ((0, 1), (1, 2), (2, 0)):
            longest = max(longest, float(np.linalg.norm(v[f[:, a]] - v[f[:, b]], axis=1).max()))
    return longest


def blurs_over(field, mesh: SceneMesh) -> bool:
    """Whether ``field`` has any non-zero matrix over the depth range of ``mesh``'s vertices
    in front of its camera."""
    cam = field.camera
    w = cam.depth(mesh.vertices)
    w_min = max(float(w.min()), cam.near)
    w_max = min(float(w.max()), cam.far)
    if w_max < cam.near or w_min > cam.far:
        return False
    bounds = field.slice_bounds_depth()
    ks = np.flatnonzero((bounds[1:] >= w_min) & (bounds[:-1] <= w_max))
    return bool(np.any(field.matrix[ks] != 0)) if len(ks) else False


def _interpolation_error(vertices, faces, fields, px_scale):
    """Per-face worst error (px, for a unit seed) of interpolating the field's matrix
    linearly along each edge instead of sampling it at the edge's midpoint."""
    err = np.zeros(len(faces))
    for f in fields:
        # faces reaching in front of the near plane are clipped there: not measured
        near = f.camera.depth(vertices) < f.camera.near
        bv = np.empty((len(vertices), 4))
        for sl in _blocks(len(vertices)):
            bv[sl] = f.lookup(vertices[sl]).reshape(-1, 4)
        for sl in _blocks(len(faces)):          # bounded temporaries (FACE_BLOCK)
            fb = faces[sl]
            clipped = near[fb].any(axis=1)
            for a, b in ((0, 1), (1, 2), (2, 0)):
                ia, ib = fb[:, a], fb[:, b]
                mid = 0.5 * (vertices[ia] + vertices[ib])
                bm = f.lookup(mid).reshape(-1, 4)
                e = np.abs(bm - 0.5 * (bv[ia] + bv[ib])).max(axis=1) * px_scale
                err[sl] = np.maximum(err[sl], np.where(clipped, 0.0, e))
    return err


def refine_for_fields(mesh: SceneMesh, fields, *, px_scale: float = 320.0,
                      tol_px: float = 0.5, max_iterations: int = 6):
    """Return (mesh, info): the mesh refined (pymeshlab midpoint subdivision of the selected
    faces) until linear interpolation of every field's matrix along every edge is within
    ``tol_px`` pixels of the field itself (for a unit seed; ``px_scale`` = pixels per NDC
    unit, i.e. half the image width) — the displacement then follows the field wherever it
    changes; meshes where no field blurs, where the field is already linear enough, or of
    over half :data:`MAX_VERTICES` vertices (never copied into pymeshlab), are left
    untouched (and say why). :func:`refine_steps` run to its end."""
    from eyelab.core.parallel import run_steps

    return run_steps(refine_steps(mesh, fields, px_scale=px_scale, tol_px=tol_px,
                                  max_iterations=max_iterations))


def refine_steps(mesh: SceneMesh, fields, *, px_scale: float = 320.0, tol_px: float = 0.5,
                 max_iterations: int = 6, offload: bool = False):
    """:func:`refine_for_fields` as a generator pausing (None) between its measurements
    and subdivisions (an interactive window's ticks), whose value is (mesh, info). With
    ``offload`` each measurement of the faces' errors (numpy: the field's look-ups) runs
    on a worker thread; pymeshlab's subdivisions stay on the calling thread."""
    from eyelab.core.parallel import on_worker

    def measure(v, f):
        work = functools.partial(_interpolation_error, v, f, blurred, px_scale)
        return (yield from on_worker(work)) if offload else work()

    fields = [f for f in fields if f is not None]
    blurred = [f for f in fields if blurs_over(f, mesh)]
    info = {"mesh": mesh.name, "triangles_before": mesh.n_triangles,
            "longest_edge_m": _longest_edge(mesh),
            "tolerance_px": tol_px}
    if not blurred or not mesh.n_triangles:
        info.update(refined=False, why="no blur over this mesh's depth range")
        return mesh, info
    err = yield from measure(mesh.vertices, mesh.faces)
    info["max_error_px_before"] = float(err.max())
    if err.max() <= tol_px:
        info.update(refined=False, why=f"the field is linear to {err.max():.2f} px along "
                                       "every edge already")
        return mesh, info
    if len(mesh.vertices) * 2 > MAX_VERTICES:   # one subdivision would pass the cap
        info.update(refined=False, capped_at_max_vertices=True,
                    why=f"linear interpolation of the field along edges is off by up to "
                        f"{info['max_error_px_before']:.2f} px (> {tol_px} px), but the mesh "
                        f"has {len(mesh.vertices)} vertices: subdividing would pass "
                        f"{MAX_VERTICES}")
        return mesh, info
    out, its, capped, final = yield from _subdivide(mesh, err, measure, tol_px,
                                                    max_iterations)
    info.update(refined=True, iterations=its, triangles_after=out.n_triangles,
                max_error_px_after=float(final.max()), capped_at_max_vertices=capped,
                why=f"linear interpolation of the field along edges was off by up to "
                    f"{info['max_error_px_before']:.2f} px (> {tol_px} px)")
    return out, info


def _subdivide(mesh: SceneMesh, err, measure, tol_px, max_iterations):
    """A generator (pausing as ``measure`` does, and after each subdivision) whose value
    is (mesh, iterations, capped, the final per-face error): ``mesh`` subdivided by
    pymeshlab where its per-face error ``err`` (px, (m,)) exceeds ``tol_px``, repeatedly
    (see :func:`refine_for_fields`); ``measure(vertices, faces)`` a generator whose value
    is the per-face error."""
    from eyelab.core.interrupt import deferred

    with deferred():            # an interrupted initialisation leaves pymeshlab unusable
        import pymeshlab

    kw = {"vertex_matrix": mesh.vertices, "face_matrix": mesh.faces.astype(np.int32),
          "f_scalar_array": err}
    if mesh.colors is not None:
        kw["v_color_matrix"] = np.column_stack([mesh.colors / 255.0, np.ones(len(mesh.colors))])
    if mesh.uv is not None:
        kw["v_tex_coords_matrix"] = mesh.uv
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(**kw))
    its = 0
    capped = False
    while its < max_iterations:
        m = ms.current_mesh()
        if m.vertex_number() * 2 > MAX_VERTICES:
            capped = True
            break
        ms.compute_selection_by_condition_per_face(condselect=f"fq > {tol_px}")
        if ms.current_mesh().selected_face_number() == 0:
            break
        # VCG splits an edge only between two selected faces: grow the selection by one ring
        ms.apply_selection_dilatation()
        ms.meshing_surface_subdivision_midpoint(iterations=1, threshold=pymeshlab.PureValue(0.0),
                                                selected=True)
        its += 1
        m = ms.current_mesh()
        v, f = m.vertex_matrix(), m.face_matrix()
        yield None
        err = yield from measure(v, f)
        kw = {"vertex_matrix": v, "face_matrix": f, "f_scalar_array": err}
        if m.has_vertex_color():
            kw["v_color_matrix"] = m.vertex_color_matrix()
        if m.has_vertex_tex_coord():
            kw["v_tex_coords_matrix"] = m.vertex_tex_coord_matrix()
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(**kw))
        if err.max() <= tol_px:
            break
    m = ms.current_mesh()
    colors = None
    if mesh.colors is not None:
        colors = np.clip(np.round(m.vertex_color_matrix()[:, :3] * 255), 0, 255).astype(np.uint8)
    out = SceneMesh(mesh.name, m.vertex_matrix(), m.face_matrix(), colors, mesh.texture,
                    m.vertex_tex_coord_matrix() if mesh.uv is not None else None)
    final = err if its else (yield from measure(out.vertices, out.faces))
    return out, its, capped, final
