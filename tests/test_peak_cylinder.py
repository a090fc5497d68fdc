"""A progressive lens's peak unwanted cylinder is found, not read off the maps' grid: from
a 2-degree map (31 x 31 over +-30 deg) it equals the largest value of a 0.5-degree map of
the same lens (121 x 121, traced point by point: brute force done another way) to within
what lies between the finer map's points, at the same eye rotation."""

import numpy as np
import pytest

from eyelab.optics.lens.asworn import as_worn_maps, peak_cylinder
from eyelab.spec import load_spec


@pytest.fixture(scope="module")
def pal():
    from pathlib import Path

    return load_spec(Path(__file__).resolve().parents[1] / "docs/gallery/pal_analytic.toml")


def test_the_peak_cylinder_is_found_between_grid_points(pal):
    coarse = as_worn_maps(pal.eye, pal.lens, half_angle_deg=30.0, n=31)
    fine = as_worn_maps(pal.eye, pal.lens, half_angle_deg=30.0, n=121)
    c = np.abs(fine.cylinder_d)
    j, i = np.unravel_index(int(np.nanargmax(c)), c.shape)
    d, (rx, ry) = peak_cylinder(coarse, pal.eye, pal.lens)
    assert d >= c[j, i] - 1e-6                          # never below a traced point
    assert d <= c[j, i] + 0.02                          # what 0.25 deg can hold
    assert abs(rx - fine.eye_rotation_x_deg[i]) <= 0.5 + 1e-9
    assert abs(ry - fine.eye_rotation_y_deg[j]) <= 0.5 + 1e-9
    assert d > np.nanmax(np.abs(coarse.cylinder_d))     # the 2-degree grid read it low
    assert abs(rx) <= 30 and abs(ry) <= 30
