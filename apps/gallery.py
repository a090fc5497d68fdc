"""Offscreen gallery of blur-field views for the docs (``python -m eyelab.apps.gallery OUT``).

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
                    "room seen through the spec's progressive lens at four gazes")
    ap.add_argument("--aberration-views", action="store_true", help="instead: write "
                    "aberrations.png, a chart seen by eyes with higher-order aberrations, "
                    "naked and through their lens")
    args = ap.parse_args(argv)
    from eyelab.render import use_offscreen

    use_offscreen()
    if args.pal_views:
        print(pal_views(args.pal_views, args.out))
        return 0
    if args.aberration_views:
        print(aberration_views(args.out))
        return 0
    from eyelab.render.gallery import write_gallery

    for path in write_gallery(args.out, window_size=tuple(args.size)):
        print(path)
    return 0


#: The eyes of aberrations.png: (label, OSA coefficients at 6 mm by (n, m), pupil mm).
ABERRATION_EYES = (
    ("0.3 um spherical aberration", {(4, 0): 0.3}, 5.0),
    ("0.3 um vertical coma", {(3, -1): 0.3}, 5.0),
    ("keratoconus-like: coma -1.2, trefoil 0.4,\nspherical -0.3 um", {
        (3, -1): -1.2, (3, -3): 0.4, (4, 0): -0.3}, 5.0),
    ("no higher orders, 2 mm pupil:\ndiffraction", {}, 2.0))


def aberration_views(out) -> str:
    """An ETDRS chart at 6 m (2 deg field) seen by a -1.00 D myope of 60 with each of
    :data:`ABERRATION_EYES`, naked (top) and through a lens for the Rx (bottom), as
    ``OUT/aberrations.png``."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from eyelab.imaging.contract import View
    from eyelab.imaging.options import RasterQuality
    from eyelab.optics.eye.aberrations import Aberrations
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.eye.zernike import j_from_nm
    from eyelab.optics.lens.spectacle import SpectacleLens
    from eyelab.render.raster import RasterRenderer
    from eyelab.scene.library import chart_scene

    scene = chart_scene(6.0)
    view = View(width=320, height=240, fov_y_deg=2.0, near=0.1, far=20.0)
    rx = Prescription(-1.0)
    lens = SpectacleLens.from_rx(rx)
    fig, axes = plt.subplots(2, len(ABERRATION_EYES), figsize=(3.4 * len(ABERRATION_EYES), 5.6),
                             constrained_layout=True)
    with RasterRenderer(RasterQuality()) as r:
        for col, (label, terms, pupil) in enumerate(ABERRATION_EYES):
            c = np.zeros(28)
            for (n, m), v in terms.items():
                c[j_from_nm(n, m)] = v
            eye = Eye.from_rx(rx, accommodation_max=1.0, pupil_diameter=pupil * 1e-3,
                              aberrations=Aberrations(tuple(c), 6.0))
            for row, ln in enumerate((None, lens)):
                ax = axes[row, col]
                ax.imshow(r.render(scene, eye, ln, view).srgb)
                ax.set_axis_off()
                ax.set_title(label if row == 0 else "through the -1.00 D lens", fontsize=9)
    path = Path(out) / "aberrations.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


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
