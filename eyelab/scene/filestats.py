"""How big a scene is, counted without building it: triangles, vertices and texture texels
of a built :class:`~eyelab.scene.scene.Scene`, or read cheaply from a mesh file before it is
loaded (for the memory estimate, :mod:`eyelab.imaging.memory`).

From a file, by format (no mesh is parsed; every count is a lower bound of what the loader
makes, exact for triangle meshes — but for a part drawn shaded, whose vertices split at
creases and whose edges split where the normals turn fast, up to
:data:`~eyelab.scene.shading.MAX_SHADED_TRIANGLES`):

- PLY (ASCII or binary): the header's ``element vertex`` / ``element face`` counts (faces
  with colours of their own are loaded flat, three vertices each) and a ``comment
  TextureFile`` image's size;
- STL: binary, the triangle count at byte 80 (when the file's size agrees with it);
  ASCII, the ``endfacet`` keywords counted; vertices taken as half the triangles (what a
  closed mesh has once its triangle soup shares vertices again);
- OBJ: the ``v`` and ``f`` lines counted (one triangle per face line at least), the
  ``map_Kd`` images of its material libraries;
- glTF / GLB: the accessors' counts of each mesh's triangle primitives (each mesh once,
  however many nodes place it) and the embedded or referenced images' sizes.

Image sizes come from their headers (PIL opens them lazily). Other formats give None:
their size is known once loaded.
"""

from __future__ import annotations

import functools
import json
import re
import struct
from dataclasses import dataclass
from pathlib import Path

#: Bytes read per block when counting the lines of a text mesh file.
SCAN_BLOCK = 1 << 24

#: A PLY header longer than this is not read as one (bytes).
MAX_PLY_HEADER = 1 << 16


@dataclass(frozen=True)
class SceneStats:
    """The size of a scene: ``triangles``, ``vertices`` and ``texels`` (texture pixels,
    summed over the meshes: each mesh keeps its own copy), counts; ``source``: where they
    come from (said in a refusal), e.g. "read from the file's header"."""

    triangles: int
    vertices: int
    texels: int = 0
    source: str = "of the built scene"


def scene_stats(scene) -> SceneStats:
    """The :class:`SceneStats` of a built scene (:class:`~eyelab.scene.scene.Scene`)."""
    texels = sum(int(m.texture.shape[0]) * int(m.texture.shape[1])
                 for m in scene.meshes if m.texture is not None)
    return SceneStats(int(scene.n_triangles), int(scene.n_vertices), texels,
                      "of the built scene")


def file_stats(path) -> SceneStats | None:
    """The :class:`SceneStats` of a mesh file read from its header or by counting its
    lines (see the module's notes), before any loading; None for a format not read here
    or a file that does not parse as its extension says (the loader then reports it)."""
    p = Path(path)
    if p.suffix.lower() not in _READERS:
        return None
    try:
        st = p.stat()
    except OSError:
        return None
    return _file_stats(str(p.resolve()), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=64)
def _file_stats(path: str, mtime_ns: int, size: int) -> SceneStats | None:
    """:func:`file_stats` of a file as it is (its modification time and size in the key: a
    batch's jobs that share a file read it once)."""
    p = Path(path)
    try:
        stats = _READERS[p.suffix.lower()](p)
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError,
            RecursionError, struct.error):
        return None        # not what its extension says: the loader will report it
    if stats is not None and min(stats.triangles, stats.vertices, stats.texels) < 0:
        return None
    return stats


def image_texels(source) -> int:
    """Width x height of an image file (path or file object), from its header; 0 when it
    cannot be read."""
    from PIL import Image

    try:
        with Image.open(source) as img:
            return int(img.size[0]) * int(img.size[1])
    except (OSError, ValueError, Image.DecompressionBombError):
        return 0


def _ply(p: Path) -> SceneStats:
    with open(p, "rb") as f:
        head = f.read(MAX_PLY_HEADER)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        raise ValueError("not a PLY header")
    counts, face_props, texels, element = {}, [], 0, None
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if words[:1] == ["element"] and len(words) == 3:
            element = words[1]
            counts[element] = int(words[2])
        elif words[:1] == ["property"] and element == "face":
            face_props.append(words[-1])
        elif words[:2] == ["comment", "TextureFile"] and len(words) > 2:
            texels += image_texels(p.parent / " ".join(words[2:]))
    faces = counts.get("face", 0)
    flat = bool({"red", "green", "blue", "diffuse_red"} & set(face_props))
    verts = 3 * faces if flat else counts.get("vertex", 0)
    return SceneStats(faces, verts, texels, "read from the file's header")


