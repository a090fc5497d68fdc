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
import copy
import csv
import functools
import hashlib
import html
import itertools
import json
import os
import time
import tomllib
import uuid
from dataclasses import dataclass
from pathlib import Path

from eyelab.core.cache import LRUCache, content_key
from eyelab.core.errors import SpecError
from eyelab.core.fileio import linear_to_png16, write_json, write_png
from eyelab.core.parallel import LendingPool, process_owned, release_owned

FORMATS = ("png", "png16")
JOB_KEYS = {"spec", "base", "output", "sweep", "cases"}
OUTPUT_KEYS = {"dir", "formats"}


@dataclass(frozen=True)
class Job:
    """One job: its index, the spec table it renders, and the dotted keys that made it."""

    index: int
    data: dict
    params: dict

    @functools.cached_property
    def key(self) -> str:
        from eyelab import __version__

        return content_key(spec=json.dumps(self.data, sort_keys=True, default=str),
                           version=__version__)

    @property
    def stem(self) -> str:
        return f"job-{self.index:05d}-{self.key[:10]}"


@dataclass(frozen=True)
class JobSpec:
    jobs: tuple
    out_dir: Path
    formats: tuple
    source: str


def _set(data: dict, dotted: str, value, where: str) -> None:
    parts = dotted.split(".")
    if not all(parts):
        raise SpecError(where, f"{dotted!r} is not a dotted spec key like 'eye.rx'")
    t = data
    for p in parts[:-1]:
        nxt = t.setdefault(p, {})
        if not isinstance(nxt, dict):
            raise SpecError(where, f"{dotted!r}: {p!r} is not a table")
        t = nxt
    if value is False and len(parts) == 1:
        t.pop(parts[0], None)                 # "lens" = false: no lens
    else:
        t[parts[-1]] = copy.deepcopy(value)


def _merge(into: dict, over: dict) -> None:
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(into.get(k), dict):
            _merge(into[k], v)
        else:
            into[k] = copy.deepcopy(v)


