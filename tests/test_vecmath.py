"""The closed-form 2x2 SVD against LAPACK's (numpy.linalg.svd), on random matrices and on
the degenerate ones blur fields are full of: zero (in focus), rank one (a line blur),
equal singular values (a round blur), pure rotations and reflections."""

import numpy as np
import pytest

from eyelab.core.vecmath import svd2x2


def _cases():
    rng = np.random.default_rng(11)
    m = rng.normal(scale=10.0 ** rng.uniform(-6, 3, (4000, 1, 1)), size=(4000, 2, 2))
    t = rng.uniform(0, 2 * np.pi, 6)
    rot = np.stack([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]).transpose(2, 0, 1)
    special = [np.zeros((2, 2)), np.outer([1.0, 2.0], [3.0, -4.0]), np.eye(2) * 3.0,
               np.diag([2.0, 2.0]) @ rot[0], np.diag([1.0, -1.0]), np.diag([5.0, 0.0]),
               np.array([[0.0, 1e-12], [0.0, 0.0]])]
    return np.concatenate([m, rot, 2.5 * rot @ np.diag([1.0, -1.0]), np.stack(special)])


@pytest.mark.parametrize("batch_shape", [(), (3, 4)])
def test_svd2x2_matches_lapack_and_reconstructs(batch_shape):
    m = _cases()
    if batch_shape:
        m = m[:12].reshape(batch_shape + (2, 2))
    u, s, vt = svd2x2(m)
    scale = np.abs(m).max(axis=(-2, -1), keepdims=True) + 1e-300
    assert np.all(np.abs((u * s[..., None, :]) @ vt - m) <= 1e-12 * scale)
    eye = np.eye(2)
    assert np.allclose(u @ np.swapaxes(u, -1, -2), eye, atol=1e-13)
    assert np.allclose(vt @ np.swapaxes(vt, -1, -2), eye, atol=1e-13)
    ref = np.linalg.svd(m, compute_uv=False)
    assert np.all(np.abs(s - ref) <= 1e-12 * scale[..., 0])
    assert np.all(s[..., 0] >= s[..., 1]) and np.all(s >= 0)


def test_svd2x2_major_axis_is_the_blur_ellipses():
    """u's first column is the direction a unit seed is stretched most: |m^T u0| = s1."""
    m = _cases()
    u, s, _ = svd2x2(m)
    stretched = np.linalg.norm(np.swapaxes(m, -1, -2) @ u[..., :, :1], axis=(-2, -1))
    assert np.allclose(stretched, s[..., 0], rtol=1e-12, atol=1e-300)
