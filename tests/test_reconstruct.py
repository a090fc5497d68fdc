"""The reconstruction filter keeps the blur's second moments: the variance-compensated
matrices plus the blur-shaped filter (checked through the covariance's
eigen-decomposition, not the SVD the code uses) and the filters themselves (checked on a
point's spread). The rendered check is in test_raster (the dot test, reconstructed)."""

import dataclasses

import numpy as np
import pytest

from eyelab.blur.reconstruct import (
    compensated,
    directional_gaussian,
    pixel_svd,
    sigma_volume,
    variable_gaussian,
)


@dataclasses.dataclass
class _Field:
    """A stand-in with what the functions read of a second-order field."""

    matrix: np.ndarray
    key: str = "f"
    aberration: None = None

    def blur_matrix(self):
        return self.matrix


@pytest.mark.parametrize("passes", [2, 8, 32])
def test_compensated_matrix_plus_filter_keeps_the_blur_covariance(passes):
    """Random blur matrices (NDC per unit seed; round to line-like ellipses) in a 640 x 480
    window: in pixels, B' (I/4) B'^T + the filter's covariance (sigma_major^2 along the
    blur's major axis, sigma_minor^2 across) equals B (I/4) B^T to 1e-9 in every voxel;
    the filter's axis is the blur's; the major sigma is at most sqrt(0.4) of its
    semi-axis / 2, the minor at most its semi-axis / 2."""
    rng = np.random.default_rng(3)
    size = (640, 480)
    px = np.diag([size[0] / 2, size[1] / 2])
    m = rng.normal(scale=0.02, size=(4, 5, 6, 2, 2))
    m[0, 0] = np.outer([0.05, 0.1], [1.0, 0.0])          # a line blur (rank 1), ~29 px
    svd = pixel_svd(_Field(m), size)
    vol = sigma_volume([svd], passes)
    out = compensated(_Field(m), svd, vol, size).matrix
    cov = px @ m @ np.swapaxes(m, -1, -2) @ px / 4
    ev, vec = np.linalg.eigh(cov)
    major_dir = vec[..., :, 1]
    u = vol["u"]
    assert np.all(np.abs(np.sum(u * major_dir, -1))[ev[..., 1] > 1.01 * ev[..., 0]]
                  > 1 - 1e-9)
    uu = u[..., :, None] * u[..., None, :]
    filt = (vol["major"][..., None, None] ** 2 * uu
            + vol["minor"][..., None, None] ** 2 * (np.eye(2) - uu))
    cov2 = px @ out @ np.swapaxes(out, -1, -2) @ px / 4 + filt
    np.testing.assert_allclose(cov2, cov, rtol=1e-9, atol=1e-9 * ev.max())
    assert np.all(vol["minor"] <= vol["major"])
    assert np.all(vol["major"] ** 2 <= 0.4 * ev[..., 1] + 1e-12)
    assert np.all(vol["minor"] ** 2 <= ev[..., 0] + 1e-12)
    assert vol["major"][0, 0].max() > 0.25 and vol["minor"][0, 0].max() == 0.0


@pytest.mark.parametrize("sigma", [0.3, 0.5, 1.0, 2.0, 4.1])
def test_variable_gaussian_spreads_a_point_by_sigma_squared(sigma):
    """A point filtered with a uniform sigma between two of the filter's levels spreads
    with variance sigma^2 per axis within 1 % and keeps its light (a blend linear in sigma
    instead of sigma^2 would be 12 % too wide at 2.0)."""
    img = np.zeros((81, 81, 3), np.float32)
    img[40, 40] = 1.0
    out = variable_gaussian(img, np.full((81, 81), sigma))[..., 0].astype(float)
    assert out.sum() == pytest.approx(1.0, rel=1e-4)
    ys, xs = np.mgrid[:81, :81]
    var_x = (out * (xs - 40) ** 2).sum() / out.sum()
    var_y = (out * (ys - 40) ** 2).sum() / out.sum()
    assert var_x == pytest.approx(sigma**2, rel=0.01)
    assert var_y == pytest.approx(sigma**2, rel=0.01)


@pytest.mark.parametrize("sigma", [1.0, 2.5, 6.0])
@pytest.mark.parametrize("angle", [0.0, 30.0, 90.0, 135.0])
def test_directional_gaussian_spreads_a_line_along_its_direction(sigma, angle):
    """A line across the image, filtered along a direction: the light's variance along the
    filter's direction's component normal to the line is sigma^2 (sin of the angle
    between them)^2 within 2 % + the bilinear taps' quarter pixel^2 (gathering: each pixel
    averages along its own u, so a line, not a point, is what it spreads exactly)."""
    n = 121
    img = np.zeros((n, n, 3), np.float32)
    img[:, n // 2] = 1.0                                   # a vertical line at column 60
    t = np.radians(angle)
    u = np.broadcast_to(np.array([np.cos(t), np.sin(t)]), (n, n, 2))
    out = directional_gaussian(img, np.full((n, n), sigma), u)[..., 0].astype(float)
    prof = out[n // 4: 3 * n // 4].mean(axis=0)           # away from the top and bottom
    x = np.arange(n) - n // 2
    var = (prof * x**2).sum() / prof.sum()
    expect = (sigma * np.cos(t)) ** 2
    assert prof.sum() == pytest.approx(1.0, rel=1e-3)
    assert abs(var - expect) <= 0.02 * expect + 0.25


@pytest.mark.parametrize("layout", ["patch", "edge", "corner", "line"])
def test_filtering_the_region_alone_gives_the_whole_images_values(layout):
    """What a frame does (eyelab.render.raster): filter only filtered_region's padded box
    and paste its inner box — the same pixels as filtering the whole image (to float32
    summation order), and no pixel outside the box changes in the whole-image filter."""
    from eyelab.blur.reconstruct import filtered_region, reconstruct

    rng = np.random.default_rng(5)
    h, w = 120, 160
    img = rng.random((h, w, 3)).astype(np.float32)
    minor, line = np.zeros((h, w)), np.zeros((h, w))
    ang = rng.uniform(0, np.pi, (h, w))
    u = np.stack([np.cos(ang), np.sin(ang)], -1)
    if layout == "patch":
        minor[40:70, 60:100] = rng.uniform(0.3, 4.0, (30, 40))
    elif layout == "edge":                      # at the image's left and top edges
        minor[:30, :25] = 3.5
    elif layout == "corner":
        minor[100:, 140:] = 1.2
        line[100:, 140:] = 2.5
    else:
        line[60, 20:140] = 6.0
    sig = {"minor": minor, "line": line, "u": u}
    whole = reconstruct(img, sig)
    (y0, y1, x0, x1), (py0, py1, px0, px1) = filtered_region(minor, line)
    crop = reconstruct(img[py0:py1, px0:px1], {k: v[py0:py1, px0:px1] for k, v in sig.items()})
    out = img.copy()
    out[y0:y1, x0:x1] = crop[y0 - py0:y1 - py0, x0 - px0:x1 - px0]
    assert np.abs(out - whole).max() < 1e-5
    changed = np.abs(whole - img).max(-1) > 0
    assert changed[y0:y1, x0:x1].sum() == changed.sum() > 0


def test_nothing_to_filter_has_no_region():
    from eyelab.blur.reconstruct import MIN_LINE_SIGMA, MIN_SIGMA, filtered_region

    z = np.zeros((8, 8))
    assert filtered_region(z, z) is None
    assert filtered_region(z + 0.9 * MIN_SIGMA, z + 0.9 * MIN_LINE_SIGMA) is None
