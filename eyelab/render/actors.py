"""VTK data and actors built from eyelab's numpy scene data: polydata, textures, unlit
mesh actors carrying the blur-field attribute of the CPU route."""

from __future__ import annotations

import numpy as np

from eyelab.render import _vtk
from eyelab.scene.scene import SceneMesh


def polydata(vertices, faces):
    """vtkPolyData of triangles: vertices (n, 3) float, faces (m, 3) int."""
    pts = _vtk.vtkPoints()
    pts.SetData(_vtk.numpy_to_vtk(np.ascontiguousarray(vertices, dtype=float), deep=True))
    cells = _vtk.vtkCellArray()
    conn = np.ascontiguousarray(np.asarray(faces).ravel(), dtype=np.int64)
    offs = np.arange(0, len(conn) + 1, 3, dtype=np.int64)
    cells.SetData(_vtk.numpy_to_vtk(offs, deep=True), _vtk.numpy_to_vtk(conn, deep=True))
    pd = _vtk.vtkPolyData()
    pd.SetPoints(pts)
    pd.SetPolys(cells)
    return pd


def set_faces(pd, faces) -> None:
    """Replace the triangles (m, 3) of polydata in place, its points and their data kept."""
    conn = np.ascontiguousarray(np.asarray(faces).ravel(), dtype=np.int64)
    offs = np.arange(0, len(conn) + 1, 3, dtype=np.int64)
    cells = _vtk.vtkCellArray()
    cells.SetData(_vtk.numpy_to_vtk(offs, deep=True), _vtk.numpy_to_vtk(conn, deep=True))
    pd.SetPolys(cells)
    pd.Modified()


def set_geometry(pd, vertices, faces) -> None:
    """Replace the points and triangles of polydata in place (its point data is cleared)."""
    new = polydata(vertices, faces)
    pd.SetPoints(new.GetPoints())
    pd.SetPolys(new.GetPolys())
    pd.GetPointData().Initialize()
    pd.Modified()


def set_tcoords(pd, uv) -> None:
    """Attach (n, 2) texture coordinates (v = 0 at the image bottom) to polydata."""
    tc = _vtk.numpy_to_vtk(np.ascontiguousarray(uv, dtype=np.float32), deep=True)
    tc.SetName("uv")
    pd.GetPointData().SetTCoords(tc)
    pd.Modified()


def add_point_array(pd, name: str, values) -> None:
    """Attach an (n,) or (n, k) array to polydata's point data as float32 under ``name``
    (replacing one of that name), e.g. a shader's vertex attribute."""
    arr = _vtk.numpy_to_vtk(np.ascontiguousarray(values, dtype=np.float32), deep=True)
    arr.SetName(name)
    pd.GetPointData().AddArray(arr)
    pd.Modified()


def image_data(img_top_first):
    """vtkImageData of an (h, w, 3) uint8 image with row 0 at the top (VTK wants bottom)."""
    data = _vtk.vtkImageData()
    set_image(data, img_top_first)
    return data


def set_image(data, img_top_first) -> None:
    """Replace the pixels (and size) of image data made by :func:`image_data`."""
    h, w = img_top_first.shape[:2]
    data.SetDimensions(w, h, 1)
    arr = _vtk.numpy_to_vtk(np.ascontiguousarray(img_top_first[::-1].reshape(-1, 3)),
                            deep=True)
    arr.SetName("rgb")
    data.GetPointData().SetScalars(arr)
    data.Modified()


def set_image_rgba_gl(data, rgba) -> None:
    """Replace the pixels (and size) of image data with an (h, w, 4) uint8 RGBA image in GL
    row order (row 0 at the bottom, as VTK stores images), contiguous: no flip, no gather."""
    h, w = rgba.shape[:2]
    data.SetDimensions(w, h, 1)
    arr = _vtk.numpy_to_vtk(np.ascontiguousarray(rgba).reshape(-1, 4), deep=True)
    arr.SetName("rgba")
    data.GetPointData().SetScalars(arr)
    data.Modified()


def texture(img_top_first, *, mipmap: bool = False, srgb: bool = False):
    """vtkTexture (bilinear, clamped) of an (h, w, 3) uint8 image, row 0 at the top.
    ``mipmap``: trilinear mip-mapping, for textures seen smaller than their texels;
    ``srgb``: the texels are sRGB codes that the GL decodes to linear light before
    filtering and mip-mapping (the fragment shader must then re-encode its output:
    ``shaders/encode_srgb.frag.glsl``)."""
    tex = _vtk.vtkTexture()
    if srgb:
        tex.UseSRGBColorSpaceOn()
    tex.SetInputData(image_data(img_top_first))
    tex.InterpolateOn()
    tex.RepeatOff()
    tex.EdgeClampOn()
    tex.SetColorModeToDirectScalars()
    if mipmap:
        tex.MipmapOn()
    return tex


def unlit_actor(pd, tex=None):
    """An unlit actor drawing ``pd`` with its own mapper (a vtkOpenGLPolyDataMapper, on which
    UpdateShaderEvent fires); textured if ``tex`` is given."""
    mapper = _vtk.vtkOpenGLPolyDataMapper()
    mapper.SetInputData(pd)
    actor = _vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().LightingOff()
    if tex is not None:
        mapper.ScalarVisibilityOff()
        actor.SetTexture(tex)
    return actor


def mesh_actor(mesh: SceneMesh, blur_rows: np.ndarray | None = None, *, mipmap: bool = False):
    """An unlit actor of a scene mesh (vertex colours or its texture, an sRGB texture
    filtered in linear light, mip-mapped if ``mipmap``) with the per-vertex ``blurM``
    attribute (n, 4) float32 of the CPU route (zeros when None)."""
    pd = polydata(mesh.vertices, mesh.faces)
    if mesh.texture is not None:
        set_tcoords(pd, mesh.uv)
        # filtered (and mip-mapped) in linear light, as the passes are averaged (the
        # actor's shader re-encodes): minified text greys as light mixes
        actor = unlit_actor(pd, texture(mesh.texture, mipmap=mipmap, srgb=True))
    else:
        col = _vtk.numpy_to_vtk(np.ascontiguousarray(mesh.colors), deep=True)
        col.SetName("colors")
        pd.GetPointData().AddArray(col)
        actor = unlit_actor(pd)
        mapper = actor.GetMapper()
        mapper.SetScalarModeToUsePointFieldData()
        mapper.SelectColorArray("colors")
        mapper.SetColorModeToDirectScalars()
        mapper.ScalarVisibilityOn()
    rows = np.zeros((len(mesh.vertices), 4), np.float32) if blur_rows is None else blur_rows
    b = _vtk.numpy_to_vtk(np.ascontiguousarray(rows, dtype=np.float32), deep=True)
    b.SetName("blurM")
    pd.GetPointData().AddArray(b)
    actor.GetMapper().MapDataArrayToVertexAttribute(
        "blurM", "blurM", _vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, -1)
    return actor


def field_actor_factory(mesh: SceneMesh, field, route: str, *, mipmap: bool = False):
    """A zero-argument factory of the mesh's actor for a blur-field route: "texture" (the
    shader samples the field) or "attribute" (matrices looked up here, per vertex)."""
    if route == "texture":
        return lambda: mesh_actor(mesh, None, mipmap=mipmap)
    return lambda: mesh_actor(mesh, field.lookup(mesh.vertices).reshape(-1, 4)
                              .astype(np.float32), mipmap=mipmap)
