"""Run a vectorised function over row chunks on a thread pool.

numpy releases the GIL inside large array operations, so threads over contiguous row
blocks use several cores without copying inputs to other processes.
"""

from __future__ import annotations

import os
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
    with ThreadPoolExecutor(max_workers=workers) as ex:
        return list(ex.map(lambda ab: fn(*ab), bounds))


_POOL = None


def split_rows(fn, n: int, *, workers: int | None = None) -> None:
    """Call ``fn(start, stop)`` on ``workers`` contiguous row ranges covering ``range(n)``,
    on a process-wide thread pool (created once: per-frame work such as decoding a
    read-back must not pay for new threads). For numpy kernels that release the GIL."""
    global _POOL
    workers = workers or default_workers()
    if workers == 1 or n < 2 * workers:
        fn(0, n)
        return
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=default_workers(),
                                   thread_name_prefix="eyelab-rows")
    edges = [n * k // workers for k in range(workers + 1)]
    list(_POOL.map(lambda k: fn(edges[k], edges[k + 1]), range(workers)))
