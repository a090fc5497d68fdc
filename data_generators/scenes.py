"""Write eyelab's built-in scenes (:mod:`eyelab.scene.library`) as binary glTF files, with
their vertex colours and textures, for other tools or as examples of mesh input:

    python -m eyelab.data_generators.scenes OUT_DIR [--names room chart ...]

Each scene becomes ``OUT_DIR/<name>.glb`` (metres, eyelab's world frame: the eye at the
origin looking along -z, y up), written atomically.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from eyelab.core.fileio import atomic_path
from eyelab.scene.library import SCENES


def _plain(text: str) -> str:
    """Docstring text for ``--help``: Sphinx roles and double backquotes dropped."""
    import re

    return re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "")


def scene_to_trimesh(scene):
    """A ``trimesh.Scene`` with one geometry per mesh (textured or vertex-coloured)."""
    import trimesh
    from PIL import Image

    out = trimesh.Scene()
    for m in scene.meshes:
        if m.texture is not None:
            visual = trimesh.visual.TextureVisuals(uv=np.asarray(m.uv),
                                                   image=Image.fromarray(m.texture))
        else:
            rgba = np.column_stack([m.colors, np.full(len(m.colors), 255, np.uint8)])
            visual = trimesh.visual.ColorVisuals(vertex_colors=rgba)
        out.add_geometry(trimesh.Trimesh(np.asarray(m.vertices), np.asarray(m.faces),
                                         visual=visual, process=False), node_name=m.name)
    return out


def write_scenes(out_dir, names=None) -> list:
    """Write the named built-in scenes (all by default); returns the paths written."""
    out = Path(out_dir)
    paths = []
    for name in names or SCENES:
        blob = scene_to_trimesh(SCENES[name]()).export(file_type="glb")
        path = out / f"{name}.glb"
        with atomic_path(path, suffix=".glb") as tmp, open(tmp, "wb") as fh:
            fh.write(blob)
        paths.append(path)
    return paths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m eyelab.data_generators.scenes",
                                 description=_plain(__doc__.split("\n\n")[0]))
    ap.add_argument("out", help="output folder")
    ap.add_argument("--names", nargs="+", choices=sorted(SCENES), help="scenes to write")
    args = ap.parse_args(argv)
    for p in write_scenes(args.out, args.names):
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
