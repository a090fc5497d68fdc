"""Batch jobs with two eyes (and a camera lens): per-eye keys swept by their dotted names,
each job's image the one ``eyelab render`` makes of its spec, bad values refused up front."""

import json

import numpy as np
import pytest
from PIL import Image

from eyelab.core.fileio import linear_to_png16, png_bytes
from eyelab.jobs.batch import load_job_spec, run_batch, validate_jobs

W, H = 48, 32

# both eyes -2.00 D behind -2.00 D lenses (corrected), too old to accommodate much; the
# sweep makes the left eye -4.00 D (2 D under-corrected) and then shows that eye alone
# (samples = 2: one sample is a pinhole image, which shows no defocus)
TWO_EYES = f"""
[base]
render = {{scene = "chart", width = {W}, height = {H}, samples = 2, fov_y_deg = 8.0}}
eye = {{rx = "-2.00 DS", age = 60}}
lens = {{rx = "-2.00 DS"}}
binocular = {{pd_mm = 64}}

[output]
dir = "out"
formats = ["png", "png16"]

[sweep]
mode = "zip"
"eye.left.rx" = ["-2.00 DS", "-4.00 DS", "-4.00 DS"]
"binocular.output" = ["side-by-side", "side-by-side", "left"]
"""


def _png(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB")).astype(int)


def _sharpness(img: np.ndarray) -> float:
    """Mean squared horizontal and vertical neighbour difference of an (h, w, 3) image."""
    return float((np.diff(img, axis=0) ** 2).mean() + (np.diff(img, axis=1) ** 2).mean())


@pytest.fixture(scope="module")
def two_eye_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("two-eyes")
    (folder / "jobs.toml").write_text(TWO_EYES)
    js = load_job_spec(folder / "jobs.toml")
    validate_jobs(js)
    return js, run_batch(js, progress=False)


def test_a_two_eye_sweep_renders_each_job_binocularly(two_eye_run):
    js, res = two_eye_run
    assert res["jobs"] == res["run"] == 3 and res["errors"] == []
    eye = js.jobs[1].data["eye"]          # the dotted key made the left eye's own table
    assert eye["left"] == {"rx": "-4.00 DS"} and eye["rx"] == "-2.00 DS"
    sides = [json.loads((js.out_dir / f"{j.stem}.json").read_text()) for j in js.jobs]
    imgs = [_png(js.out_dir / s["images"]["png"]) for s in sides]
    # side by side is both eyes' images, twice as wide; one eye's output is one image
    assert [im.shape for im in imgs] == [(H, 2 * W, 3), (H, 2 * W, 3), (H, W, 3)]
    for s, w in zip(sides, (2 * W, 2 * W, W), strict=True):
        with Image.open(js.out_dir / s["images"]["png16"]) as im16:
            assert im16.size == (w, H)
        assert set(s["report"]) == {"binocular", "right", "left"}
        assert s["report"]["binocular"]["output"] == s["params"]["binocular.output"]
    # the left half is the left eye's (job 2 renders it alone, a different job and key);
    # only it changed: the right eye's image is byte for byte the same
    np.testing.assert_array_equal(imgs[1][:, :W], imgs[2])
    np.testing.assert_array_equal(imgs[0][:, W:], imgs[1][:, W:])
    assert np.abs(imgs[0][:, :W] - imgs[1][:, :W]).max() > 20
    # the -4.00 D eye behind a -2.00 D lens is 2 D myopic: blurred, by the report too,
    # whose blur semi-axis at fixation (infinity) is the pupil radius (2 mm) times the
    # residual defocus at the eye (each Rx moved from the 12 mm vertex: F / (1 - d F))
    assert _sharpness(imgs[1][:, :W]) < 0.7 * _sharpness(imgs[0][:, :W])
    blur = [s["report"]["binocular"]["eyes"]["left"]["blur_at_fixation_arcmin"][0]
            for s in sides[:2]]
    residual_d = 4.0 / (1 + 0.012 * 4.0) - 2.0 / (1 + 0.012 * 2.0)
    assert blur[0] < 0.5                  # the 8 deg pantoscopic tilt: a trace of astigmatism
    assert blur[1] == pytest.approx(2e-3 * residual_d * 60 * 180 / np.pi, rel=0.03)
    rows = (js.out_dir / "summary.csv").read_text().splitlines()
    assert len(rows) == 4 and "param:eye.left.rx" in rows[0]
    assert all(float(r.split(",")[5]) > 0 for r in rows[1:])   # both eyes' render time


def test_a_two_eye_job_writes_what_eyelab_render_makes(two_eye_run):
    """The job's images are ``render_binocular_spec``'s (its own renderer and scene):
    sRGB as ``eyelab render`` writes it, and the linear output at 16 bits."""
    from eyelab.jobs.render import render_binocular_spec
    from eyelab.spec import parse_spec

    js, _ = two_eye_run
    job = js.jobs[1]
    side = json.loads((js.out_dir / f"{job.stem}.json").read_text())
    res = render_binocular_spec(parse_spec(job.data))
    assert (js.out_dir / side["images"]["png"]).read_bytes() == \
        png_bytes(res.srgb("side-by-side"))
    assert (js.out_dir / side["images"]["png16"]).read_bytes() == \
        png_bytes(linear_to_png16(res.linear("side-by-side")))


@pytest.mark.parametrize("sweep, field", [
    ('"eye.left.rx" = ["-1.00 DS", "banana"]', 'jobspec.sweep."eye.left.rx"[1] (eye.left.rx)'),
    ('"eye.left.rx" = ["-1.00 DS", "OD -1.00 DS"]',
     'jobspec.sweep."eye.left.rx"[1] (eye.left.rx)'),
    ('"binocular.frame_pd_mm" = [60, 64, 200]',
     'jobspec.sweep."binocular.frame_pd_mm"[2] (binocular.frame_pd_mm)'),
    ('"binocular.output" = ["side-by-side", "stereo"]',
     'jobspec.sweep."binocular.output"[1] (binocular.output)'),
])
def test_a_bad_two_eye_sweep_value_is_refused_before_anything_is_written(tmp_path, capsys,
                                                                         sweep, field):
    from eyelab.apps.cli import main

    spec = tmp_path / "jobs.toml"
    spec.write_text(f"[base]\nbinocular = {{pd_mm = 64}}\n[sweep]\n{sweep}\n")
    assert main(["batch", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(f"eyelab: error: {field}: "), err
    assert not (tmp_path / "out").exists()


def test_a_camera_job_renders_the_camera(tmp_path):
    """A spec whose observer is a camera lens renders the camera, as ``eyelab render``
    does, not the spec's default eye."""
    from eyelab.jobs.render import render_spec
    from eyelab.spec import parse_spec

    (tmp_path / "cam.toml").write_text(
        f'[render]\nscene = "chart"\ncamera = "doublet"\nrenderer = "imagebased"\n'
        f"width = {W}\nheight = {H}\nfov_y_deg = 8.0\nsamples = 2\ncamera_f_number = 8\n")
    (tmp_path / "jobs.toml").write_text('spec = "cam.toml"\n[output]\ndir = "out"\n')
    js = load_job_spec(tmp_path / "jobs.toml")
    validate_jobs(js)
    assert run_batch(js, progress=False)["errors"] == []
    side = json.loads((js.out_dir / f"{js.jobs[0].stem}.json").read_text())
    assert side["report"]["details"]["radiometry"] == "irradiance"   # a camera's default
    assert (js.out_dir / side["images"]["png"]).read_bytes() == \
        png_bytes(render_spec(parse_spec(js.jobs[0].data)).srgb)
