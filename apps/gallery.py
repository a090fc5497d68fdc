"""Offscreen gallery of blur-field views for the README (``python -m eyelab.apps.gallery OUT``).

Writes: ``blurfield_volume.png`` (the naked field of a myopic presbyope as a volume over
the view frustum), ``blurfield_glyphs.png`` (Sturm-conoid ellipses of an astigmatic
naked eye at 6-11 cm, as in Kakimoto Fig. 12), ``sturm_conoid.png`` (one point's conoid
inside the eye) and the datasets as ``.vti`` / ``.vtp`` for ParaView.
"""

from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m eyelab.apps.gallery")
    ap.add_argument("out", help="output folder")
    ap.add_argument("--size", type=int, nargs=2, default=(800, 600), metavar=("W", "H"))
    ap.add_argument("--pal-views", metavar="SPEC", help="instead: write pal_views.png, the "
                    "room seen through the spec's progressive lens at three gazes")
    args = ap.parse_args(argv)
    from eyelab.render import use_offscreen

    use_offscreen()
    if args.pal_views:
        print(pal_views(args.pal_views, args.out))
        return 0
    from eyelab.render.gallery import write_gallery

    for path in write_gallery(args.out, window_size=tuple(args.size)):
        print(path)
    return 0


#: Gazes (right, up; deg) through a progressive lens: distance zone, near zone, lower side.
PAL_GAZES = (("distance zone: 5 deg up", (0.0, 5.0)),
             ("corridor: 16 deg down", (-2.0, -16.0)),
             ("near zone: 28 deg down", (-5.0, -28.0)),
             ("lower side: 28 down, 25 right", (25.0, -28.0)))


def pal_views(spec_path, out) -> str:
    """The room through the spec's progressive lens at :data:`PAL_GAZES` (Kakimoto Fig. 11's
    experiment), side by side with labels, as ``OUT/pal_views.png``."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from eyelab.imaging.registry import make_renderer
    from eyelab.jobs.render import build_scene
    from eyelab.spec import load_spec

    spec = load_spec(spec_path)
    rs = spec.render.with_changes(width=400, height=300, samples=16)
    scene = build_scene(rs.scene)
    panels = []
    with make_renderer(rs.renderer, rs.quality) as r:
        for label, gaze in PAL_GAZES:
            view = rs.with_changes(gaze_deg=list(gaze)).view
            panels.append((label, r.render(scene, spec.eye, spec.lens, view).srgb))
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.4),
                             constrained_layout=True)
    for ax, (label, img) in zip(axes, panels, strict=True):
        ax.imshow(np.asarray(img))
        ax.set_title(label)
        ax.set_axis_off()
    path = Path(out) / "pal_views.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


if __name__ == "__main__":
    sys.exit(main())