def load_job_spec(path, *, out_dir=None) -> JobSpec:
    """Read and expand a job spec file (every field checked, errors name it)."""
    p = Path(path)
    if not p.is_file():
        raise SpecError("jobspec", f"file not found: {str(p)!r}")
    try:
        js = tomllib.loads(p.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise SpecError("jobspec", f"{p} is not valid TOML: {e}") from None
    unknown = sorted(set(js) - JOB_KEYS)
    if unknown:
        raise SpecError(f"jobspec.{unknown[0]}", f"unknown key; allowed: {sorted(JOB_KEYS)}")
    base = _base_spec(js, p.parent)
    folder, formats = _output(js.get("output", {}), p.parent, out_dir)
    combos = _sweep(js.get("sweep", {}))
    cases = js.get("cases", [])
    if not isinstance(cases, list) or not all(isinstance(c, dict) for c in cases):
        raise SpecError("jobspec.cases", "must be an array of tables ([[cases]])")
    combos = combos + [dict(c) for c in cases] or [{}]
    jobs = []
    for i, params in enumerate(combos):
        data = copy.deepcopy(base)
        for k, v in params.items():
            _set(data, k, v, f"jobspec.job[{i}].{k}")
        jobs.append(Job(i, data, params))
    return JobSpec(tuple(jobs), folder, formats, str(p))


def _base_spec(js: dict, here: Path) -> dict:
    """The spec every job starts from: ``spec`` (else the built-in one) with ``[base]``
    merged over it; relative paths (of ``spec``, of a mesh scene file) are from ``here``."""
    from eyelab.spec import read_spec_data

    base_path = js.get("spec")
    if base_path is not None and not isinstance(base_path, str):
        raise SpecError("jobspec.spec", "must be a spec file path")
    if base_path is not None:
        base_path = Path(base_path) if Path(base_path).is_absolute() else here / base_path
    base = copy.deepcopy(read_spec_data(base_path)[0])
    extra = js.get("base", {})
    if not isinstance(extra, dict):
        raise SpecError("jobspec.base", "must be a table of spec tables")
    _merge(base, extra)
    scene = base.get("render", {}).get("scene")
    where = scene if isinstance(scene, dict) else base.get("render", {})
    key = "path" if isinstance(scene, dict) else "scene"
    rel = where.get(key) if isinstance(where, dict) else None
    if isinstance(rel, str) and not Path(rel).is_absolute() and (here / rel).is_file():
        where[key] = str((here / rel).resolve())
    return base


def _output(out, here: Path, out_dir) -> tuple:
    """(folder, formats without repeats) of the ``[output]`` table; ``out_dir`` replaces
    its ``dir``, which is relative to ``here``."""
    if not isinstance(out, dict):
        raise SpecError("jobspec.output", "must be a table")
    bad = sorted(set(out) - OUTPUT_KEYS)
    if bad:
        raise SpecError(f"jobspec.output.{bad[0]}", f"unknown key; allowed: {sorted(OUTPUT_KEYS)}")
    formats = out.get("formats", ["png"])
    if not isinstance(formats, list) or not formats or any(f not in FORMATS for f in formats):
        raise SpecError("jobspec.output.formats", f"must be a non-empty list of {FORMATS}, "
                                                  f"got {formats!r}")
    folder = out_dir or out.get("dir", "batch-out")
    if not isinstance(folder, (str, Path)):
        raise SpecError("jobspec.output.dir", "must be a folder path")
    folder = Path(folder) if Path(folder).is_absolute() or out_dir else here / folder
    return folder, tuple(dict.fromkeys(formats))


def _sweep(sw) -> list:
    if not isinstance(sw, dict):
        raise SpecError("jobspec.sweep", "must be a table of dotted keys -> lists")
    sw = dict(sw)
    mode = sw.pop("mode", "product")
    if mode not in ("product", "zip"):
        raise SpecError("jobspec.sweep.mode", f"must be 'product' or 'zip', got {mode!r}")
    for k, v in sw.items():
        if isinstance(v, dict):
            sw[k] = v = _range(v, f"jobspec.sweep.{k}")
        if not isinstance(v, list) or not v:
            raise SpecError(f"jobspec.sweep.{k}", "must be a non-empty list of values or a "
                                                  "range {start, stop, step}")
    if not sw:
        return []
    keys = list(sw)
    if mode == "zip":
        n = {len(v) for v in sw.values()}
        if len(n) != 1:
            raise SpecError("jobspec.sweep", f"zip needs lists of one length, got "
                                             f"{ {k: len(v) for k, v in sw.items()} }")
        rows = zip(*sw.values(), strict=True)
    else:
        rows = itertools.product(*sw.values())
    return [dict(zip(keys, r, strict=True)) for r in rows]


def _range(t: dict, where: str) -> list:
    """{start, stop, step} -> the numbers start, start + step, ... up to stop inclusive
    (within 1e-9 of a step), rounded to 10 decimals; at most 10000."""
    import math

    if set(t) != {"start", "stop", "step"}:
        raise SpecError(where, f"a range needs exactly start, stop and step, got {sorted(t)}")
    vals = []
    for name in ("start", "stop", "step"):
        v = t[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SpecError(f"{where}.{name}", f"must be a finite number, got {v!r}")
        vals.append(float(v))
    start, stop, step = vals
    if step == 0 or (stop - start) / step < 0:
        raise SpecError(f"{where}.step", f"must be non-zero and lead from start to stop, "
                                         f"got {step:g}")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > 10000:
        raise SpecError(where, f"{n} values; at most 10000")
    return [round(start + i * step, 10) for i in range(n)]


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
    from eyelab.spec import one_eye, parse_spec

    out_dir = Path(out_dir)
    t0 = time.perf_counter()
    meta = {"key": job.key, "index": job.index, "params": job.params, "spec": job.data,
            "eyelab_version": __version__, "images": {}, "sha256": {}}
    try:
        spec = one_eye(parse_spec(job.data, f"job {job.index}"), "eyelab batch")
        rs = spec.render
        check_memory(rs, memory_limit())
        lender = JobResources() if resources is None else contextlib.nullcontext(resources)
        with lender as pool, pool.renderer(rs.renderer, rs.quality) as renderer:
            res = renderer.render(pool.scene(rs.scene), spec.eye, spec.lens, rs.view)
    except SpecError as e:
        meta.update(status="invalid", error=str(e), time_s=time.perf_counter() - t0)
    except Exception as e:          # an unreadable mesh, a failure: listed, retried next run
        meta.update(status="failed", error=f"{type(e).__name__}: {e}",
                    time_s=time.perf_counter() - t0)
    else:
        for fmt in formats:
            name = f"{job.stem}.png" if fmt == "png" else f"{job.stem}.linear16.png"
            path = out_dir / name
            # sRGB 8-bit, or linear light 16-bit: deterministic bytes (core.fileio)
            write_png(path, res.srgb if fmt == "png" else linear_to_png16(res.linear))
            meta["images"][fmt] = name
            meta["sha256"][fmt] = _sha(path)
        meta.update(status="ok", time_s=time.perf_counter() - t0, report=res.report)
    write_json(out_dir / f"{job.stem}.json", meta)
    return _row(meta)


def _row(meta: dict) -> dict:
    rep = meta.get("report") or {}
    return {"index": meta["index"], "key": meta["key"], "status": meta["status"],
            "error": meta.get("error", ""), "time_s": round(meta.get("time_s", 0.0), 4),
            "render_s": round(rep.get("timings_s", {}).get("total", 0.0), 4),
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
    out.mkdir(parents=True, exist_ok=True)
    if not os.access(out, os.W_OK):
        raise SpecError("jobspec.output.dir", f"{out} is not writable")
    swept = sweep_temporaries(out)
    todo = [j for j in js.jobs if not job_done(j, out, js.formats)]
    skipped = len(js.jobs) - len(todo)
    t0 = time.perf_counter()
    if todo:
        if scheduler is None and workers <= 1:
            _run_serial(todo, out, js.formats, progress)
        else:
            _run_dask(todo, out, js.formats, workers, scheduler, progress)
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


def _run_dask(todo, out, formats, workers, scheduler, progress):
    """The jobs as Dask tasks on a new ``LocalCluster`` or the cluster at ``scheduler``; the
    workers close their resources for the run (an id of its own) however it ends."""
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        # ":0": the scheduler's HTTP server on a free port (None still takes 8787, and
        # fails when another cluster holds it)
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0")
    client = Client(scheduler if cluster is None else cluster)
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
        try:
            client.cancel(futs)            # after a failure: start no job after the release
            client.run(release_owned, run_id, on_error="ignore")
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


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