def _stl(p: Path) -> SceneStats:
    size = p.stat().st_size
    with open(p, "rb") as f:
        head = f.read(84)
    if len(head) == 84:
        n = struct.unpack("<I", head[80:84])[0]
        if size == 84 + 50 * n:
            return SceneStats(n, n // 2, 0, "read from the file's header")
    n = _count(p, (b"endfacet",))[0]
    return SceneStats(n, n // 2, 0, "counted in the file")


def _obj(p: Path) -> SceneStats:
    nv, nf = _count(p, (b"\nv ", b"\nf "), first_line=True)
    texels = 0
    for lib in _obj_mtllibs(p):
        texels += _mtl_texels(lib)
    return SceneStats(nf, nv, texels, "counted in the file")


def _obj_mtllibs(p: Path) -> list:
    """The material libraries an OBJ names (``mtllib`` lines, read from its first MB)."""
    with open(p, "rb") as f:
        head = f.read(1 << 20).decode("utf-8", "replace")
    return [p.parent / m.strip() for m in re.findall(r"^mtllib\s+(.+)$", head, re.M)]


def _mtl_texels(mtl: Path) -> int:
    try:
        text = mtl.read_text(errors="replace")
    except OSError:
        return 0
    maps = re.findall(r"^\s*map_Kd\s+(?:-\S+\s+\S+\s+)*(.+)$", text, re.M)
    return sum(image_texels(mtl.parent / m.strip()) for m in maps)


def _count(p: Path, needles: tuple, first_line: bool = False) -> list:
    """Occurrences of each byte string in the file, read in :data:`SCAN_BLOCK` blocks
    (``first_line``: a needle starting with a newline also matches at the file's start)."""
    counts = [0] * len(needles)
    prev = b"\n" if first_line else b""
    with open(p, "rb") as f:
        while block := f.read(SCAN_BLOCK):
            for i, n in enumerate(needles):
                # the last len(n) - 1 bytes before the block: a match across the seam
                counts[i] += (prev[len(prev) - len(n) + 1:] + block).count(n)
            prev = block
    return counts


def _gltf(p: Path) -> SceneStats:
    if p.suffix.lower() == ".glb":
        doc, binary = _glb_chunks(p)
    else:
        doc, binary = json.loads(p.read_text()), None
    acc = doc.get("accessors", [])
    tris = verts = 0
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            if prim.get("mode", 4) != 4:       # points, lines, strips: not counted
                continue
            n_pos = int(acc[prim["attributes"]["POSITION"]]["count"])
            idx = prim.get("indices")
            tris += (int(acc[idx]["count"]) if idx is not None else n_pos) // 3
            verts += n_pos
    texels = sum(_gltf_image_texels(p, doc, img, binary) for img in doc.get("images", []))
    return SceneStats(tris, verts, texels, "read from the file's header")


def _glb_chunks(p: Path) -> tuple:
    """(JSON document, the binary chunk's offset in the file or None) of a GLB file."""
    with open(p, "rb") as f:
        magic, _, _ = struct.unpack("<4sII", f.read(12))
        if magic != b"glTF":
            raise ValueError("not a GLB file")
        length, kind = struct.unpack("<I4s", f.read(8))
        doc = json.loads(f.read(length))
        start = 12 + 8 + length
        f.seek(start)
        head = f.read(8)
    return doc, (start + 8 if len(head) == 8 and head[4:] == b"BIN\x00" else None)


def _gltf_image_texels(p: Path, doc: dict, img: dict, binary: int | None) -> int:
    """Texels of one glTF image: a file beside the glTF, or (GLB) a buffer view read from
    the binary chunk; 0 for data URIs and what cannot be read."""
    import io

    uri = img.get("uri")
    if uri is not None:
        return 0 if uri.startswith("data:") else image_texels(p.parent / uri)
    view = doc["bufferViews"][img["bufferView"]]
    if binary is None or view.get("buffer", 0) != 0:
        return 0
    with open(p, "rb") as f:
        f.seek(binary + int(view.get("byteOffset", 0)))
        data = f.read(int(view["byteLength"]))
    return image_texels(io.BytesIO(data))


_READERS = {".ply": _ply, ".stl": _stl, ".obj": _obj, ".glb": _gltf, ".gltf": _gltf}
