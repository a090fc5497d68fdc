"""Run a vectorised function over row chunks on a thread pool; lend costly objects to one
thread at a time; run work on a worker thread while a GL thread goes on (:func:`on_worker`).

numpy releases the GIL inside large array operations, so threads over contiguous row
blocks use several cores without copying inputs to other processes.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor


def default_workers() -> int:
    return max(1, min(len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                      else (os.cpu_count() or 1), 16))


def map_row_chunks(fn, n: int, *, workers: int | None = None, block: int = 16_384):
    """Call ``fn(start, stop)`` for contiguous row blocks of at most ``block`` rows covering
    ``range(n)``, on ``workers`` threads.

    Blocks of ~16k rows keep every temporary array (~130 kB) in cache, which matters more
    than the thread count for these memory-bound kernels. Returns the results in block
    order; the blocks do not depend on the thread count, so neither does the result.
    """
    workers = workers or default_workers()
    bounds = [(a, min(a + block, n)) for a in range(0, n, block)] or [(0, 0)]
    if workers == 1 or len(bounds) == 1:
        return [fn(a, b) for a, b in bounds]
    ex = ThreadPoolExecutor(max_workers=workers)
    try:
        return list(ex.map(lambda ab: fn(*ab), bounds))
    finally:              # after Ctrl-C or a failure, start no further block
        ex.shutdown(wait=True, cancel_futures=True)


#: The process-wide pool of :func:`split_rows`: made on first use, ended by
#: :func:`shutdown_pool` (at the latest when the interpreter exits).
_POOL: ThreadPoolExecutor | None = None
#: Guards ``_POOL``: its creation, its shutdown, and every submission to it.
_POOL_LOCK = threading.Lock()


def split_rows(fn, n: int, *, workers: int | None = None) -> None:
    """Call ``fn(start, stop)`` on ``workers`` contiguous row ranges covering ``range(n)``,
    on a process-wide thread pool (created once: per-frame work such as decoding a
    read-back must not pay for new threads). For numpy kernels that release the GIL.

    Safe to call from several threads at once, and after :func:`shutdown_pool` (a new pool
    is made). Returns when every range is done, raising the exception of the first range
    (in row order) that failed, if any. ``fn`` must not call :func:`split_rows` itself (it
    would wait for threads of the pool it occupies).
    """
    global _POOL
    workers = workers or default_workers()
    if workers == 1 or n < 2 * workers:
        fn(0, n)
        return
    edges = [n * k // workers for k in range(workers + 1)]
    # submitted under the lock, so that no shutdown_pool comes between the pool's creation
    # and the submissions; a pool shut down afterwards still finishes them
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=default_workers(),
                                       thread_name_prefix="eyelab-rows")
        futures = [_POOL.submit(fn, edges[k], edges[k + 1]) for k in range(workers)]
    try:
        for f in futures:
            f.result()
    finally:                    # after a failure: drop the ranges not yet started
        for f in futures:
            f.cancel()


def shutdown_pool(*, wait: bool = True) -> None:
    """End the process-wide pool of :func:`split_rows`, after the work already given to it
    (``wait``: return only when it is done). Safe to call repeatedly and from any thread; a
    later :func:`split_rows` makes a new pool. Registered to run at interpreter exit."""
    global _POOL
    with _POOL_LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=wait)


atexit.register(shutdown_pool)


class LendingPool:
    """Costly closeable objects (renderers: GL contexts, caches) kept by key and lent to one
    user at a time, for threads that share them; a context manager that closes them all.

    :meth:`lend` gives an idle object made for the key, else ``make()``'s; no other user
    gets it, and nothing closes it, until the ``with`` block ends. Before an object is
    made, the least recently used idle ones are closed until at most ``max_items`` exist
    with it, so there are never more than that or than the most objects lent at once.
    :meth:`close` closes the idle objects at once and each lent one when it is given back;
    nothing is lent afterwards.

    >>> class Thing:
    ...     def __init__(self, key): self.key = key
    ...     def close(self): print("closed", self.key)
    >>> with LendingPool(1) as pool:
    ...     with pool.lend("a", lambda: Thing("a")) as a:
    ...         pass
    ...     with pool.lend("a", lambda: Thing("a")) as again:
    ...         print(again is a)          # the idle one, lent again
    ...     with pool.lend("b", lambda: Thing("b")) as b:
    ...         pass                       # room made for it: "a" closed
    True
    closed a
    closed b
    """

    def __init__(self, max_items: int, name: str = "pool"):
        if max_items < 1:
            raise ValueError(f"{name}: max_items must be >= 1, got {max_items}")
        self.max_items = max_items
        self.name = name
        self._lock = threading.Lock()       # guards the three below
        self._idle = []                     # (key, object) not lent, least recently used first
        self._lent = 0                      # objects lent now
        self._closed = False

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    @contextlib.contextmanager
    def lend(self, key, make):
        """Lend an object for ``key`` (hashable) for the ``with`` block: an idle one made
        for the same key, else a new one, ``make()`` (called without the lock held)."""
        obj = self._borrow(key, make)
        try:
            yield obj
        finally:
            with self._lock:
                self._lent -= 1
                if not self._closed:
                    self._idle.append((key, obj))
                    obj = None
            if obj is not None:
                obj.close()

    def _borrow(self, key, make):
        with self._lock:
            if self._closed:
                raise RuntimeError(f"{self.name}: closed (its owner has ended)")
            for i in range(len(self._idle) - 1, -1, -1):
                if self._idle[i][0] == key:
                    self._lent += 1
                    return self._idle.pop(i)[1]
            stale = []
            while self._idle and len(self._idle) + self._lent >= self.max_items:
                stale.append(self._idle.pop(0)[1])
            self._lent += 1
        try:
            close_all(stale)
            return make()
        except BaseException:
            with self._lock:
                self._lent -= 1
            raise

    def close(self) -> None:
        """Close the idle objects now and each lent one when it is given back. Safe to call
        repeatedly."""
        with self._lock:
            self._closed = True
            stale = [obj for _, obj in self._idle]
            self._idle.clear()
        close_all(stale)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: Objects this process keeps on behalf of an owner elsewhere (a Dask worker's share of a
#: batch run), by key: see :func:`process_owned`.
_OWNED: dict = {}
_OWNED_LOCK = threading.Lock()


def process_owned(key, make):
    """The closeable object this process keeps under ``key`` (hashable): ``make()``'s, made
    by the first caller (under a lock) and shared by every thread of the process until
    :func:`release_owned` closes it."""
    with _OWNED_LOCK:
        if key not in _OWNED:
            _OWNED[key] = make()
        return _OWNED[key]


def release_owned(key) -> bool:
    """Close and forget the object kept under ``key``; whether there was one. A later
    :func:`process_owned` of the key makes a new one."""
    with _OWNED_LOCK:
        obj = _OWNED.pop(key, None)
    if obj is not None:
        obj.close()
    return obj is not None


def close_all(objects) -> None:
    """Close every object, even when one fails; the first failure is raised after."""
    first = None
    for obj in objects:
        try:
            obj.close()
        except Exception as e:
            first = first or e
    if first is not None:
        raise first


@contextlib.contextmanager
def scoped_environ(*names: str, **values: str):
    """Environment variables ``values`` set for the block (processes started in it inherit
    them), and those and ``names`` restored after — as they were, or absent — whatever the
    block set."""
    before = {k: os.environ.get(k) for k in (*names, *values)}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def on_worker(fn, name: str = "eyelab-worker", idle=None):
    """Run ``fn()`` on a worker thread, yielding ``idle`` while it runs (a window's ticks go
    on between the yields, each after at most 20 ms); the generator's return value is
    ``fn``'s value, its exception raised here. For numpy and embree work that releases the
    GIL while a GL thread stays responsive."""
    out, failed = [], []

    def work():
        try:
            out.append(fn())
        except BaseException as e:          # re-raised on the caller's thread below
            failed.append(e)

    worker = threading.Thread(target=work, name=name, daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(timeout=0.02)
            yield idle
    finally:
        worker.join()
    if failed:
        raise failed[0]
    return out[0]


#: What a progressive renderer's inner frame generator yields at a checkpoint of its
#: passes that gets no image (or while a worker averages one): a step of its own, unlike a
#: set-up step's None, so that two eyes' frames pair up checkpoint by checkpoint.
NO_IMAGE = "no image"


def relabel(steps, idle=None):
    """Yield ``idle`` for each step of the generator ``steps``; return its value (the
    ``yield from`` of a stepped computation inside a generator that yields other
    values)."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value
        yield idle


def run_steps(steps):
    """Run the generator ``steps`` to its end without pausing; return its value."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value
