"""``eyelab psf`` of a schematic eye (eyelab.optics.chain.retinal_psf) and of one eye of two,
against independent truths.

- The geometric spot of the same point: forward rays from the object through a grid over
  the entrance pupil, through the lens and every surface of the eye to the retina, mapped
  to visual angle by the eye's own lines of sight 1 px apart (eyelab.reference.spots, the
  truth of the retinal-image tests): the PSF's encircled-energy radii, where defocus
  dominates diffraction, are the spot's within a few per cent (diffraction softens the
  caustic at the blur's rim: measured 0.3-2.3 % at 50 %, 4-5 % at 80 %, naked or behind a
  lens, on the axis and 20-25 deg off it).
- The Strehl ratio of ``analyze`` (the reversed wave, a point source on the retina, its
  peak by an exact sum over the stop): the PSF's (the forward wave, an FFT) within 0.005.
- Two eyes: a side's PSF is the one-eye PSF of that eye and lens at the accommodation
  both share; the refusals name the flag.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from eyelab.core.errors import SpecError
from eyelab.imaging.contract import View
from eyelab.jobs.api import as_spec
from eyelab.jobs.psf import point_psf
from eyelab.reference.spots import point_spot

GREEN = 546.07


def _ee(radii_weights, fractions):
    r, w = radii_weights
    o = np.argsort(r)
    cum = np.cumsum(w[o]) / w.sum()
    return np.array([np.interp(f, cum, r[o]) for f in fractions])


def psf_ee(img, pitch, fractions):
    """Encircled-energy radii (arcmin) of an image about its centroid."""
    n = img.shape[0]
    c = (np.arange(n) - n // 2) * pitch
    yy, xx = np.meshgrid(c, c, indexing="ij")
    w = img / img.sum()
    mx, my = (w * xx).sum(), (w * yy).sum()
    return _ee((np.hypot(xx - mx, yy - my).ravel(), w.ravel()), fractions)


def spot_ee(spec, field, fractions):
    """Encircled-energy radii (arcmin) of the geometric spot of point ``field`` (deg, at
    infinity) seen by the spec's eye turned to it."""
    view = View(width=201, height=201, fov_y_deg=200 / 60.0, gaze_deg=field)
    d = np.array([math.tan(math.radians(field[0])), math.tan(math.radians(field[1])), -1.0])
    sp = point_spot(spec.eye, spec.lens, view, 1e6 * d / np.linalg.norm(d), 0.0, GREEN)
    arcmin = 2 * math.tan(math.radians(view.fov_y_deg / 2)) / view.height * 180 / math.pi * 60
    p, w = sp["px"] * arcmin, sp["weight"]
    m = (p * w[:, None]).sum(0) / w.sum()
    return _ee((np.hypot(*(p - m).T), w), fractions)


@pytest.mark.parametrize(("lens_rx", "field"), [(None, (0, 0)), ("-1.00", (0, -20)),
                                                ("-1.00", (25, 0))])
def test_a_schematic_eyes_psf_spreads_as_its_rays_do(lens_rx, field):
    """A -3 D Navarro myope, naked or behind a -1.00 lens, turned to the point: 3 or 2 D
    of defocus (blur 16 or 11' across at 50 %)."""
    d = {"eye": {"model": "navarro", "rx": "-3.00", "pupil_diameter_mm": 4,
                 "accommodation_d": 0},
         "points": [{"field_deg": list(field)}], "analysis": {"fixation": "rotating"}}
    if lens_rx:
        d["lens"] = {"rx": lens_rx}
    spec = as_spec(d)
    img, rep = point_psf(spec, pitch_arcmin=1.0, size=129)
    assert rep["eye_model"] == "navarro" and rep["channels"][1]["energy_inside"] > 0.99
    got = psf_ee(img[1], 1.0, (0.5, 0.8))
    want = spot_ee(spec, field, (0.5, 0.8))
    assert abs(got[0] / want[0] - 1) < 0.03, (got, want)
    assert abs(got[1] / want[1] - 1) < 0.07, (got, want)


def test_a_schematic_eyes_psf_strehl_is_analyzes():
    """examples/myope.toml's point 2 (20 deg off the fixating eye's axis, through its -3.00
    lens): the PSF's Strehl ratio at 546 nm against analyze's at the same wavelength
    (measured 0.0612 and 0.0602)."""
    from eyelab.jobs.analyze import analyze_spec
    from eyelab.spec import load_spec

    spec = dataclasses.replace(load_spec("examples/myope.toml"), wavelength_nm=GREEN)
    _, rep = point_psf(spec, point=2, size=33)
    green = rep["channels"][1]
    assert green["wavelength_nm"] == GREEN
    assert green["strehl"] == pytest.approx(analyze_spec(spec)["points"][2]["strehl"],
                                            abs=0.005)


def test_one_eye_of_two_is_that_eye_at_the_shared_accommodation():
    """An anisometrope (-2 / -1 D, no lenses) looking at a point 2 m away: the left eye's
    PSF is the one-eye PSF of the left eye with the accommodation the pair shares (the
    less-blurred eye's); a two-eye spec without --eye, and --eye of a one-eye spec, are
    one-line refusals naming it."""
    from eyelab.optics.chain.binocular import analyze_binocular

    two = as_spec({"eye": {"right": {"rx": "-2.00"}, "left": {"rx": "-1.00"},
                           "pupil_diameter_mm": 3},
                   "binocular": {}, "points": [{"distance_m": 2.0, "field_deg": [0, 0]}]})
    left, rep = point_psf(two, side="left", size=33)
    acc = float(analyze_binocular(two.binocular, two.points)["accommodation_d"][0])
    b = two.binocular
    one = dataclasses.replace(two, eye=b.left, lens=b.left_lens, binocular=None,
                              points=b.points_for("left", two.points), accommodation=acc)
    alone, _ = point_psf(one, size=33)
    np.testing.assert_array_equal(left, alone)
    assert rep["side"] == "left"
    with pytest.raises(SpecError, match="--eye"):
        point_psf(two, size=33)
    with pytest.raises(SpecError, match="--eye"):
        point_psf(one, side="right", size=33)


def test_analyze_and_psf_refuse_a_camera_spec_by_name():
    """A camera lens has no eye: the API refuses as the commands do (it used to return the
    default eye's numbers)."""
    import eyelab

    cam = {"render": {"renderer": "reference", "camera": "doublet"}}
    assert as_spec(cam).render.camera is not None
    for call in (eyelab.analyze, eyelab.psf):
        with pytest.raises(SpecError, match="render.camera: .*camera lens, which has no eye"):
            call(cam)
