"""The reconstruction filter keeps the blur's second moments: the variance-compensated
matrices (checked through the covariance's eigen-decomposition, not the SVD the code
uses) and the per-pixel Gaussian (checked on a point's spread)."""

import numpy as np
import pytest

from eyelab.blur.reconstruct import compensated, variable_gaussian


def _field(matrix):
    """A stand-in with the two attributes :func:`compensated` reads."""
    import dataclasses

    @dataclasses.dataclass
    class F:
        matrix: np.ndarray
        key: str = "f"

    return F(matrix)


def test_compensated_matrix_plus_gaussian_keeps_the_blur_covariance():
    """Random matrices (NDC per unit seed) in a 640 x 480 window: in pixels,
    B' (I/4) B'^T + sigma^2 I equals B (I/4) B^T to 1e-9 wherever the blur's smaller
    variance exceeds sigma^2; where only the larger one does, it is still exact and the
    smaller one is sigma^2 (the documented residual); where neither does, the Gaussian
    alone remains (both sigma^2). The major axis keeps its direction."""
    rng = np.random.default_rng(3)
    size = (640, 480)
    px = np.diag([size[0] / 2, size[1] / 2])
    m = rng.normal(scale=0.02, size=(4, 5, 6, 2, 2))
    sigma = rng.uniform(0.2, 4.0, size=(4, 5, 6))
    out = compensated(_field(m), sigma, size).matrix
    cov = px @ m @ np.swapaxes(m, -1, -2) @ px / 4
    cov2 = px @ out @ np.swapaxes(out, -1, -2) @ px / 4 + sigma[..., None, None] ** 2 * np.eye(2)
    ev, vec = np.linalg.eigh(cov)
    ev2 = np.linalg.eigvalsh(cov2)
    exact = ev[..., 0] >= sigma**2
    minor_only = ~exact & (ev[..., 1] >= sigma**2)
    neither = ev[..., 1] < sigma**2
    for regime in (exact, minor_only, neither):       # all three are exercised
        assert regime.sum() >= 5
    np.testing.assert_allclose(cov2[exact], cov[exact], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ev2[minor_only][:, 1], ev[minor_only][:, 1], rtol=1e-9)
    np.testing.assert_allclose(ev2[minor_only][:, 0], sigma[minor_only] ** 2, rtol=1e-9)
    np.testing.assert_allclose(ev2[neither], (sigma[neither] ** 2)[:, None] * [1, 1],
                               rtol=1e-9)
    # the major axis keeps its direction
    major = vec[..., :, 1]
    major2 = np.linalg.eigh(cov2)[1][..., :, 1]
    ok = (ev[..., 1] > 1.01 * ev[..., 0]) & ~neither
    assert np.all(np.abs(np.sum(major * major2, -1))[ok] > 1 - 1e-9)


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
