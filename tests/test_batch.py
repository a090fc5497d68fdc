"""Batch generation: job specs, resumable atomic runs, and the same bytes serially, on a
local Dask cluster and on a real scheduler with workers."""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from eyelab.core.errors import SpecError
from eyelab.jobs.batch import job_done, load_job_spec, run_batch

JOBS = """
[base]
render = {{scene = "chart", width = 64, height = 48, samples = 2, fov_y_deg = 10.0}}

[output]
dir = "out"
formats = {formats}

[sweep]
"eye.rx" = {rxs}
"lens.material" = ["cr39", "polycarbonate"]
"""


def _jobspec(tmp_path, n_rx=2, formats='["png"]', extra=""):
    rxs = json.dumps([f"-{1 + 0.25 * i:.2f} DS" for i in range(n_rx)])
    p = tmp_path / "jobs.toml"
    p.write_text(JOBS.format(rxs=rxs, formats=formats) + extra)
    return p


def _images(out: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(out.glob("job-*.png"))}

def _scheduler(tmp_path, env) -> tuple:
    """A `dask scheduler` on loopback: (its process, its address)."""
    sched_file = tmp_path / "scheduler.json"
    proc = subprocess.Popen([_dask(), "scheduler", "--host", "127.0.0.1", "--port", "0",
                             "--no-dashboard", "--scheduler-file", str(sched_file)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(300):
        if sched_file.exists() and sched_file.stat().st_size:
            break
        time.sleep(0.1)
    return proc, json.loads(sched_file.read_text())["address"]


def _dask() -> str:
    bindir = Path(sys.executable).parent
    return str(bindir / "dask") if (bindir / "dask").exists() else "dask"



def test_expansion_outputs_resume_and_invalid_jobs(tmp_path):
    extra = '\n[[cases]]\n"eye.rx" = "-6.00 DS"\n"lens" = false\n' \
            '\n[[cases]]\n"eye.pupil_diameter_mm" = 42\n'
    js = load_job_spec(_jobspec(tmp_path, formats='["png", "png16"]', extra=extra))
    assert len(js.jobs) == 6
    assert "lens" not in js.jobs[4].data
    res = run_batch(js, progress=False)
    assert res["run"] == 6 and [i for i, _ in res["errors"]] == [5]
    assert "eye.pupil_diameter_mm" in res["errors"][0][1]
    out = js.out_dir
    side = json.loads((out / f"{js.jobs[0].stem}.json").read_text())
    assert side["status"] == "ok" and side["params"]["eye.rx"] == "-1.00 DS"
    assert side["report"]["renderer"] == "raster" and side["eyelab_version"]
    # the 16-bit linear image is a valid PNG (PIL reads it) holding the render's light
    with Image.open(out / side["images"]["png16"]) as img16:
        img16.load()
        assert img16.size == (64, 48)
    with Image.open(out / side["images"]["png"]) as im:
        srgb = np.asarray(im)
    lin = np.frombuffer(_idat(out / side["images"]["png16"]), ">u2").reshape(48, 64, 3)
    from eyelab.core.color import encode_srgb

    again = encode_srgb(lin / 65535.0)
    assert np.abs(again.astype(int) - srgb.astype(int)).max() <= 1
    rows = (out / "summary.csv").read_text().splitlines()
    assert len(rows) == 7 and "param:eye.rx" in rows[0]
    assert "<img" in (out / "index.html").read_text()
    # a second run redoes nothing; a damaged image redoes its job only
    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("job-*.json")}
    assert run_batch(js, progress=False)["run"] == 0
    (out / side["images"]["png"]).write_bytes(b"broken")
    assert not job_done(js.jobs[0], out, js.formats)
    res = run_batch(js, progress=False)
    assert res["run"] == 1
    changed = [p for p in out.glob("job-*.json") if p.stat().st_mtime_ns != mtimes[p]]
    assert [p.name for p in changed] == [f"{js.jobs[0].stem}.json"]


def _idat(path) -> bytes:
    """The raw scanlines of a filter-0 PNG (what eyelab writes), filters removed."""
    import struct
    import zlib

    data = Path(path).read_bytes()[8:]
    idat, w = b"", None
    while data:
        n, tag = struct.unpack(">I4s", data[:8])
        body = data[8:8 + n]
        if tag == b"IHDR":
            w = struct.unpack(">I", body[:4])[0]
        if tag == b"IDAT":
            idat += body
        data = data[12 + n:]
    raw = zlib.decompress(idat)
    stride = 1 + 6 * w
    assert all(raw[i] == 0 for i in range(0, len(raw), stride))
    return b"".join(raw[i + 1:i + stride] for i in range(0, len(raw), stride))


@pytest.mark.parametrize("text, field", [
    ('[sweep]\n"eye.rx" = "-1.00"\n', 'jobspec.sweep."eye.rx"'),
    ('[sweep]\nmode = "cross"\n"eye.rx" = ["-1.00"]\n', "jobspec.sweep.mode"),
    ('[sweep]\nmode = "zip"\n"eye.rx" = ["-1.00"]\n"eye.age" = [1, 2]\n', "jobspec.sweep"),
    ('[output]\nformats = ["tiff"]\n', "jobspec.output.formats"),
    ('[outputs]\ndir = "x"\n', "jobspec.outputs"),
    ('spec = "missing.toml"\n', "spec"),
    ('[sweep]\n"eye.age" = {start = 10, stop = 1, step = 1}\n', 'jobspec.sweep."eye.age".step'),
    ('[sweep]\n"eye.age" = {start = 10, stop = 20}\n', 'jobspec.sweep."eye.age"'),
])
def test_bad_job_specs_name_the_field(tmp_path, text, field):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(SpecError) as e:
        load_job_spec(p)
    assert e.value.field == field


def test_ranges_and_zip(tmp_path):
    p = tmp_path / "r.toml"
    p.write_text('[sweep]\nmode = "zip"\n"eye.pupil_diameter_mm" = {start = 2, stop = 3, '
                 'step = 0.5}\n"eye.age" = [20, 30, 40]\n')
    js = load_job_spec(p)
    assert [(j.data["eye"]["pupil_diameter_mm"], j.data["eye"]["age"]) for j in js.jobs] \
        == [(2.0, 20), (2.5, 30), (3.0, 40)]


def test_cli_exit_codes(tmp_path, capsys):
    from eyelab.apps.cli import main

    spec = _jobspec(tmp_path)
    assert main(["batch", str(spec), "--quiet"]) == 0
    assert "4 jobs: 4 run" in capsys.readouterr().out
    assert main(["batch", str(spec), "--workers", "0"]) == 2
    capsys.readouterr()
    bad = tmp_path / "bad.toml"
    bad.write_text('[[cases]]\n"eye.rx" = "banana"\n')
    assert main(["batch", str(bad), "--quiet", "-o", str(tmp_path / "o2")]) == 2
    assert capsys.readouterr().err.startswith("eyelab: error: jobspec.cases[0] (eye.rx): ")
    assert not (tmp_path / "o2").exists()                    # refused before any output
    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"not a mesh at all")
    bad.write_text(f'[[cases]]\n"render.scene" = "{junk}"\n[[cases]]\n"eye.age" = 30\n')
    assert main(["batch", str(bad), "--quiet", "-o", str(tmp_path / "o3")]) == 1
    text = capsys.readouterr().out
    assert "1 not ok" in text and "job 0:" in text           # job 1 still ran
    assert (tmp_path / "o3" / "summary.csv").read_text().count(",ok,") == 1


