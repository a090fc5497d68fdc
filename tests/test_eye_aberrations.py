"""The eye's higher-order aberrations in renders (eyelab/imaging/eyepsf.py) against the
full-wave answer: a flat ETDRS chart at 4 m, its sharp image (the reference renderer, an
eye that focuses every point, 64 spp) convolved per channel with the FFT PSF of the pupil
function — the eye's defocus for the chart plus the higher orders over the render's pupil
(eyelab/optics/eye/psf.py, itself checked against a direct Fraunhofer integral in
tests/test_wave_psf.py). Also the spec's [eye.aberrations]: the second order as the Rx,
conflicts refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.core.color import encode_srgb
from eyelab.imaging.contract import View
from eyelab.imaging.eyepsf import channel_wavelengths, convolve_linear, sharp_eye, view_pitch_rad
from eyelab.imaging.options import RasterQuality, ReferenceQuality
from eyelab.optics.eye.aberrations import Aberrations, second_order
from eyelab.optics.eye.psf import psf
from eyelab.optics.eye.thin import Eye
from eyelab.reference.metrics import ssim
from eyelab.reference.tracer import ReferenceRenderer
from eyelab.render.raster import RasterRenderer
from eyelab.scene.library import chart_scene

DIST = 4.0
PUPIL = 5.0
VIEW = View(width=160, height=120, fov_y_deg=2.5, near=0.1, far=20.0)


@pytest.fixture(scope="module")
def scene():
    return chart_scene(DIST)


def _eye(rx, coma, sa):
    c = np.zeros(13)
    c[7], c[12] = coma, sa
    return Eye.from_rx(rx, accommodation_max=0.0, pupil_diameter=PUPIL * 1e-3, chromatic=False,
                       aberrations=Aberrations(tuple(c), 6.0))


def _truth(sharp_linear, eye, mean_d):
    """The sharp image convolved with the full-wave PSF of defocus ``mean_d`` (D, the
    wave's M = P - n2/z_r + v) plus the eye's higher orders over the render pupil."""
    c20, _, _ = second_order(mean_d, 0.0, mean_d, PUPIL)
    coef = np.zeros(28)
    hoa = eye.aberrations.wearer(PUPIL)
    coef[:len(hoa)] = hoa
    coef[4] += c20
    pitch = view_pitch_rad(VIEW)
    ks = [psf(coef, PUPIL, wl, pitch, 81)["psf"] for wl in channel_wavelengths()]
    return encode_srgb(convolve_linear(sharp_linear, [k / k.sum() for k in ks]))


@pytest.mark.parametrize("rx,coma,sa", [("-0.250752 DS", 0.08, 0.12),    # in focus at 4 m
                                        ("-0.50 DS", 0.08, 0.12),        # 0.25 D
                                        ("-1.25 DS", 0.08, 0.12),        # 0.98 D
                                        ("-2.00 DS", 0.10, 0.15)])       # 1.70 D
def test_a_naked_eye_with_aberrations_matches_the_full_wave_image(scene, rx, coma, sa):
    eye = _eye(rx, coma, sa)
    with ReferenceRenderer(ReferenceQuality(samples=64)) as r:
        sharp = r.render(scene, sharp_eye(eye), None, VIEW).linear
    truth = _truth(sharp, eye, (eye.power_min - eye.emmetropic_power) - 1.0 / DIST)
    for cls, q in ((RasterRenderer, RasterQuality()), (ReferenceRenderer,
                                                       ReferenceQuality(samples=64))):
        with cls(q) as r:
            res = r.render(scene, eye, None, VIEW)
        assert res.report["details"]["eye_aberrations"]["mode"].startswith("wave")
        score = ssim(res.srgb, truth)
        print(f"{rx}: {cls.name} SSIM {score:.4f} against the full-wave image")
        assert score >= 0.98


def test_through_a_lens_the_product_stays_close_to_the_full_wave_image(scene):
    """A -0.50 D lens for the -0.50 D eye leaves -0.25 D for the chart at 4 m (no
    accommodation); the product of the lens's geometric blur and the higher orders'
    kernel against the full wave at the image's centre defocus (the README's figures)."""
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.lens.spectacle import SpectacleLens

    eye = _eye("-0.50 DS", 0.08, 0.12)
    lens = SpectacleLens.from_rx(Prescription(-0.5))
    with ReferenceRenderer(ReferenceQuality(samples=64)) as r:
        sharp = r.render(scene, sharp_eye(eye), lens, VIEW).linear
    v_lens = -1.0 / (DIST + lens.pose.vertex_distance) - 0.5
    v_eye = v_lens / (1 - lens.pose.vertex_distance * v_lens)
    truth = _truth(sharp, eye, (eye.power_min - eye.emmetropic_power) + v_eye)
    scores = {}
    for cls, q in ((RasterRenderer, RasterQuality()), (ReferenceRenderer,
                                                       ReferenceQuality(samples=64))):
        with cls(q) as r:
            res = r.render(scene, eye, lens, VIEW)
        assert res.report["details"]["eye_aberrations"]["mode"].startswith("product")
        scores[cls.name] = ssim(res.srgb, truth)
    print(f"through the lens, product against full wave: {scores}")
    assert min(scores.values()) >= 0.9


def test_without_aberrations_nothing_is_applied(scene):
    eye = Eye.from_rx("-0.50 DS", accommodation_max=0.0, pupil_diameter=PUPIL * 1e-3)
    with RasterRenderer(RasterQuality(samples=1)) as r:
        res = r.render(scene, eye, None, VIEW)
    assert "eye_aberrations" not in res.report["details"]
    assert "eye_psf" not in res.report["timings_s"]


def test_the_spec_takes_the_second_order_as_the_rx_and_refuses_both():
    from eyelab.core.errors import SpecError
    from eyelab.optics.eye import zernike as zk
    from eyelab.optics.eye.thin import ocular_lca
    from eyelab.spec import parse_spec

    # an eye measured at 555 nm over 6 mm: -2.00 DS at the eye (ocular refraction)
    c20 = zk.power_vector_to_second_order(-2.0, 0.0, 0.0, 6.0)[0]
    spec = parse_spec({"eye": {"aberrations": {"coefficients_um": {"Z2_0": c20, "Z4_0": 0.1},
                                               "pupil_mm": 6.0, "wavelength_nm": 555.0}}})
    k = spec.eye.refraction()[0]                       # at the eye's reference wavelength
    assert k == pytest.approx(-2.0 - float(ocular_lca(555.0)), abs=1e-9)
    assert spec.eye.aberrations.coefficients_um[12] == 0.1
    assert spec.eye.aberrations.coefficients_um[4] == 0.0       # moved to the refraction
    for eye, field in (({"rx": "-1.00", "aberrations": {"coefficients_um": {"Z2_0": 0.3},
                                                        "pupil_mm": 6.0}}, "coefficients_um"),
                       ({"pupil_diameter_mm": 7.0, "aberrations": {
                           "coefficients_um": {"Z4_0": 0.1}, "pupil_mm": 6.0}},
                        "eye.pupil_diameter_mm"),
                       ({"aberrations": {"coefficients_um": {"Z5_2": 0.1}, "pupil_mm": 6.0}},
                        "coefficients_um"),
                       ({"aberrations": {"coefficients_um": [0.1], "pupil_mm": 0.5}},
                        "pupil_mm")):
        with pytest.raises(SpecError) as e:
            parse_spec({"eye": eye})
        assert field in e.value.field, e.value


def test_the_spec_reads_coefficients_from_a_file(tmp_path):
    from eyelab.spec import load_spec

    (tmp_path / "zernike.csv").write_text("# OSA j = 0 ...\n0, 0, 0\n0 0 0\n0 0.05 0 0\n"
                                          "0 0 0.12\n")
    (tmp_path / "eye.toml").write_text('[eye]\nrx = "-1.00"\n[eye.aberrations]\n'
                                       'file = "zernike.csv"\npupil_mm = 5.5\n')
    eye = load_spec(tmp_path / "eye.toml").eye
    assert eye.aberrations.coefficients_um[7] == 0.05
    assert eye.aberrations.coefficients_um[12] == 0.12


def test_the_psf_command_writes_the_psf_and_its_report(tmp_path, capsys):
    """`eyelab psf`: three channels' PSFs of the built-in spec's first point through its
    lens; the JSON's Strehl is the peak ratio the PSF module reports and its coefficients
    give back the same PSF; analyze reports the wave's RMS and Strehl; bad flags are one
    line each, nothing written."""
    import json

    from eyelab.apps.cli import main
    from eyelab.optics.eye.psf import ARCMIN

    out, js = tmp_path / "p.npy", tmp_path / "p.json"
    for flags in (["--no-lens"], []):
        assert main(["psf", "-o", str(out), "--json", str(js), "--size", "65", *flags]) == 0
        img, rep = np.load(out), json.loads(js.read_text())
        assert img.shape == (3, 65, 65) and rep["pitch_arcmin"] == 0.25
        ch = rep["channels"][1]
        again = psf(np.array(ch["coefficients_um"]), rep["pupil_mm"], ch["wavelength_nm"],
                    0.25 * ARCMIN, 65, integrate=True)    # the command's pixels: integrated
        if flags:              # the naked eye: the coefficients are the whole wave
            np.testing.assert_allclose(again["psf"], img[1], atol=1e-12)
            assert again["strehl"] == pytest.approx(ch["strehl"])
        else:                  # through the lens its real wave beyond them is added (the
            assert rep["lens_wave"] is not None     # 8 deg tilt's coma: tests/test_lenslet_psf)
            assert np.abs(again["psf"] - img[1]).sum() > 0.01
    for argv, field in ((["psf", "-o", str(tmp_path / "q.npy"), "--point", "9"], "--point"),
                        (["psf", "-o", str(tmp_path / "q.txt")], "--output"),
                        (["psf", "-o", str(tmp_path / "q.npy"), "--size", "64"], "--size")):
        assert main(argv) == 2
        assert field in capsys.readouterr().err
        assert not (tmp_path / "q.npy").exists()
    assert main(["analyze", "--json"]) == 0
    wave = json.loads(capsys.readouterr().out)["points"][0]["wave"]
    assert 0 < wave["strehl"] <= 1 and wave["rms_higher_orders_um"] == 0.0


def test_a_fixed_focus_is_applied_once(scene):
    """The naked eye in wave optics with the view's fixed focus at the accommodation Eq. 13
    picks for the chart anyway: the same image as without it (the sharp image is drawn
    without the fixed focus; the real eye's focus enters the wave once)."""
    import dataclasses

    c = np.zeros(13)
    c[12] = 0.1
    eye = Eye.from_rx("+0.50 DS", accommodation_max=3.0, pupil_diameter=PUPIL * 1e-3,
                      chromatic=False, aberrations=Aberrations(tuple(c), 6.0))
    acc = float(eye.accommodation_for(-1.0 / DIST))
    with RasterRenderer(RasterQuality(samples=1)) as r:
        free = r.render(scene, eye, None, VIEW).linear
        fixed = r.render(scene, eye, None, dataclasses.replace(VIEW, focus_d=acc)).linear
    assert acc > 0.5
    np.testing.assert_allclose(fixed, free, atol=2e-3)


def test_the_render_reports_rms_as_analyze_does_without_the_tilt():
    """Coma measured over 6 mm and rendered over 4 mm leaks into tilt (which moves the
    image, not blurs it): the render's rms_um leaves the tilt out, as analyze's does, and
    keeps the defocus spherical aberration leaks into."""
    from eyelab.optics.eye import zernike as zk

    c = np.zeros(13)
    c[zk.j_from_nm(3, 1)] = 0.4
    c[zk.j_from_nm(4, 0)] = 0.2
    ab = Aberrations(tuple(c), pupil_mm=6.0)
    w = ab.wearer(4.0)
    tilt = np.hypot(w[zk.j_from_nm(1, 1)], w[zk.j_from_nm(1, -1)])
    assert tilt > 0.05                                        # the leak is real
    assert ab.rms_um(4.0) == pytest.approx(zk.rms(w, from_order=2), abs=1e-12)
    assert ab.rms_um(4.0) < zk.rms(w) - 1e-3                  # the tilt is left out
    assert abs(w[zk.j_from_nm(2, 0)]) > 0.01                  # defocus leaked, and counted
    assert ab.rms_um(4.0) > zk.rms(w, from_order=3)
