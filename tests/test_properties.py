"""Property tests over the whole parameter space: no NaN/inf anywhere, failures carry a
status, and symmetries hold."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.spectacle import LensPose, SpectacleLens
from eyelab.optics.rays.materials import CATALOGUE, Material
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.optics.rays.surfaces import Sphere, Toric
from eyelab.optics.rays.trace import FATAL

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

rx_st = st.builds(Prescription, st.floats(-20, 20), st.floats(-8, 0), st.floats(1, 180))
eye_st = st.builds(
    Eye, power_min=st.floats(52, 66), astigmatism=st.floats(0, 6),
    astigmatism_axis_deg=st.floats(0, 180), accommodation_max=st.floats(0, 12),
    pupil_diameter=st.floats(1e-3, 9e-3))
material_st = st.sampled_from([m for k, m in CATALOGUE.items() if k != "air"])
pose_st = st.builds(LensPose, vertex_distance=st.floats(0.008, 0.02),
                    pantoscopic_tilt_deg=st.floats(-15, 15), wrap_deg=st.floats(-10, 10),
                    decentration=st.tuples(st.floats(-0.005, 0.005), st.floats(-0.005, 0.005)))


def _objects(seed, n=40):
    rng = np.random.default_rng(seed)
    dist = 10 ** rng.uniform(math.log10(0.05), 3, n)
    dist[::7] = np.inf
    return ObjectPoints.from_angles(dist, rng.uniform(-40, 40, n), rng.uniform(-40, 40, n))


def _check_finite(res):
    for arr in (res.retina_matrix, res.accommodation, res.a, res.b, res.omega,
                res.wave_eye.k11, res.wave_eye.k12, res.wave_eye.k22, res.chief.residual[
                    (res.status & np.uint8(FATAL)) == 0]):
        assert np.isfinite(arr).all()
    assert ((res.status & ~np.uint8(0x3F)) == 0).all()  # only defined status bits
    ok = (res.status & np.uint8(FATAL)) == 0
    # every ray without a fatal status really converged
    assert (res.chief.residual[ok] <= 1e-8).all()


@SETTINGS
@given(rx=rx_st, eye=eye_st, material=material_st, pose=pose_st,
       fixation=st.sampled_from(["fixed", "rotating"]), seed=st.integers(0, 2**31))
def test_designed_lens_chain_never_produces_nan(rx, eye, material, pose, fixation, seed):
    try:
        lens = SpectacleLens.from_rx(rx, material=material, pose=pose)
    except SpecError:
        return  # a lens that cannot be made is refused with a clear error
    res = analyze_points(eye, lens, _objects(seed), fixation=fixation)
    _check_finite(res)


@SETTINGS
@given(c1=st.floats(-30, 45), c2=st.floats(-30, 70), c3=st.floats(-30, 70),
       axis=st.floats(0, math.pi), n=st.floats(1.45, 1.95), t=st.floats(0.0005, 0.012),
       seed=st.integers(0, 2**31))
def test_steep_high_index_lenses_flag_tir_and_misses(c1, c2, c3, axis, n, t, seed):
    try:
        lens = SpectacleLens(Sphere(c1), Toric(c2, c3, axis), t, Material("x", n, 30.0),
                             diameter=0.04)
    except SpecError as e:    # surfaces that cross inside the diameter: no lens
        assert e.field == "lens.center_thickness_mm" and "cross" in e.message
        return
    res = analyze_points(Eye(), lens, _objects(seed, 60))
    _check_finite(res)


@SETTINGS
@given(eye=eye_st, seed=st.integers(0, 2**31))
def test_naked_eye_never_produces_nan(eye, seed):
    _check_finite(analyze_points(eye, None, _objects(seed)))


def test_points_at_focal_distances_and_a_focus_in_the_air_gap():
    # points exactly at the far point of each meridian, and the eye focused there
    eye = Eye.from_rx(Prescription(-4.0, -2.0, 90), vertex_distance=0.0, accommodation_max=0)
    obj = ObjectPoints.from_angles([0.25, 1 / 6, 0.2], 0.0, 0.0)
    res = analyze_points(eye, None, obj)
    _check_finite(res)
    assert np.abs(res.a).min() < 1e-15 or np.abs(res.b).min() < 1e-15
    # a +105.6 D lens focuses 9.5 mm behind its back vertex, 2.5 mm before the eye: the wave
    # crosses a focal point in the air gap and arrives diverging, exactly as the vertex
    # formula F / (1 - d F) says (it holds through the focus)
    lens = SpectacleLens(Sphere(100.0), Sphere(-100.0), 0.003, Material("hi", 1.5),
                         diameter=0.010)
    res = analyze_points(Eye(), lens, ObjectPoints.from_angles(np.inf, 0.0, 0.0))
    _check_finite(res)
    fv = lens.back_vertex_powers()[0]
    assert 1 / fv < 0.012
    assert res.wave_eye.k11[0] == pytest.approx(fv / (1 - 0.012 * fv), rel=1e-9)
    assert res.wave_eye.k11[0] < 0


@SETTINGS
@given(eye=eye_st, rot=st.floats(0, 180), d=st.floats(0.1, 100))
def test_rotating_eye_axis_rotates_every_ellipse(eye, rot, d):
    turned = Eye(eye.power_min, eye.astigmatism, eye.astigmatism_axis_deg + rot,
                 eye.accommodation_max, eye.retina_distance, eye.n_vitreous, eye.pupil_diameter)
    obj = ObjectPoints.from_angles(d, 0.0, 0.0)
    m0 = analyze_points(eye, None, obj).retina_matrix[0]
    m1 = analyze_points(turned, None, obj).retina_matrix[0]
    r = math.radians(rot)
    rm = np.array([[math.cos(r), -math.sin(r)], [math.sin(r), math.cos(r)]])
    np.testing.assert_allclose(m1, rm @ m0 @ rm.T, atol=1e-12)