@pytest.mark.slow
def test_killed_runs_resume_to_valid_outputs(tmp_path):
    """A 50-job batch killed (SIGKILL) at 10 random moments and restarted each time: in the
    end every job is done and valid, no temporary is left, and no job that had finished
    was ever redone (its sidecar's bytes never change once written)."""
    spec = _jobspec(tmp_path, n_rx=25)
    out = tmp_path / "out"
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    cmd = [sys.executable, "-P", "-m", "eyelab.apps.cli", "batch", str(spec), "--quiet"]
    rng = random.Random(1)
    finished = {}
    for _ in range(10):
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(1.5, 6.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        for p in out.glob("job-*.json"):
            b = p.read_bytes()
            assert finished.setdefault(p.name, b) == b, f"{p.name} was redone"
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    js = load_job_spec(spec)
    assert all(job_done(j, out, js.formats) for j in js.jobs)
    for name, b in finished.items():
        assert (out / name).read_bytes() == b
    assert not list(out.glob(".*"))


def test_same_bytes_serial_local_cluster_and_real_scheduler(tmp_path):
    """20 jobs serially, on a LocalCluster of 2 worker processes, and on a `dask
    scheduler` with two `dask worker` processes started here on loopback: byte-identical
    images; the workers, which outlive the run, hold none of its resources after it."""
    spec = _jobspec(tmp_path, n_rx=10)
    js = load_job_spec(spec, out_dir=tmp_path / "serial")
    assert run_batch(js, progress=False)["errors"] == []
    ref = _images(js.out_dir)
    assert len(ref) == 20
    js2 = load_job_spec(spec, out_dir=tmp_path / "local")
    assert run_batch(js2, workers=2, progress=False)["errors"] == []
    assert _images(js2.out_dir) == ref
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    scheduler, address = _scheduler(tmp_path, env)
    procs = [scheduler]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen(
                [_dask(), "worker", address, "--nthreads", "1", "--no-dashboard"], env=env,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        js3 = load_job_spec(spec, out_dir=tmp_path / "cluster")
        assert run_batch(js3, scheduler=address, progress=False)["errors"] == []
        assert _images(js3.out_dir) == ref
        from distributed import Client

        def batch_runs_held():
            from eyelab.core import parallel

            return sorted(str(k) for k in parallel._OWNED if str(k).startswith("eyelab-batch-"))

        with Client(address) as client:
            held = client.run(batch_runs_held)
        assert len(held) == 2 and all(v == [] for v in held.values())
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=30)


def test_bench_batch_small():
    from eyelab.bench.batch import run_batch_bench

    res = run_batch_bench(2)
    assert set(res["times_s"]) == {"batch_1_worker", "batch_2_workers", "separate_processes"}
    assert res["same_bytes_1_vs_2_workers"] is True
    assert all(v > 0 for v in res["times_s"].values())


@pytest.mark.parametrize("sweep, words", [
    # four axes of 100 values: 10^8 jobs, refused from the counts alone
    ("".join(f'"{k}" = {{start = 1, stop = 100, step = 1}}\n' for k in
             ("eye.age", "eye.pupil_diameter_mm", "render.width", "render.height")),
     "100,000,000 jobs (product of 100 x 100 x 100 x 100)"),
    # two ranges under the per-range cap whose product is 10^8
    ('"eye.age" = {start = 0, stop = 9999, step = 1}\n'
     '"render.width" = {start = 0, stop = 9999, step = 1}\n', "100,000,000 jobs"),
    # a million jobs
    ('"eye.age" = {start = 0, stop = 999, step = 1}\n'
     '"render.width" = {start = 0, stop = 999, step = 1}\n', "1,000,000 jobs"),
    # a range whose count overflows
    ('"eye.age" = {start = 0, stop = 1e308, step = 1e-300}\n', "inf values"),
])
def test_huge_grids_are_refused_before_they_are_made(tmp_path, capsys, sweep, words):
    from eyelab.apps.cli import main

    spec = tmp_path / "grid.toml"
    spec.write_text("[sweep]\n" + sweep)
    assert main(["batch", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and words in err and "jobspec.sweep" in err
    assert not (tmp_path / "out").exists()


def test_the_job_limit_counts_sweep_and_cases(tmp_path):
    spec = _jobspec(tmp_path, n_rx=3, extra='\n[[cases]]\n"eye.age" = 30\n')
    with pytest.raises(SpecError, match=r"7 jobs \(product of 3 x 2, plus 1 cases\); "
                                        r"at most 6 \(--max-jobs"):
        load_job_spec(spec, max_jobs=6)
    assert len(load_job_spec(spec, max_jobs=7).jobs) == 7


@pytest.mark.parametrize("jobspec, field", [
    ('[sweep]\n"eye.rxx" = ["-1 DS"]\n', 'jobspec.sweep."eye.rxx"[0] (eye.rxx)'),
    ('[sweep]\n"eye.rx" = ["-1 DS", "-2 DS", "banana"]\n', 'jobspec.sweep."eye.rx"[2] (eye.rx)'),
    ('[base]\neye = {pupil_diameter_mm = 42}\n[sweep]\n"eye.rx" = ["-1 DS"]\n',
     "jobspec.base (eye.pupil_diameter_mm)"),
    ('[base]\nbinocular = {pd_mm = 640}\n', "jobspec.base (binocular.pd_mm)"),
    ('[base]\nrender = {width = 4096, height = 3072, samples = 64}\n',
     "jobspec.base (render.width)"),
    ('[[cases]]\n"eye.age" = 30\n[[cases]]\n"render.samples" = 0\n',
     "jobspec.cases[1] (render.samples)"),
])
def test_what_would_fail_every_job_is_refused_up_front(tmp_path, capsys, jobspec, field):
    """A misspelt sweep key, a bad sweep value, a bad base value, a bad two-eye base, a base
    over the memory limit, a bad case: one line naming where the value came from and the
    spec field, exit 2, no folder, no sidecar, no summary."""
    from eyelab.apps.cli import main

    spec = tmp_path / "jobs.toml"
    spec.write_text(jobspec)
    assert main(["batch", str(spec), "-o", str(tmp_path / "out"), "--max-memory", "2"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(f"eyelab: error: {field}: "), err
    assert not (tmp_path / "out").exists()


def test_output_folders_and_schedulers_are_checked_before_work(tmp_path, capsys):
    from eyelab.apps.cli import main

    spec = _jobspec(tmp_path)
    (tmp_path / "a_file").write_text("x")
    for out, words in ((str(tmp_path / "a_file" / "o"), "is not a folder"),
                       (str(tmp_path / "a_file"), "exists and is not a folder"),
                       ("", "must be a folder path")):
        assert main(["batch", str(spec), "-o", out]) == 2
        err = capsys.readouterr().err
        assert err.startswith("eyelab: error: --output: ") and words in err, err
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if not os.access(ro, os.W_OK):            # (root may write anywhere)
            assert main(["batch", str(spec), "-o", str(ro / "o")]) == 2
            assert "cannot write in" in capsys.readouterr().err
    finally:
        ro.chmod(0o700)
    assert main(["batch", str(spec), "-o", str(tmp_path / "o"), "--scheduler",
                 "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("eyelab: error: --scheduler: cannot connect to tcp://127.0.0.1:9")
    assert len(err.splitlines()) == 1 and not (tmp_path / "o").exists()
    # a relative folder is taken from where the command runs, made absolute for workers
    js = load_job_spec(spec, out_dir="rel-out")
    assert js.out_dir == Path.cwd() / "rel-out"


def test_a_finished_job_is_not_rendered_again(tmp_path, monkeypatch):
    """run_job on a job whose complete sidecar exists returns its row without rendering
    (what a Dask task rescheduled after its worker died does)."""
    from eyelab.jobs import batch

    js = load_job_spec(_jobspec(tmp_path))
    assert run_batch(js, progress=False)["errors"] == []
    side = js.out_dir / f"{js.jobs[0].stem}.json"
    before = side.stat().st_ino, side.read_bytes()

    def no_render(*a, **k):
        raise AssertionError("rendered again")

    monkeypatch.setattr(batch.JobResources, "renderer", no_render)
    row = batch.run_job(js.jobs[0], js.out_dir, js.formats)
    assert row["status"] == "ok" and (side.stat().st_ino, side.read_bytes()) == before


@pytest.mark.slow
def test_a_worker_killed_mid_run_changes_nothing(tmp_path):
    """A `dask scheduler` and two workers started in another folder; `eyelab batch -o out`
    (relative) from a third; one worker SIGKILLed once a few jobs are done and a fresh one
    started: every image equals the serial run's bytes, and no sidecar, once written, is
    ever rewritten (no finished job is rendered twice)."""
    spec = _jobspec(tmp_path, n_rx=15)
    js = load_job_spec(spec, out_dir=tmp_path / "serial")
    assert run_batch(js, progress=False)["errors"] == []
    ref = _images(js.out_dir)
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    workdir, client_dir = tmp_path / "workers", tmp_path / "client"
    workdir.mkdir()
    client_dir.mkdir()
    scheduler, address = _scheduler(tmp_path, env)
    procs = [scheduler]

    def worker():
        procs.append(subprocess.Popen([_dask(), "worker", address, "--nthreads", "1",
                                       "--no-dashboard"], env=env, cwd=workdir,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        return procs[-1]

    try:
        victim = worker()
        worker()
        run = subprocess.Popen([sys.executable, "-P", "-m", "eyelab.apps.cli", "batch",
                                str(spec), "-o", "out", "--quiet", "--scheduler", address],
                               cwd=client_dir, env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
        out = client_dir / "out"
        seen, killed = {}, False
        while run.poll() is None:
            for p in out.glob("job-*.json"):
                st = p.stat()
                seen.setdefault(p.name, (st.st_ino, st.st_mtime_ns))
            if not killed and len(seen) >= 6:
                victim.send_signal(signal.SIGKILL)
                victim.wait()
                worker()
                killed = True
            time.sleep(0.05)
        text = run.communicate()[0]
        assert run.returncode == 0, text
        assert killed and _images(out) == ref
        for name, (ino, mtime) in seen.items():
            st = (out / name).stat()
            assert (st.st_ino, st.st_mtime_ns) == (ino, mtime), f"{name} was rewritten"
        assert not list((workdir).glob("out"))
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=30)


def test_relative_lens_and_frame_files_resolve_from_their_specs(tmp_path, monkeypatch):
    """A base spec in its own folder names a points surface and a frame trace by relative
    paths: the jobs find them whatever folder the batch runs from."""
    import shutil

    fixtures = Path(__file__).parent / "fixtures"
    specs = tmp_path / "specs"
    specs.mkdir()
    np.save(specs / "front.npy", np.zeros((77, 77)))
    shutil.copy(fixtures / "frame_trace.oma", specs / "job.oma")
    (specs / "base.toml").write_text(
        '[eye]\nrx = "-2.00 DS"\n[lens]\ncenter_thickness_mm = 2.0\ndiameter_mm = 70\n'
        'rx = "-2.00 DS"\n[lens.front]\nfile = "front.npy"\nspacing_mm = 1.0\n'
        '[lens.back]\ntype = "sphere"\nradius_mm = 265\n'
        '[frame]\nfile = "job.oma"\nmonocular_pd_mm = 32\nfitting_height_mm = 18\n')
    jobs = tmp_path / "jobs"
    jobs.mkdir()
    (jobs / "jobs.toml").write_text('spec = "../specs/base.toml"\n[sweep]\n'
                                    '"eye.pupil_diameter_mm" = [3, 4]\n')
    monkeypatch.chdir("/")
    from eyelab.jobs.batch import validate_jobs

    js = load_job_spec(jobs / "jobs.toml", out_dir=tmp_path / "out")
    validate_jobs(js)
    assert Path(js.jobs[0].data["lens"]["front"]["file"]).resolve() == specs / "front.npy"
    assert Path(js.jobs[0].data["frame"]["file"]).resolve() == specs / "job.oma"


def test_a_changed_input_file_makes_a_new_job(tmp_path):
    """The job key digests the files the spec reads: editing a points surface (or a frame
    trace, a mesh) makes its jobs undone, so a re-run renders them again."""
    np.save(tmp_path / "front.npy", np.zeros((77, 77)))
    (tmp_path / "jobs.toml").write_text(
        '[base]\nlens = {center_thickness_mm = 2.0, rx = "-2.00 DS", front = {file = '
        '"front.npy", spacing_mm = 1.0}, back = {type = "sphere", radius_mm = 265}}\n')
    before = load_job_spec(tmp_path / "jobs.toml", out_dir=tmp_path / "out").jobs[0].key
    assert load_job_spec(tmp_path / "jobs.toml", out_dir=tmp_path / "out").jobs[0].key \
        == before
    np.save(tmp_path / "front.npy", np.full((77, 77), 1e-3))
    assert load_job_spec(tmp_path / "jobs.toml", out_dir=tmp_path / "out").jobs[0].key \
        != before


def test_a_sweep_over_the_eyes_rx_says_when_the_lens_stays_fixed(tmp_path):
    """The built-in spec's lens has its own Rx: a sweep over eye.rx keeps it, and says so
    before the run; a base spec whose [lens] has no rx makes each job's lens for its eye (the spec's
    own eye.rx in the resolved job), and sweeping lens.rx too is silent."""
    from eyelab.jobs.jobspec import fixed_lens_note
    from eyelab.spec.load import parse_spec

    def grid(text):
        p = tmp_path / "g.toml"
        p.write_text(text)
        return load_job_spec(p, out_dir=tmp_path / "out")

    sweep = '[sweep]\n"eye.rx" = ["-1.00 DS", "-2.00 DS"]\n'
    note = fixed_lens_note(grid(sweep))
    assert note and "lens.rx = '-3.00 -1.00 x 180'" in note and "eye.rx" in note
    assert fixed_lens_note(grid(sweep + '"lens.rx" = ["-1.00 DS", "-2.00 DS"]\n')) is None
    (tmp_path / "base.toml").write_text('[lens]\nmaterial = "cr39"\n')
    follows = grid('spec = "base.toml"\n' + sweep)
    assert fixed_lens_note(follows) is None
    specs = [parse_spec(job.data, base=tmp_path) for job in follows.jobs]
    assert [round(s.lens.rx.sphere, 6) for s in specs] == [-1.0, -2.0]


def test_workers_without_dask_are_one_line_and_nothing_written(tmp_path, monkeypatch):
    """Dask is the `dask` extra: without it, --workers 2 (or --scheduler) is refused by
    name before anything is created; one worker runs without it."""
    monkeypatch.setitem(sys.modules, "distributed", None)       # import fails
    p = tmp_path / "g.toml"
    p.write_text('[base]\nrender = {width = 32, height = 24, samples = 1}\n')
    js = load_job_spec(p, out_dir=tmp_path / "out")
    with pytest.raises(SpecError, match=r"^--workers: .*pip install 'eyelab\[dask\]'"):
        run_batch(js, workers=2, progress=False)
    with pytest.raises(SpecError, match=r"^--scheduler: "):
        run_batch(js, scheduler="tcp://127.0.0.1:1", progress=False)
    assert not (tmp_path / "out").exists()
    assert run_batch(js, workers=1, progress=False)["errors"] == []


def test_a_schematic_base_sweeps_its_own_keys(tmp_path, capsys):
    """A schematic eye's base spec (``spec = FILE``, the naked eye) swept over its axial
    length: each job renders its own eye (the summary names its length) — and a bad key in that
    file is blamed on it, not on [base]."""
    import csv

    from eyelab.apps.cli import main

    (tmp_path / "eye.toml").write_text('[eye]\nmodel = "navarro"\npupil_diameter_mm = 4\n')
    spec = tmp_path / "jobs.toml"
    spec.write_text('spec = "eye.toml"\n[base]\nrender = {width = 32, height = 24, '
                    'samples = 4}\n[sweep]\n"eye.axial_length_mm" = [23.0, 25.0]\n')
    assert main(["batch", str(spec), "-o", str(tmp_path / "out")]) == 0
    with (tmp_path / "out" / "summary.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [float(r["param:eye.axial_length_mm"]) for r in rows] == [23.0, 25.0]
    assert all(r["status"] == "ok" for r in rows), rows
    a, b = ((tmp_path / "out" / r["image"]).read_bytes() for r in rows)
    assert a != b                                  # 23 mm is hyperopic, 25 mm myopic
    capsys.readouterr()
    (tmp_path / "eye.toml").write_text('[eye]\nmodel = "navarro"\nage = 5\n')
    spec.write_text('spec = "eye.toml"\n[base]\nrender = {width = 32, height = 24}\n')
    assert main(["batch", str(spec), "-o", str(tmp_path / "out2")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("eyelab: error: jobspec.spec (eye.toml) (eye.age): "), err
