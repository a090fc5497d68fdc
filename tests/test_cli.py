import json
import os
import subprocess
import sys

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.jobs.analyze import analyze_spec
from eyelab.spec import load_spec


def test_analyze_default_in_process_matches_library(capsys, tmp_path):
    out = tmp_path / "rep.json"
    assert main(["analyze", "--json", "-o", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    direct = analyze_spec(load_spec())
    assert printed == json.loads(json.dumps(direct))
    assert json.loads(out.read_text()) == printed
    assert [p["status"] for p in printed["points"]] == ["ok", "ok", "ok"]
    # the corrected far point: blur well under an arcminute
    assert printed["points"][0]["blur"]["major_arcmin"] < 0.5


def test_analyze_says_which_fixation_it_used(tmp_path, capsys):
    """Without [analysis] the eye turns about its centre of rotation (the as-worn model);
    the text and the JSON say which model was used and what it means."""
    from eyelab.spec.schema import FIXATION_MEANINGS

    spec = tmp_path / "s.toml"
    spec.write_text('[eye]\nrx = "-2.00"\n[lens]\nrx = "-2.00"\n')
    for flags, model in (([], "rotating"), (["--fixation", "fixed"], "fixed")):
        assert main(["analyze", str(spec), "--json", *flags]) == 0
        rep = json.loads(capsys.readouterr().out)
        assert (rep["fixation"], rep["fixation_meaning"]) == (model, FIXATION_MEANINGS[model])
        assert main(["analyze", str(spec), *flags]) == 0
        assert f"fixation {model}: {FIXATION_MEANINGS[model]}" in capsys.readouterr().out


def test_analyze_text_and_no_lens(capsys):
    assert main(["analyze", "--no-lens"]) == 0
    text = capsys.readouterr().out
    assert "lens: none (naked eye)" in text
    assert "retinal blur ellipse" in text


@pytest.mark.parametrize("command", ["module", "script"])
def test_analyze_as_subprocess_equals_the_library(command, tmp_path, capsys):
    """The installed ``eyelab`` script and ``python -m eyelab.apps.cli``, run from an
    unrelated folder as a user would, print what the in-process call prints."""
    exe = ([sys.executable, "-m", "eyelab.apps.cli"] if command == "module" else
           [os.path.join(os.path.dirname(sys.executable), "eyelab")])
    if command == "script" and not os.path.exists(exe[0]):
        pytest.skip("no eyelab script beside this interpreter")
    r = subprocess.run(exe + ["analyze", "--json"], capture_output=True, text=True,
                       check=False, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert main(["analyze", "--json"]) == 0
    assert json.loads(r.stdout) == json.loads(capsys.readouterr().out)
    assert len(json.loads(r.stdout)["points"]) == 3


@pytest.mark.parametrize("body, field", [
    ('[eye]\npupil_diameter_mm = 40\n', "eye.pupil_diameter_mm"),
    ('[eye]\nrx = "-2 -1 x 400"\n', "eye.rx.axis"),
    ('[eye]\ncolour = 3\n', "eye.colour"),
    ('[lens]\nrx = "-2"\nmaterial = "glass?"\n', "lens.material"),
    ('[[points]]\ndistance_m = -1\n', "points[0].distance_m"),
    ('[[points]]\nfield_deg = [0]\n', "points[0].field_deg"),
    ('[analysis]\nfixation = "wobbly"\n', "analysis.fixation"),
    ('not toml = = 3', "spec"),
])
def test_bad_spec_exits_2_naming_the_field_and_writes_nothing(tmp_path, capsys, body, field):
    spec = tmp_path / "bad.toml"
    spec.write_text(body)
    out = tmp_path / "out.json"
    assert main(["analyze", str(spec), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"eyelab: error: {field}")
    assert not out.exists()
    assert "Traceback" not in err


def test_missing_spec_file(capsys):
    assert main(["analyze", "/nonexistent/spec.toml"]) == 2
    assert "file not found" in capsys.readouterr().err


def test_explicit_surfaces_spec(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text('[eye]\npower_min_d = 60.0\n[lens]\ncenter_thickness_mm = 2.5\n'
                    'material = {n_d = 1.6, v_d = 40}\n[lens.front]\ntype = "sphere"\n'
                    'radius_mm = 120\n[lens.back]\ntype = "toric"\nradius_x_mm = 80\n'
                    'radius_y_mm = 70\naxis_deg = 30\n[[points]]\ndistance_m = 2\n'
                    'field_deg = [5, 5]\n')
    assert main(["analyze", str(spec), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["points"][0]["status"] == "ok"
    assert rep["lens"]["rx"] is None


def test_bench_optics_small(tmp_path, capsys):
    out = tmp_path / "b.json"
    assert main(["bench", "optics", "--points", "20000", "--repeats", "1", "-o", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["chain_ok_fraction"] > 0.9
    assert res["chain_points_per_s"]["1_thread"] > 0
    assert "M points/s" in capsys.readouterr().out


def test_bench_bad_argument(capsys):
    assert main(["bench", "optics", "--points", "5"]) == 2
    assert "--points" in capsys.readouterr().err


def test_bench_blurfield_writes_json(tmp_path, monkeypatch):
    import eyelab.bench.blurfield as bb

    monkeypatch.setattr(bb, "GRIDS", [(16, 4, 4), (32, 8, 8)])
    out = tmp_path / "bf.json"
    assert main(["bench", "blurfield", "--repeats", "1", "-o", str(out)]) == 0
    res = json.loads(out.read_text())
    assert [r["grid"] for r in res["grids"]] == ["4x4x16", "8x8x32"]
    assert res["path_sharing"]["ellipse_rel_error"]["max"] < 0.05
    assert {r["depth_mode"] for r in res["depth_sampling_accuracy"]} == {"ndc", "linear"}


def test_render_and_demo_commands(tmp_path, capsys):
    out = tmp_path / "r.png"
    rep = tmp_path / "r.json"
    assert main(["render", "-o", str(out), "--report", str(rep), "--samples", "2",
                 "--width", "96", "--height", "72"]) == 0
    import matplotlib.image as mpimg

    assert mpimg.imread(out).shape[:2] == (72, 96)
    assert json.loads(rep.read_text())["samples"]["done"] == {"naked": 0, "environment": 2}
    demo = tmp_path / "d.png"
    assert main(["demo", "-o", str(demo), "--samples", "2", "--width", "96",
                 "--height", "72"]) == 0
    assert json.loads((tmp_path / "d.json").read_text())["panels"].keys() == {
        "uncorrected", "with the lens", "emmetrope"}


def test_render_bad_input_leaves_no_file(tmp_path, capsys):
    out = tmp_path / "r.png"
    assert main(["render", "-o", str(out), "--samples", "999"]) == 2
    err = capsys.readouterr().err
    assert "--samples (render.samples)" in err and "[1, 256]" in err
    assert not out.exists()
    assert main(["render", "-o", str(out), "--renderer", "reference", "--samples",
                 "70000"]) == 2
    assert "[1, 65536]" in capsys.readouterr().err
    assert main(["render", "-o", str(out), "--gaze", "0", "-90"]) == 2
    assert "--gaze (render.gaze_deg[1]): must be in [-60, 60]" in capsys.readouterr().err
    assert not out.exists()
    spec = tmp_path / "s.toml"
    spec.write_text('[render]\nscene = "nowhere.obj"\n')
    assert main(["render", str(spec), "-o", str(out)]) == 2
    assert "render.scene" in capsys.readouterr().err
    assert main(["render", "-o", str(tmp_path / "x.jpg")]) == 2


def test_bench_render_small(tmp_path, monkeypatch):
    import eyelab.bench.render as br

    orig = br.run_render_bench
    monkeypatch.setattr(br, "run_render_bench", lambda repeats=1, against=None, quality=None,
                        frames_only=False:
                        orig(width=96, height=72, triangles=(600,), samples=(1, 4), repeats=1,
                             against=against, quality=quality, frames_only=frames_only))
    out = tmp_path / "r.json"
    quality = tmp_path / "q.json"
    quality.write_text(json.dumps(_quality_result()))
    assert main(["bench", "render", "--repeats", "1", "--quality", str(quality),
                 "-o", str(out)]) == 0
    res = json.loads(out.read_text())
    frame = res["default_frame"]
    assert frame["size"] == [96, 72] and "old" not in frame
    assert frame["new"]["quality"]["samples"] == 8
    assert all(frame["new"][k] > 0 for k in frame["kinds"])
    assert set(frame["new"]["ratios"]) == {"emmetrope_over_uncorrected",
                                           "api_second_over_warm", "api_first_over_warm"}
    # equal-error speed-up: where the raster's error equals the reference's at 16 spp it is
    # their time ratio; a 4x smaller error takes the reference 16x the samples and time
    # (Monte Carlo error ~ 1/sqrt(spp)), which the reference's own two rows bear out here
    # (RMSE 0.16 at 1 spp -> 0.04 at 16 spp in 16x the time)
    assert res["equal_error"]["rows"][0]["speedup_at_equal_error"] == pytest.approx(
        (10.0 / 0.5) * 16)
    assert {r["view"] for r in res["rows"]} == {"naked", "through_lens"}
    # the numbers are measurements (no timing assertions in tests): check their presence
    assert set(res["skip_speedups"]) == {"one_pass_for_zero_field", "no_lens_passes",
                                         "one_texcoord_set", "caches_reused",
                                         "one_wavelength", "one_wavelength_no_lens"}
    assert all(np.isfinite(v) and v > 0 for v in res["skip_speedups"].values())
    assert all(r["gl_render_s"] > 0 for r in res["rows"])


def _quality_result():
    """A quality benchmark's result with one case: raster S = 8 (RMSE 0.01 in 0.5 s),
    reference 1 and 16 spp (RMSE 0.16 in 0.625 s, 0.04 in 10 s)."""
    raster = [{"samples": s, "ssim": 0.99, "psnr_db": 40.0, "rmse": 0.01, "time_s": 0.5}
              for s in (8, 32)]
    ref = [{"spp": 1, "ssim": 0.5, "rmse": 0.16, "time_s": 0.625},          # 10 s / 16
           {"spp": 16, "ssim": 0.9, "rmse": 0.04, "time_s": 10.0}]
    case = {"scene": "chart_6m", "config": "x", "truth_spp": 256, "truth_time_s": 1.0,
            "truth_rays_per_s": 1e6, "raster": raster, "reference": ref}
    return {"benchmark": "quality", "preset": "quick", "size": [160, 120], "cases": [case],
            "reference_spp": [1, 16]}


def test_bench_render_against_an_earlier_version_or_a_clear_refusal(tmp_path, capsys):
    """``--against REF`` times the default frame of REF (a git worktree) beside this code's;
    where eyelab is not imported from a git checkout (an installed wheel) it is a
    one-line error naming the flag."""
    from eyelab.bench.frames import default_frames, worktree
    from eyelab.core.errors import SpecError

    try:
        with worktree("HEAD"):
            pass
    except SpecError as e:
        assert "--against" in str(e) and "git" in str(e)
        assert main(["bench", "render", "--against", "HEAD", "-o",
                     str(tmp_path / "r.json")]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
        return
    res = default_frames("HEAD", size=(64, 48), repeats=1, rounds=1)
    assert res["against"]["ref"] == "HEAD" and len(res["against"]["commit"]) == 40
    assert set(res["new_over_old"]) == set(res["kinds"])
    assert all(res[v]["corrected_through_lens"] > 0 for v in ("old", "new"))


@pytest.mark.parametrize("text", ['{"benchmark": "render"}', "[1, 2]",
                                  '{"benchmark": "quality", "cases": [{"scene": "x"}]}'])
def test_bench_render_refuses_a_json_that_is_not_a_quality_result(tmp_path, capsys, text):
    q = tmp_path / "q.json"
    q.write_text(text)
    assert main(["bench", "render", "--quality", str(q), "-o", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--quality" in err
    assert not (tmp_path / "r.json").exists()


def test_bench_render_against_a_ref_git_does_not_know(tmp_path, capsys):
    """A ref git cannot resolve is a one-line error naming --against (or, outside a git
    checkout, the refusal), before any frame is timed."""
    assert main(["bench", "render", "--against", "no-such-ref-eyelab", "-o",
                 str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--against" in err
    assert not (tmp_path / "r.json").exists()


@pytest.mark.parametrize("spec_text, field", [
    ('[eye]\nage = "45"\n', "eye.age"),                           # a numeric string
    ('[eye]\npupil_diameter_mm = true\n', "eye.pupil_diameter_mm"),  # a boolean
    ('[eye]\nage = ' + "9" * 400 + '\n', "eye.age"),              # a 400-digit integer
    ('[lens]\nrx = "-2.00"\nmaterial = {n_d = 1.5, v_d = "inf"}\nbase_curve_d = "4"\n',
     "lens.base_curve_d"),
])
def test_wrong_types_and_huge_numbers_name_the_field(tmp_path, capsys, spec_text, field):
    p = tmp_path / "s.toml"
    p.write_text(spec_text)
    assert main(["analyze", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{field}:" in err and "Traceback" not in err


@pytest.mark.parametrize("make", ["latin1", "mesh", "nested", "long_name", "folder"])
def test_unreadable_spec_files_are_one_line_errors(tmp_path, capsys, make):
    if make == "latin1":
        p = tmp_path / "s.toml"
        p.write_bytes(b"# caf\xe9\n[eye]\nage = 40\n")
    elif make == "mesh":
        import trimesh

        p = tmp_path / "box.stl"
        trimesh.creation.box().export(p)
    elif make == "nested":
        p = tmp_path / "s.toml"
        p.write_text("x = " + "[" * 3000 + "]" * 3000 + "\n")
    elif make == "long_name":
        p = tmp_path / ("a" * 5000 + ".toml")
    else:
        p = tmp_path
    out = tmp_path / "o.png"
    assert main(["render", str(p), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("eyelab: error: spec")
    assert not out.exists()


def test_a_closed_pipe_ends_quietly(tmp_path):
    import subprocess
    import sys

    # `true` exits at once: every write to the pipe fails (EPIPE)
    cmd = f"{sys.executable} -P -m eyelab.apps.cli analyze --json | true"
    r = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert r.stderr == "", r.stderr


def test_outputs_are_checked_before_any_work(tmp_path, capsys):
    """Same path for two outputs, a folder as output, a parent that is a file: one-line
    errors, exit 2, nothing written, before rendering starts."""
    same = tmp_path / "same.png"
    assert main(["render", "-o", str(same), "--report", str(same), "--width", "32",
                 "--height", "24", "--samples", "1"]) == 2
    assert "--report" in capsys.readouterr().err and not same.exists()
    folder = tmp_path / "f.png"
    folder.mkdir()
    assert main(["render", "-o", str(folder)]) == 2
    assert "is a folder" in capsys.readouterr().err
    afile = tmp_path / "file"
    afile.write_text("x")
    assert main(["render", "-o", str(afile / "x.png")]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert main(["analyze", "-o", str(folder)]) == 2


def test_a_device_is_never_replaced(tmp_path, capsys):
    """`-o /dev/null` names a device: refused before any work, never renamed over."""
    import os
    import stat

    for argv in (["render", "-o", os.devnull.replace("null", "null.png")],
                 ["bench", "optics", "-o", os.devnull],
                 ["analyze", "-o", os.devnull]):
        if not os.path.exists(argv[-1]):
            continue
        assert main(argv) == 2
        assert "not a regular file" in capsys.readouterr().err
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


def test_a_full_disk_at_the_write_is_one_line_and_keeps_the_old_outputs(tmp_path, capsys,
                                                                        monkeypatch):
    import errno

    import eyelab.core.fileio

    out, rep = tmp_path / "o.png", tmp_path / "o.json"
    out.write_bytes(b"old")
    real = eyelab.core.fileio.atomic_path

    def full(path, suffix=".tmp"):
        if str(path).endswith(".json"):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, suffix)

    monkeypatch.setattr(eyelab.core.fileio, "atomic_path", full)
    rc = main(["render", "-o", str(out), "--report", str(rep), "--width", "32", "--height",
               "24", "--samples", "1"])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and len(err.splitlines()) == 1 and "No space left on device" in err
    assert out.read_bytes() == b"old" and not rep.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["o.png"]


@pytest.mark.parametrize("argv", [["bench", "optics", "--plot", "x.png"],
                                  ["bench", "render", "--truth-spp", "64"],
                                  ["bench", "stability", "--points", "2000"],
                                  ["bench", "nothing"]])
def test_bench_refuses_a_flag_of_another_benchmark(argv, capsys):
    """Each benchmark takes only its own flags: another's is a one-line usage error."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error:" in err[0]
