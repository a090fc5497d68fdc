"""Offscreen gallery of blur-field views for the README (``python -m eyelab.apps.gallery OUT``).

Writes: ``blurfield_volume.png`` (the naked field of a myopic presbyope as a volume over
the view frustum), ``blurfield_glyphs.png`` (Sturm-conoid ellipses of an astigmatic
naked eye at 6-11 cm, as in Kakimoto Fig. 12), ``sturm_conoid.png`` (one point's conoid
inside the eye) and the datasets as ``.vti`` / ``.vtp`` for ParaView.
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m eyelab.apps.gallery")
    ap.add_argument("out", help="output folder")
    ap.add_argument("--size", type=int, nargs=2, default=(800, 600), metavar=("W", "H"))
    args = ap.parse_args(argv)
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
    from eyelab.render.gallery import write_gallery

    for path in write_gallery(args.out, window_size=tuple(args.size)):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
