import numpy as np
import pytest

from eyelab.blur import VoxelStatus, compute_blur_field
from eyelab.blur.bundle import compute_blur_field_bundles, traverse
from eyelab.core.errors import SpecError
from eyelab.core.sampling import disc_seeds
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.camera import eye_camera


def test_traversal_visits_exactly_the_voxels_a_dense_sampling_finds():
    rng = np.random.default_rng(4)
    shape = (7, 5, 6)
    g0 = rng.uniform(-2, 9, (300, 3))
    g1 = rng.uniform(-2, 9, (300, 3))
    ray, k, j, i, lin, lout = traverse(g0, g1, shape)
    assert (lout >= lin).all()
    lam = np.linspace(0, 1, 20001)
    for r in range(300):
        p = g0[r] + lam[:, None] * (g1[r] - g0[r])
        inside = np.all((p >= 0) & (p < [6, 5, 7]), axis=1)
        cells = {tuple(c) for c in np.floor(p[inside]).astype(int)[:, ::-1]}
        got = set(zip(k[ray == r], j[ray == r], i[ray == r], strict=True))
        # dense sampling can miss a voxel only clipped by a corner (< 1/20000 of the segment)
        assert cells <= got
        assert len(got - cells) <= 2
        # visits along one ray are contiguous in the segment parameter
        li, lo = lin[ray == r], lout[ray == r]
        np.testing.assert_allclose(li[1:], lo[:-1])


def test_disc_seeds_fill_the_unit_disc_evenly():
    s = disc_seeds(256)
    assert (np.hypot(*s.T) <= 1).all()
    # second moment of a uniform unit disc: E[x^2] = E[y^2] = 1/4
    np.testing.assert_allclose((s**2).mean(0), 0.25, atol=0.005)
    np.testing.assert_allclose(s.mean(0), 0.0, atol=0.01)


@pytest.mark.parametrize("rx, amp, wl", [("-2.00 DS", 2.0, 587.56), ("+1.00 DS", 0.5, 587.56),
                                         ("-5.00 DS", 0.0, 587.56),
                                         ("+1.00 DS", 0.5, 486.13)])
def test_bundle_method_agrees_with_wavefront_method_for_the_naked_spherical_eye(rx, amp, wl):
    """Both methods are exact for a naked spherical eye up to sampling: the bundle method
    samples visit midpoints (= slice centres along a column ray in NDC) and averages 4
    reference rays per column. Documented tolerance: 0.5 % of the blur, or 0.05 arcmin,
    away from the near/far points (one slice either side). Away from the eye's reference
    wavelength both apply its chromatic aberration."""
    eye = Eye.from_rx(Prescription.parse(rx), accommodation_max=amp, pupil_diameter=5e-3)
    cam = eye_camera(fov_y_deg=40.0, near=0.1, far=20.0)
    shape = (48, 12, 12)
    f1 = compute_blur_field(eye, None, cam, shape=shape, wavelength_nm=wl)
    f2 = compute_blur_field_bundles(eye, None, cam, shape=shape, wavelength_nm=wl)
    assert f2.report["voxels_unvisited"] == 0
    zero = f1.major_arcmin < 1e-9
    edge = zero ^ np.roll(zero, 1, 0) | zero ^ np.roll(zero, -1, 0)
    sel = ~edge
    sel[0] = sel[-1] = False
    diff = np.abs(f1.major_arcmin - f2.major_arcmin)[sel]
    assert np.all(diff <= np.maximum(0.005 * f1.major_arcmin[sel], 0.05))
    # and the matrices themselves, including sign (same pupil -> displacement convention)
    np.testing.assert_allclose(f2.matrix[sel], f1.matrix[sel], atol=2e-3 * np.abs(
        f1.matrix).max())


def test_bundle_method_through_a_lens_is_close_to_the_wavefront_method():
    rx = Prescription(-3.0)
    eye = Eye.from_rx(rx, accommodation_max=1.0)
    lens = SpectacleLens.from_rx(Prescription(-2.0))     # under-corrected by 1 D
    f1 = compute_blur_field(eye, lens, shape=(32, 8, 8))
    f2 = compute_blur_field_bundles(eye, lens, f1.camera, shape=(32, 8, 8))
    ok = (f1.status == VoxelStatus.OK) & (f2.status == VoxelStatus.OK)
    big = ok & (f1.major_arcmin > 2.0)
    rel = np.abs(f2.major_arcmin - f1.major_arcmin)[big] / f1.major_arcmin[big]
    assert big.sum() > 500
    # the bundle method spans the real 4 mm pupil (aberrations included) and averages
    # reference rays across the voxel: a few per cent (documented in the README)
    assert np.median(rel) < 0.02
    assert np.percentile(rel, 95) < 0.06


def test_bundle_method_rejects_bad_arguments():
    with pytest.raises(SpecError, match="samples"):
        compute_blur_field_bundles(Eye(), None, shape=(8, 2, 2), samples=1)
