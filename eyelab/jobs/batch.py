"""Batch image generation: a job spec (a base spec plus axes to sweep) expanded into jobs,
each rendered to an image and a JSON sidecar, resumable and atomic, serially or on Dask.

Job spec (TOML)::

    spec = "base.toml"            # optional: a spec file the jobs start from (else built-in)
    [base]                        # optional: spec tables merged over it ([eye], [render], ...)
    render = {width = 320, height = 240, samples = 8}
    [output]
    dir = "batch-out"             # where images, sidecars and the summary go
    formats = ["png"]             # "png" (sRGB 8-bit) and/or "png16" (linear light, 16-bit)
    [sweep]                       # axes: dotted spec keys -> lists of values
    mode = "product"              # every combination, or "zip" (the lists side by side)
    "eye.rx" = ["-1.00 DS", "-3.00 DS"]
    "eye.pupil_diameter_mm" = {start = 2, stop = 6, step = 2}     # a range: 2, 4, 6
    "lens.material" = ["cr39", "polycarbonate"]
    [[cases]]                     # extra jobs, each a set of dotted keys over the base
    "eye.rx" = "-6.00 DS"
    "lens" = false                # false removes a table (here: the naked eye)

A spec with two eyes (``[binocular]``, or per-eye tables ``[eye.right]``, ``[lens.left]``,
...) is swept the same way, each side's keys by their dotted names (``"eye.left.rx"``,
``"lens.right.decentration_mm"``, ``"binocular.frame_pd_mm"``, ``"binocular.output"``);
its job renders both eyes (:func:`eyelab.imaging.stereo.render_binocular`) and writes the
image ``eyelab render`` writes for its ``binocular.output`` (side by side: twice as wide),
its sidecar the binocular report (``binocular``, ``right``, ``left``).

A job is done when its sidecar exists, names the job's content key (a digest of the job's
resolved spec and eyelab's version) and records the SHA-256 of each image present; the
images are written first and the sidecar last, each atomically (a temporary beside the
final name, then a rename), so a run killed at any moment leaves finished jobs and no
partial file under a final name; the next run sweeps the temporaries and redoes only
unfinished jobs. Renders are deterministic: the same job gives byte-identical images in
any process.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import html
import json
import logging
import os
import time
import uuid
from pathlib import Path

from eyelab.core.cache import LRUCache
from eyelab.core.errors import SpecError
from eyelab.core.fileio import linear_to_png16, write_png, write_report
from eyelab.core.parallel import LendingPool, process_owned, release_owned, scoped_environ
from eyelab.jobs.jobspec import FORMATS, MAX_JOBS, Job, JobSpec, load_job_spec, validate_jobs

__all__ = ["FORMATS", "MAX_JOBS", "Job", "JobSpec", "JobResources", "load_job_spec",
           "validate_jobs", "job_done", "render_images", "run_job", "run_batch",
           "sweep_temporaries", "write_summary"]


# ------------------------------------------------------------------------ one job
class JobResources(LendingPool):
    """The renderers and scenes one batch run's jobs share (from any threads), closed when
    the run ends. Renderers are kept by name and options, lent to one job at a time and
    never closed while lent (:class:`~eyelab.core.parallel.LendingPool`); scenes are shared,
    the ``max_scenes`` most recently used kept. ``make_renderer(name, quality)`` and
    ``build_scene(source)`` make what is missing (tests pass fakes; by default
    :func:`eyelab.imaging.registry.make_renderer`, :func:`eyelab.jobs.render.build_scene`)."""

    def __init__(self, *, max_renderers: int = 4, max_scenes: int = 8,
                 make_renderer=None, build_scene=None):
        from eyelab.imaging.registry import make_renderer as new_renderer
        from eyelab.jobs.render import build_scene as new_scene

        super().__init__(max_renderers, "batch renderers")
        self.scenes = LRUCache(max_scenes, "batch scenes")
        self._make_renderer = make_renderer or new_renderer
        self._build_scene = build_scene or new_scene

    def renderer(self, name: str, quality):
        """Lend a renderer ``name`` with options ``quality`` for a ``with`` block."""
        return self.lend((name, repr(quality)), lambda: self._make_renderer(name, quality))

    def scene(self, source):
        """The scene of ``source`` (a :class:`~eyelab.scene.scene.SceneSource`), built on
        first use (a mesh file's again when its modification time or size changes)."""
        p = Path(source.name)
        key = (source, p.stat().st_mtime_ns, p.stat().st_size) if p.is_file() else (source,)
        return self.scenes.get_or_create(key, lambda: self._build_scene(source))[0]


def _sha(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def job_done(job: Job, out_dir: Path, formats) -> bool:
    """Whether the job's sidecar exists, names its key and matches its images."""
    side = out_dir / f"{job.stem}.json"
    try:
        meta = json.loads(side.read_text())
    except (OSError, ValueError):
        return False
    if meta.get("key") != job.key or meta.get("status") not in ("ok", "invalid"):
        return False
    for fmt in formats if meta["status"] == "ok" else ():
        img = out_dir / meta["images"].get(fmt, "")
        if not img.is_file() or _sha(img) != meta["sha256"].get(fmt):
            return False
    return True


def run_job(job: Job, out_dir, formats, *, resources: JobResources | None = None) -> dict:
    """Render one job and write its images and sidecar (atomically, sidecar last); an
    invalid job (a bad spec value) gets a sidecar with the parser's message and counts as
    done; a job that fails otherwise (an unreadable mesh) gets one with the error and is
    retried by the next run. Returns the summary row. ``resources``: the renderers and
    scenes to use (the caller's, left open); None: the job's own, closed when it ends."""
    from eyelab import __version__
    from eyelab.imaging.memory import check_memory, memory_limit
    from eyelab.spec import parse_spec

    out_dir = Path(out_dir)
    if job_done(job, out_dir, formats):     # finished already (a rescheduled Dask task)
        return _row(json.loads((out_dir / f"{job.stem}.json").read_text()))
    t0 = time.perf_counter()
    meta = {"key": job.key, "index": job.index, "params": job.params, "spec": job.data,
            "eyelab_version": __version__, "images": {}, "sha256": {}}
    try:
        spec = parse_spec(job.data, f"job {job.index}")
        check_memory(spec.render, memory_limit())   # one image (two eyes: each in turn)
        lender = JobResources() if resources is None else contextlib.nullcontext(resources)
        with lender as pool:
            images, report = render_images(spec, pool, formats)
    except SpecError as e:
        meta.update(status="invalid", error=str(e), time_s=time.perf_counter() - t0)
    except Exception as e:          # an unreadable mesh, a failure: listed, retried next run
        meta.update(status="failed", error=f"{type(e).__name__}: {e}",
                    time_s=time.perf_counter() - t0)
    else:
        for fmt, image in images.items():
            name = f"{job.stem}.png" if fmt == "png" else f"{job.stem}.linear16.png"
            path = out_dir / name
            write_png(path, image)
            meta["images"][fmt] = name
            meta["sha256"][fmt] = _sha(path)
        meta.update(status="ok", time_s=time.perf_counter() - t0, report=report)
    write_report(out_dir / f"{job.stem}.json", meta)
    return _row(meta)


def render_images(spec, pool: JobResources, formats) -> tuple:
    """({format: image}, report) of a parsed job ``spec`` rendered with ``pool``'s renderer
    and scene, as ``eyelab render`` renders it: what its eye sees through its lens (or its
    camera lens sees), or with two eyes both eyes
    (:func:`~eyelab.imaging.stereo.render_binocular`) composed as its
    ``binocular.output``. Images: "png" (h, w', 3) uint8 sRGB, "png16" (h, w', 3) uint16
    linear light (deterministic bytes, :func:`~eyelab.core.fileio.linear_to_png16`);
    w' = ``render.width``, twice it for two eyes side by side or crossed."""
    rs = spec.render
    with pool.renderer(rs.renderer, rs.quality) as renderer:
        scene = pool.scene(rs.scene)
        if spec.binocular is None:
            observer, lens = (spec.eye, spec.lens) if rs.camera is None else (rs.camera, None)
            res = renderer.render(scene, observer, lens, rs.view)
            srgb, linear = (lambda: res.srgb), (lambda: res.linear)
        else:
            from eyelab.imaging.stereo import render_binocular

            res = render_binocular(renderer, scene, spec.binocular, rs.view, rs.quality)
            output = spec.binocular.output
            srgb, linear = (lambda: res.srgb(output)), (lambda: res.linear(output))
    return ({fmt: srgb() if fmt == "png" else linear_to_png16(linear()) for fmt in formats},
            res.report)


def _render_s(report: dict) -> float:
    """Seconds a job's renders took: its report's, or both eyes' together."""
    if "binocular" in report:
        return sum(_render_s(report[side]) for side in ("right", "left"))
    return report.get("timings_s", {}).get("total", 0.0)


def _row(meta: dict) -> dict:
    rep = meta.get("report") or {}
    return {"index": meta["index"], "key": meta["key"], "status": meta["status"],
            "error": meta.get("error", ""), "time_s": round(meta.get("time_s", 0.0), 4),
            "render_s": round(_render_s(rep), 4),
            "image": meta["images"].get("png") or next(iter(meta["images"].values()), ""),
            **{f"param:{k}": json.dumps(v) if not isinstance(v, str) else v
               for k, v in meta["params"].items()}}


# ------------------------------------------------------------------------- a run
def sweep_temporaries(out_dir: Path) -> int:
    """Remove the temporaries a killed run left beside the outputs (this run's folder is
    its own: every ``.eyelab-tmp.`` job, summary and sheet file)."""
    from eyelab.core.fileio import TMP_PREFIX

    n = 0
    for pattern in ("job-*", "summary.csv.*", "index.html.*"):
        for p in out_dir.glob(TMP_PREFIX + pattern):
            try:
                p.unlink()
                n += 1
            except OSError:
                pass
    return n


def run_batch(js: JobSpec, *, workers: int = 1, scheduler: str | None = None,
              progress: bool = True) -> dict:
    """Run every job not yet done; serially in this process (``workers`` 1), on a Dask
    ``LocalCluster`` of ``workers`` processes, or on the cluster at ``scheduler``. Writes
    the summary (CSV) and contact sheet (HTML). Returns counts and the error list. The
    run's resources (:class:`JobResources`) are closed when it ends."""
    out = js.out_dir
    todo = [j for j in js.jobs if not job_done(j, out, js.formats)]
    skipped = len(js.jobs) - len(todo)
    t0 = time.perf_counter()
    # the cluster first: an unreachable scheduler is named before anything is created
    client = _connect(scheduler, workers) if todo and (scheduler or workers > 1) else None
    try:
        out.mkdir(parents=True, exist_ok=True)
        if not os.access(out, os.W_OK):
            raise SpecError("jobspec.output.dir", f"{out} is not writable")
        swept = sweep_temporaries(out)
        if client is not None:
            _run_dask(client, todo, out, js.formats, progress)
        elif todo:
            _run_serial(todo, out, js.formats, progress)
    finally:
        if client is not None:
            client.close()
    rows = []
    for j in js.jobs:
        try:
            rows.append(_row(json.loads((out / f"{j.stem}.json").read_text())))
        except (OSError, ValueError, KeyError):
            rows.append({"index": j.index, "key": j.key, "status": "failed",
                         "error": "no sidecar: the job did not finish", "time_s": 0.0,
                         "render_s": 0.0, "image": ""})
    write_summary(out, rows)
    errors = [(r["index"], r["error"]) for r in rows if r["status"] != "ok"]
    return {"jobs": len(js.jobs), "run": len(todo), "skipped_done": skipped,
            "temporaries_swept": swept, "errors": errors, "wall_s": time.perf_counter() - t0}


def _run_serial(todo, out, formats, progress):
    """The jobs one after another in this process, sharing the run's resources."""
    bar = _bar(len(todo), progress)
    with JobResources() as resources:
        for j in todo:
            run_job(j, out, formats, resources=resources)
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()


#: Seconds to wait for a Dask scheduler to answer.
CONNECT_TIMEOUT_S = 10


class _Cluster:
    """A Dask client and, for a local cluster, the cluster it owns; ``close`` ends both."""

    def __init__(self, client, cluster=None):
        self.client, self.cluster = client, cluster

    def close(self):
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()


def _connect(scheduler: str | None, workers: int) -> _Cluster:
    """A client of the scheduler at ``scheduler`` (an unreachable one is a one-line
    :class:`SpecError` naming ``--scheduler``), or of a new ``LocalCluster`` of ``workers``
    single-threaded processes. Without Dask (the ``dask`` extra) a one-line
    :class:`SpecError` naming the option that asked for it."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SpecError("--scheduler" if scheduler is not None else "--workers",
                        "runs jobs on Dask, which is not installed: pip install "
                        "'eyelab[dask]' (one worker needs no Dask)") from None

    if scheduler is not None:
        try:
            return _Cluster(Client(scheduler, timeout=CONNECT_TIMEOUT_S))
        except (OSError, TimeoutError) as e:
            raise SpecError("--scheduler", f"cannot connect to {scheduler} within "
                            f"{CONNECT_TIMEOUT_S} s ({type(e).__name__})") from None
        except (ValueError, TypeError) as e:        # an address Dask cannot parse
            raise SpecError("--scheduler", f"must be an address like tcp://host:8786, got "
                            f"{scheduler!r} ({e})") from None
    # ":0": the scheduler's HTTP server on a free port (None still takes 8787, and fails
    # when another cluster holds it). The worker processes are started with Ctrl-C
    # ignored (they inherit it): the terminal sends it to the whole process group, and
    # this process ends the cluster itself.
    import signal
    import threading

    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
    try:
        # Dask's own log lines (a cancelled task's warning after Ctrl-C) are not shown:
        # eyelab reports the run in its own lines
        with scoped_environ(DASK_LOGGING__DISTRIBUTED="error"):
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.ERROR)
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
    return _Cluster(Client(cluster), cluster)


def _run_dask(cluster: _Cluster, todo, out, formats, progress):
    """The jobs as Dask tasks on ``cluster``; the workers close their resources for the run
    (an id of its own) however it ends. A job a worker finished before it died is not
    rendered again when Dask reschedules it (:func:`run_job` checks its sidecar)."""
    from distributed import as_completed

    client = cluster.client
    run_id = f"eyelab-batch-{uuid.uuid4().hex}"
    futs = []
    try:
        futs = [client.submit(_run_dask_job, j, str(out), formats, run_id,
                              key=f"eyelab-{j.stem}", pure=False) for j in todo]
        bar = _bar(len(futs), progress)
        for f in as_completed(futs):
            f.result()
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
    finally:
        client.cancel(futs)                # after a failure: start no job after the release
        client.run(release_owned, run_id, on_error="ignore")


def _run_dask_job(job: Job, out_dir: str, formats, run_id: str) -> dict:
    """A Dask task: :func:`run_job` with its worker's resources for run ``run_id``."""
    return run_job(job, out_dir, formats, resources=process_owned(run_id, JobResources))


def _bar(total, progress):
    if not progress:
        return None
    from eyelab.core.progress import bar

    return bar(total, "batch", "job", force=True)


def write_summary(out: Path, rows: list) -> None:
    """``summary.csv`` (one row per job) and ``index.html`` (a contact sheet: each image
    with its parameters), both atomic; viewable offline."""
    from eyelab.core.fileio import atomic_path

    cols = list(dict.fromkeys(k for r in rows for k in r))
    with atomic_path(out / "summary.csv", suffix=".csv") as tmp, \
            open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        w.writerows(rows)
    cells = []
    for r in rows:
        params = "<br>".join(html.escape(f"{k[6:]} = {v}") for k, v in r.items()
                             if k.startswith("param:"))
        img = (f'<img src="{html.escape(r["image"])}" width="240">' if r["image"] else
               f'<div class="err">{html.escape(r["error"])}</div>')
        cells.append(f'<figure>{img}<figcaption>job {r["index"]} · {r["status"]} · '
                     f'{r["render_s"]} s<br>{params}</figcaption></figure>')
    page = ("<!doctype html><meta charset=utf-8><title>eyelab batch</title><style>"
            "body{font:12px sans-serif}figure{display:inline-block;margin:6px;"
            "vertical-align:top;width:240px}.err{color:#b00}</style>"
            f"<h1>eyelab batch: {len(rows)} jobs</h1>" + "".join(cells))
    with atomic_path(out / "index.html", suffix=".html") as tmp:
        Path(tmp).write_text(page)
