"""Free-form surfaces (a bicubic spline through a sag grid, exact derivatives) work in
every part of the engine: a free-form copy of a toric back surface gives the same traced
rays, wavefronts and analysis as the toric itself."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.surfaces import FreeForm, Sphere, Toric


@pytest.mark.parametrize("surface", [Toric(8.0, 12.0, 0.3), Toric(-20.0, -14.0, 1.2),
                                     Sphere(10.0), Sphere(-15.0)])
def test_curvatures_of_a_sampled_sphere_or_torus_to_1e_6(surface):
    """An 81 x 81 quintic free-form over 64 mm reproduces the principal curvatures to 1e-6
    relative (inside the grid, away from its last cell)."""
    f = FreeForm.from_surface(surface, 0.032, 81)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-0.028, 0.028, (2, 2000))
    k1, k2, *_ = surface.principal_curvatures(x, y)
    f1, f2, *_ = f.principal_curvatures(x, y)
    scale = np.abs(np.concatenate([k1, k2])).max()
    assert np.abs(f1 - k1).max() < 1e-6 * scale and np.abs(f2 - k2).max() < 1e-6 * scale
    a, b = surface.derivatives(x, y), f.derivatives(x, y)
    assert np.abs(a.z - b.z).max() < 1e-11                      # m
    out = f.derivatives(np.array([0.05]), np.array([0.0]))
    assert not out.valid[0] and np.isnan(out.z[0])


def test_a_free_form_back_surface_traces_like_the_toric():
    rx = Prescription(-4.0, -2.0, 30)
    lens = SpectacleLens.from_rx(rx)
    ff = FreeForm.from_surface(lens.back, lens.diameter / 2 + 0.004, 61)
    twin = SpectacleLens(lens.front, ff, lens.center_thickness, lens.material, lens.diameter,
                         lens.pose, lens.rx)
    obj = ObjectPoints.from_angles([np.inf, 0.5, 2.0], [0.0, 15.0, -25.0], [0.0, 10.0, 5.0])
    for fixation in ("fixed", "rotating"):
        a = analyze_points(Eye(), lens, obj, fixation=fixation)
        b = analyze_points(Eye(), twin, obj, fixation=fixation)
        assert (a.status == b.status).all() and (a.status == 0).all()
        np.testing.assert_allclose(b.chief.dir_in, a.chief.dir_in, atol=1e-9)
        for k in ("k11", "k12", "k22"):
            np.testing.assert_allclose(getattr(b.wave_eye, k), getattr(a.wave_eye, k),
                                       atol=1e-4)                  # D
    f1, f2, _ = twin.back_vertex_powers()
    assert (f1, f2) == pytest.approx(lens.back_vertex_powers()[:2], abs=1e-4)


def test_bad_grids_are_named_errors():
    g = np.linspace(-0.01, 0.01, 7)
    with pytest.raises(SpecError, match="6 x 6"):
        FreeForm(g[:3], g, np.zeros((7, 3)))
    with pytest.raises(SpecError, match="increase"):
        FreeForm(g[::-1], g, np.zeros((7, 7)))
    with pytest.raises(SpecError, match="finite"):
        FreeForm(g, g, np.full((7, 7), np.nan))
    with pytest.raises(SpecError, match="3 or 5"):
        FreeForm(g, g, np.zeros((7, 7)), degree=4)
