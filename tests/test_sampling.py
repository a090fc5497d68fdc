"""Sample sets are physics: the pass seeds have the unit disc's mean and covariance at
every S, the jitter is zero-mean and uncorrelated with them, and an in-focus image is
antialiased like the box-filtered reference."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.core.sampling import antialias_jitter, disc_seeds, pass_samples


@pytest.mark.parametrize("samples", range(3, 65))
def test_seeds_have_the_disc_moments_exactly(samples):
    s, j = pass_samples(samples)
    assert s.shape == j.shape == (samples, 2)
    np.testing.assert_allclose(s.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(s.T @ s / samples, np.eye(2) / 4, atol=1e-12)
    np.testing.assert_allclose(j.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(s.T @ j, 0.0, atol=1e-12)        # jitter does not skew
    assert np.abs(j).max() < 0.75          # R2 offsets, decorrelated from the seeds


def test_two_seeds_are_antithetic_with_the_disc_trace():
    """No 2-point set is isotropic; the pair keeps the mean (0) and the trace (1/2)."""
    s, _ = pass_samples(2)
    np.testing.assert_allclose(s.mean(axis=0), 0.0, atol=1e-15)
    assert np.trace(s.T @ s / 2) == pytest.approx(0.5)


@pytest.mark.parametrize("samples", [8, 12, 16, 32, 64, 100])
def test_progressive_prefixes_are_exact(samples):
    """S a multiple of 4: every power-of-two prefix >= 4 has mean 0 and covariance I/4."""
    s, _ = pass_samples(samples)
    p = 4
    while p < samples:
        np.testing.assert_allclose(s[:p].mean(axis=0), 0.0, atol=1e-12)
        np.testing.assert_allclose(s[:p].T @ s[:p] / p, np.eye(2) / 4, atol=1e-12)
        p *= 2


@pytest.mark.parametrize("samples", [5, 6, 7, 10, 11, 18, 34])
def test_other_prefixes_are_unbiased(samples):
    """S not a multiple of 4 (whitened as a whole): even prefixes keep mean 0."""
    s, _ = pass_samples(samples)
    for p in (2, 4, 8, 16, 32):
        if p < samples:
            np.testing.assert_allclose(s[:p].mean(axis=0), 0.0, atol=1e-12)


@pytest.mark.parametrize("samples", [4, 5, 8, 10, 16, 33])
def test_the_passes_are_centrally_symmetric(samples):
    """Every (seed, jitter) pass has its opposite: odd moments vanish, so a blurred edge is
    half-way exactly at the edge."""
    s, j = pass_samples(samples)
    p = np.hstack([s, j])
    for q in -p:
        assert np.abs(p - q).sum(axis=1).min() < 1e-12


def test_the_vogel_spiral_was_biased_and_these_are_not():
    """The old seed set (Vogel's spiral) at S = 8 renders a circular blur 21 % elongated;
    the new one is isotropic (eigenvalue ratio 1)."""
    old = disc_seeds(8)
    ev = np.linalg.eigvalsh(old.T @ old / 8 - np.outer(old.mean(0), old.mean(0)))
    assert ev[1] / ev[0] > 1.2
    new, _ = pass_samples(8)
    ev = np.linalg.eigvalsh(new.T @ new / 8)
    assert ev[1] / ev[0] == pytest.approx(1.0, abs=1e-12)


def test_antialias_jitter_is_zero_mean_and_inside_the_pixel():
    for n in (2, 7, 16, 64):
        j = antialias_jitter(n)
        np.testing.assert_allclose(j.mean(axis=0), 0.0, atol=1e-15)
        assert np.abs(j).max() < 0.75
        assert len(np.unique(j.round(9), axis=0)) == n


def test_in_focus_checkerboard_edges_match_the_reference():
    """An in-focus, slightly rotated checkerboard: raster S = 16 (jitter-only passes) and
    the reference at 256 spp (box-filtered pixels) put every edge at the same sub-pixel
    position, < 0.05 px rms."""
    from eyelab.imaging.contract import View
    from eyelab.imaging.options import RasterQuality, ReferenceQuality
    from eyelab.imaging.registry import make_renderer
    from eyelab.optics.eye.thin import Eye
    from eyelab.scene.scene import Scene, SceneMesh

    a = np.radians(7.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    meshes = []
    n, size = 6, 0.03
    for i in range(n):
        for k in range(n):
            x0, y0 = (i - n / 2) * size, (k - n / 2) * size
            sq = np.array([[x0, y0], [x0 + size, y0], [x0 + size, y0 + size], [x0, y0 + size]])
            xy = sq @ rot.T
            v = np.column_stack([xy, np.full(4, -1.0)])
            c = 255 if (i + k) % 2 else 0
            meshes.append(SceneMesh(f"sq{i}{k}", v, [[0, 1, 2], [0, 2, 3]],
                                    colors=np.array([c, c, c], np.uint8)))
    scene = Scene(meshes, background=(128, 128, 128), name="checker")
    eye = Eye(accommodation_max=5.0, chromatic=False)      # in focus in every channel
    view = View(width=96, height=96, fov_y_deg=8.0, near=0.2, far=5.0)
    imgs = {}
    for name, q in (("raster", RasterQuality(samples=16, refine=False)),
                    ("reference", ReferenceQuality(samples=256))):
        with make_renderer(name, q) as r:
            imgs[name] = r.render(scene, eye, None, view).linear[..., 1].astype(float)

    def crossings(img):
        out = {}
        for y in range(10, 86):
            row = img[y, 10:86]
            for x in range(len(row) - 1):
                a0, a1 = row[x] - 0.5, row[x + 1] - 0.5
                if a0 * a1 < 0 and abs(row[x + 1] - row[x]) > 0.5:
                    out[(y, x)] = x + a0 / (a0 - a1)
        return out

    ra, rf = crossings(imgs["raster"]), crossings(imgs["reference"])
    common = sorted(set(ra) & set(rf))
    assert len(common) > 200
    d = np.array([ra[k] - rf[k] for k in common])
    print("edge rms", np.sqrt(np.mean(d**2)), len(common))
    assert np.sqrt(np.mean(d**2)) < 0.05, np.sqrt(np.mean(d**2))
