"""Adaptive tessellation (pymeshlab) driven by the blur field.

A vertex is displaced by the matrix of the voxel it lies in, so a triangle can follow the
field's changes only if its edges are no longer than a voxel (Kakimoto 2007, §6). A mesh is
refined (midpoint subdivision of edges longer than the threshold, pymeshlab) only where a
field has blur at its depths and its edges are longer than one voxel column there; every
other mesh is left untouched. Colours and uv are interpolated by the subdivision.
"""

from __future__ import annotations

import numpy as np

from eyelab.scene.scene import SceneMesh

#: Refinement stops before a mesh would exceed this many vertices (reported).
MAX_VERTICES = 100_000
#: The threshold is one voxel column at this depth percentile of the mesh's vertices in
#: front of the camera. Voxel columns are uniform in angle, so one length threshold can
#: only be right at one depth: the 10th percentile refines the near part of a mesh that
#: recedes (a floor) without exploding the part right under the eye.
DEPTH_PERCENTILE = 10.0


def _edge_lengths(mesh: SceneMesh):
    f = mesh.faces
    v = mesh.vertices
    return np.concatenate([np.linalg.norm(v[f[:, a]] - v[f[:, b]], axis=1)
                           for a, b in ((0, 1), (1, 2), (2, 0))])


def voxel_size_at(field, mesh: SceneMesh):
    """World size (m) of one voxel column at the mesh's nearest depth in ``field``'s camera,
    and whether the field has any blur over the mesh's depth range."""
    cam = field.camera
    w = cam.depth(mesh.vertices)
    w_min = max(float(w.min()), cam.near)
    w_max = min(float(w.max()), cam.far)
    if w_max < cam.near or w_min > cam.far:
        return np.inf, False
    tx, ty = cam.tan_half
    nz, ny, nx = field.shape
    w_ref = max(float(np.percentile(w[w > cam.near], DEPTH_PERCENTILE)), cam.near)
    size = 2 * w_ref * min(tx / nx, ty / ny)
    bounds = field.slice_bounds_depth()
    ks = np.flatnonzero((bounds[1:] >= w_min) & (bounds[:-1] <= w_max))
    blurred = bool(np.any(field.matrix[ks] != 0)) if len(ks) else False
    return size, blurred


def refine_for_fields(mesh: SceneMesh, fields, *, max_iterations: int = 6):
    """Return (mesh, info): the mesh refined so that no edge is longer than one voxel column
    of any field that blurs it (or unchanged, with the reason in ``info``)."""
    sizes = [voxel_size_at(f, mesh) for f in fields if f is not None]
    blurred = [s for s, b in sizes if b]
    longest = float(_edge_lengths(mesh).max()) if mesh.n_triangles else 0.0
    info = {"mesh": mesh.name, "triangles_before": mesh.n_triangles, "longest_edge_m": longest}
    if not blurred:
        info.update(refined=False, why="no blur over this mesh's depth range")
        return mesh, info
    thr = min(blurred)
    info["threshold_m"] = thr
    if longest <= thr:
        info.update(refined=False, why="edges already shorter than a voxel")
        return mesh, info
    import pymeshlab

    kw = {"vertex_matrix": mesh.vertices, "face_matrix": mesh.faces.astype(np.int32)}
    if mesh.colors is not None:
        kw["v_color_matrix"] = np.column_stack([mesh.colors / 255.0, np.ones(len(mesh.colors))])
    if mesh.uv is not None:
        kw["v_tex_coords_matrix"] = mesh.uv
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(**kw))
    its = 0
    capped = False
    for its in range(1, max_iterations + 1):  # noqa: B007 - reported below
        if ms.current_mesh().vertex_number() * 4 > MAX_VERTICES:
            capped = True
            its -= 1
            break
        ms.meshing_surface_subdivision_midpoint(iterations=1,
                                                threshold=pymeshlab.PureValue(thr))
        m = ms.current_mesh()
        v = m.vertex_matrix()
        f = m.face_matrix()
        e = max(np.linalg.norm(v[f[:, a]] - v[f[:, b]], axis=1).max()
                for a, b in ((0, 1), (1, 2), (2, 0)))
        if e <= thr:
            break
    m = ms.current_mesh()
    colors = None
    if mesh.colors is not None:
        colors = np.clip(np.round(m.vertex_color_matrix()[:, :3] * 255), 0, 255).astype(np.uint8)
    out = SceneMesh(mesh.name, m.vertex_matrix(), m.face_matrix(), colors, mesh.texture,
                    m.vertex_tex_coord_matrix() if mesh.uv is not None else None)
    info.update(refined=True, iterations=its, triangles_after=out.n_triangles,
                capped_at_max_vertices=capped,
                why=f"edges up to {longest:.3g} m > voxel {thr:.3g} m where the field blurs")
    return out, info
