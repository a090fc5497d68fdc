"""Shared state that threads touch, each owned and guarded: the camera reference renderer's
ray count (summed per block, no shared counter), the process-wide row pool of
:func:`~eyelab.core.parallel.split_rows` (made once under a lock, shut down and remade),
and a batch run's renderers and scenes (:class:`~eyelab.jobs.batch.JobResources`, a
:class:`~eyelab.core.parallel.LendingPool`: lent to one job at a time, never closed while
lent, all closed when the run ends; on Dask, one per worker process and run)."""

from __future__ import annotations

import sys
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from eyelab.core import parallel
from eyelab.jobs import batch
from eyelab.jobs.batch import JobResources, load_job_spec, run_batch, run_job


@pytest.fixture
def fast_switching():
    """Switch threads every microsecond (default 5 ms), so that an unguarded
    read-modify-write between threads is likely to lose an update."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(old)


@pytest.fixture
def fresh_pool():
    """No row pool before the test, none left after it."""
    parallel.shutdown_pool()
    yield
    parallel.shutdown_pool()


# ---------------------------------------------------------------- the camera ray count
def test_camera_ray_count_is_exact_on_many_threads(fast_switching):
    """The doublet (dispersive: three channels) at 16 x 16 pixels and 512 rays per pixel and
    channel: 32-pixel blocks, 8 of them on 4 threads. The report counts every ray exactly
    once, and the image is the same bytes as on one thread."""
    from eyelab.imaging.contract import View
    from eyelab.imaging.options import ReferenceQuality
    from eyelab.optics.cameralens.system import get_system
    from eyelab.reference.camera import render_camera
    from eyelab.scene.library import chart_scene

    system = get_system("doublet").focused(1.5)
    view = View(width=16, height=16, fov_y_deg=20.0, near=0.1, far=20.0)
    scene = chart_scene(1.5)
    k = 512
    many = render_camera(scene, system, view, ReferenceQuality(samples=k, workers=4))
    assert many.report["details"]["channels"] == 3
    assert many.report["details"]["rays"] == 16 * 16 * k * 3
    one = render_camera(scene, system, view, ReferenceQuality(samples=k, workers=1))
    assert one.report["details"]["rays"] == many.report["details"]["rays"]
    np.testing.assert_array_equal(one.linear, many.linear)


# ---------------------------------------------------------------------- the row pool
def _covered(n: int, workers: int) -> list:
    """The rows split_rows hands out for ``n`` rows on ``workers`` ranges, sorted."""
    rows, lock = [], threading.Lock()

    def fn(a, b):
        with lock:
            rows.extend(range(a, b))

    parallel.split_rows(fn, n, workers=workers)
    return sorted(rows)


def test_split_rows_works_after_shutdown_pool(fresh_pool):
    assert _covered(100, 4) == list(range(100))
    first = parallel._POOL
    assert first is not None
    parallel.shutdown_pool()
    parallel.shutdown_pool()                       # a second call is harmless
    assert parallel._POOL is None
    assert _covered(101, 4) == list(range(101))
    assert parallel._POOL is not None and parallel._POOL is not first


def test_row_pool_is_made_once_under_concurrent_first_use(fresh_pool, monkeypatch):
    """16 threads call split_rows at once while no pool exists; making a pool takes 50 ms
    (a window for the others to see none and make their own): one pool is made."""
    made = []

    class SlowPool(parallel.ThreadPoolExecutor):
        def __init__(self, *args, **kwargs):
            time.sleep(0.05)
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(parallel, "ThreadPoolExecutor", SlowPool)
    start = threading.Barrier(16)
    results = [None] * 16

    def call(i):
        start.wait()
        results[i] = _covered(64, 4)

    threads = [threading.Thread(target=call, args=(i,)) for i in range(16)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    assert len(made) == 1
    assert all(r == list(range(64)) for r in results)


def test_split_rows_racing_shutdown_pool_never_fails(fresh_pool, fast_switching):
    """Four threads splitting rows while a fifth shuts the pool down again and again: every
    call covers its rows (none meets a pool shut down between its creation and its
    submissions)."""
    errors, stop = [], threading.Event()

    def split():
        while not stop.is_set():
            try:
                assert _covered(40, 4) == list(range(40))
            except Exception as e:         # RuntimeError: cannot schedule new futures...
                errors.append(e)
                return

    threads = [threading.Thread(target=split) for _ in range(4)]
    for t in threads:
        t.start()
    deadline = time.monotonic() + 0.5
    while time.monotonic() < deadline:
        parallel.shutdown_pool(wait=False)
        time.sleep(0.0005)
    stop.set()
    for t in threads:
        t.join(timeout=10)
    assert errors == []


# ------------------------------------------------------------------ batch resources
class FakeRenderer:
    """A renderer that records its uses and closes in ``log`` and the rule breaks in
    ``log.broken``: used by two threads at once, used or closed while closed, closed while
    in use."""

    def __init__(self, name, quality, log):
        self.key = (name, repr(quality))
        self.log = log
        self.users = 0
        self.closed = 0
        self.lock = threading.Lock()

    def render(self, scene, eye=None, lens=None, view=None):
        with self.lock:
            self.users += 1
            if self.users > 1:
                self.log.broken.append(f"{self.key} used by two threads")
            if self.closed:
                self.log.broken.append(f"{self.key} used after close")
        self.log.append(("use", self))
        time.sleep(0.001)
        with self.lock:
            self.users -= 1
        h, w = (view.height, view.width) if view is not None else (2, 2)
        return SimpleNamespace(srgb=np.zeros((h, w, 3), np.uint8),
                               linear=np.zeros((h, w, 3), np.float32),
                               report={"renderer": "fake", "scene": scene})

    def close(self):
        with self.lock:
            if self.users:
                self.log.broken.append(f"{self.key} closed while in use")
            if self.closed:
                self.log.broken.append(f"{self.key} closed twice")
            self.closed += 1
        self.log.append(("close", self))


class Log(list):
    def __init__(self):
        super().__init__()
        self.broken = []
        self.made = []


def _fakes(log):
    def make_renderer(name, quality):
        r = FakeRenderer(name, quality, log)
        log.made.append(r)
        return r

    return {"make_renderer": make_renderer,
            "build_scene": lambda source: f"scene of {source.name}"}


def _source(name="chart"):
    from eyelab.scene.scene import SceneSource

    return SceneSource(name)


def test_resources_reuse_evict_idle_and_close_lent_ones_when_given_back():
    log = Log()
    res = JobResources(max_renderers=2, **_fakes(log))
    with res.renderer("raster", 1) as a:
        pass
    with res.renderer("raster", 1) as again:
        assert again is a                          # kept warm between jobs
    with res.renderer("raster", 2) as b, res.renderer("raster", 3) as c:
        # three exist while two jobs hold theirs: only the idle one (a) made room
        assert a.closed == 1 and not b.closed and not c.closed
        res.close()                                # the run ends while they are lent
        assert not b.closed and not c.closed
        b.render(res)
    assert b.closed == 1 and c.closed == 1         # closed as they were given back
    assert res.closed and log.broken == []
    with pytest.raises(RuntimeError, match="closed"), res.renderer("raster", 1):
        pass
    res.close()                                    # a second close is harmless


@pytest.mark.parametrize("threads, room", [(3, 4), (8, 1)])
def test_resources_never_close_a_renderer_a_job_uses(threads, room):
    """``threads`` threads, 25 jobs each, over 3 renderer kinds with room for ``room``
    renderers: renderers are reused (3, 4: most jobs find an idle one of their kind) or
    made, evicted and remade all the time (8, 1), yet none is used by two jobs at once or
    closed while a job uses it; at the end every renderer made is closed exactly once."""
    log = Log()
    res = JobResources(max_renderers=room, **_fakes(log))
    start = threading.Barrier(threads)

    def jobs(i):
        start.wait()
        for j in range(25):
            with res.renderer("raster", (i + j) % 3) as r:
                r.render(res.scene(_source()))

    workers = [threading.Thread(target=jobs, args=(i,)) for i in range(threads)]
    for t in workers:
        t.start()
    for t in workers:
        t.join(timeout=30)
    assert sum(op == "use" for op, _ in log) == 25 * threads
    res.close()
    assert log.broken == []
    assert len(log.made) >= 3 and all(r.closed == 1 for r in log.made)


def test_resources_build_each_scene_once_and_keep_the_newest():
    built = []

    def build(source):
        built.append(source.name)
        return f"scene of {source.name}"

    with JobResources(max_scenes=2, make_renderer=None, build_scene=build) as res:
        a, b = _source("a"), _source("b")
        assert res.scene(a) == "scene of a" and res.scene(b) == "scene of b"
        res.scene(a)                               # a used last: b is the oldest
        res.scene(_source("c"))
        res.scene(a)
        res.scene(b)
    assert built == ["a", "b", "c", "b"]


JOBS = """
[base]
render = {scene = "chart", width = 16, height = 16, samples = 1}
[output]
dir = "out"
[sweep]
"eye.rx" = ["-1.00 DS", "-2.00 DS", "-3.00 DS"]
[[cases]]
"render.samples" = 2
"""


def test_a_run_closes_its_renderers_when_it_ends(tmp_path, monkeypatch):
    """Four jobs of two renderer kinds (samples 1 and 2), serially: the run makes one
    JobResources, two renderers (the first kept warm for its three jobs), closes both
    after the last use, and writes every job."""
    log, runs = Log(), []

    class Recorded(JobResources):
        def __init__(self, **kwargs):
            super().__init__(**_fakes(log), **kwargs)
            runs.append(self)

    monkeypatch.setattr(batch, "JobResources", Recorded)
    spec = tmp_path / "jobs.toml"
    spec.write_text(JOBS)
    js = load_job_spec(spec)
    res = run_batch(js, progress=False)
    assert res["run"] == 4 and res["errors"] == []
    assert len(runs) == 1 and runs[0].closed
    assert len(log.made) == 2 and all(r.closed == 1 for r in log.made)
    ops = [op for op, _ in log]
    assert ops.count("use") == 4
    assert ops[-2:] == ["close", "close"]          # closed after every use, not before
    assert log.broken == []


def test_run_job_without_resources_closes_its_own(tmp_path, monkeypatch):
    log = Log()

    class Recorded(JobResources):
        def __init__(self, **kwargs):
            super().__init__(**_fakes(log), **kwargs)

    monkeypatch.setattr(batch, "JobResources", Recorded)
    spec = tmp_path / "jobs.toml"
    spec.write_text(JOBS)
    js = load_job_spec(spec)
    js.out_dir.mkdir()
    row = run_job(js.jobs[0], js.out_dir, js.formats)
    assert row["status"] == "ok"
    assert [op for op, _ in log] == ["use", "close"] and log.broken == []


def test_process_owned_is_one_per_key_and_closed_on_release():
    """A Dask worker's threads asking at once for a run's resources get one object (made
    once); the release at the run's end closes it, and another run's are its own."""
    made = []

    def make():
        time.sleep(0.02)                           # a window for a second maker
        made.append(JobResources())
        return made[-1]

    run_id = "test-run-shared-state"
    start = threading.Barrier(8)
    got = [None] * 8

    def ask(i):
        start.wait()
        got[i] = parallel.process_owned(run_id, make)

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    try:
        assert len(made) == 1 and all(g is made[0] for g in got)
        assert parallel.process_owned(run_id + "-other", JobResources) is not made[0]
    finally:
        assert parallel.release_owned(run_id) is True
        assert parallel.release_owned(run_id + "-other") is True
    assert made[0].closed
    assert parallel.release_owned(run_id) is False
