"""The raster renderer's defaults show a large blur as blur, not as copies: the line spread
of a blurred edge (the derivative of the edge's profile, in linear light) at the default
quality has one peak — no secondary peak rising above 2 % of the step — and no dip below
-2 %.
The same edge without the reconstruction filter (S = 8 displaced copies) fails the check,
so the check can tell blur from ghosts."""

import numpy as np

from eyelab.core.color import srgb_to_linear
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import grid_quad
from eyelab.scene.scene import Scene

#: Secondary peaks and dips of the line spread allowed, as a fraction of the step.
TOLERANCE = 0.02


def _edge_scene(distance=1.0):
    """A black half-plane left of a white one, 1 m away, facing the eye (-z is forward)."""
    halves = []
    for name, x, grey in (("black", -0.15, 10), ("white", 0.15, 245)):
        n = 17 * 17
        halves.append(grid_quad(name, (x, 0.0, -distance), (1, 0, 0), (0, 1, 0), 0.3, 0.3,
                                colors=np.full((n, 3), grey, np.uint8)))
    return Scene(halves, background=(128, 128, 128), name="edge")


def _line_spread(quality):
    """(line spread (w - 1,), step) of the edge's profile: the mean of the middle rows, in
    linear light, differentiated across the columns."""
    eye = Eye.from_rx(Prescription(-4.0), accommodation_max=1.5, pupil_diameter=5e-3)
    view = View(width=160, height=120, fov_y_deg=6.0, near=0.1, far=5.0)
    with RasterRenderer(quality) as r:
        img = r.render(_edge_scene(), eye, None, view).srgb
    lin = srgb_to_linear(img[40:80].astype(float) / 255.0).mean(axis=(0, 2))
    return np.diff(lin), lin[-5:].mean() - lin[:5].mean()


def _secondary(lsf, step):
    """(the largest prominence of a secondary peak of the line spread — its height above the
    lowest point between it and the main peak —, the deepest dip below 0), as fractions
    of the step. One blur disc gives one hump (the reference renderer's: a half-ellipse);
    S copies of a sharp edge give S steps, the line spread S peaks."""
    k = int(np.argmax(lsf))
    inner = lsf[1:-1]
    is_max = (inner > lsf[:-2]) & (inner >= lsf[2:])
    prominence = [lsf[i] - lsf[min(i, k):max(i, k) + 1].min()
                  for i in np.flatnonzero(is_max) + 1 if i != k]
    return max(prominence, default=0.0) / step, -min(lsf.min(), 0.0) / step


def test_default_quality_blurs_an_edge_without_copies():
    lsf, step = _line_spread(RasterQuality())
    assert step > 0.8                              # the edge is in the view, black to white
    blur_px = step / lsf.max()                     # the edge's width, ~a disc's diameter
    assert blur_px > 12                            # a blur of many pixels, where copies show
    peak, dip = _secondary(lsf, step)
    assert peak < TOLERANCE and dip < TOLERANCE


def test_the_check_sees_copies_without_the_filter():
    lsf, step = _line_spread(RasterQuality(reconstruct=False))
    peak, _ = _secondary(lsf, step)
    assert peak > TOLERANCE
