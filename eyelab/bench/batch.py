"""``eyelab bench batch``: throughput of ``eyelab batch`` against one ``eyelab render``
process per image, and its scaling from 1 to 2 worker processes.

N small jobs (the chart scene, 320 x 240, S = 8, a sweep of N prescriptions) are run:
(a) as N separate ``eyelab render`` processes, one after another (each pays the start-up:
imports, GL context, shader compilation, scene building); (b) by ``eyelab batch`` in one
process; (c) by ``eyelab batch --workers 2`` (a Dask LocalCluster of two processes).
Wall times, images per second, the ratios, and a check that (b) and (c) wrote the same
bytes.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from eyelab.render import OFFSCREEN_WINDOW, WINDOW_ENV

JOB_SPEC = """
[base]
render = {{scene = "chart", width = 320, height = 240, samples = 8, fov_y_deg = 10.0}}

[output]
dir = "out"

[sweep]
"eye.rx" = [{rxs}]
"""


def _rx(i: int) -> str:
    return f"-{0.25 * (i + 1):.2f} DS" if i < 60 else f"+{0.25 * (i - 59):.2f} DS"


def run_batch_bench(jobs: int = 100) -> dict:
    env = dict(os.environ, **{WINDOW_ENV: OFFSCREEN_WINDOW})
    cli = [sys.executable, "-P", "-m", "eyelab.apps.cli"]
    with tempfile.TemporaryDirectory(prefix="eyelab-bench-batch-") as tmp:
        tmp = Path(tmp)
        rxs = [_rx(i) for i in range(jobs)]
        spec = tmp / "jobs.toml"
        spec.write_text(JOB_SPEC.format(rxs=", ".join(f'"{r}"' for r in rxs)))
        times = {}
        for label, extra in (("batch_1_worker", []), ("batch_2_workers", ["--workers", "2"])):
            t = time.perf_counter()
            subprocess.run(cli + ["batch", str(spec), "--quiet", "-o", str(tmp / label)]
                           + extra, env=env, check=True, capture_output=True)
            times[label] = time.perf_counter() - t
        one = {p.name: p.read_bytes() for p in (tmp / "batch_1_worker").glob("job-*.png")}
        two = {p.name: p.read_bytes() for p in (tmp / "batch_2_workers").glob("job-*.png")}
        # the same jobs as spec files, one `eyelab render` process each
        from eyelab.jobs.batch import load_job_spec
        from eyelab.spec import dump_spec

        paths = []
        for job in load_job_spec(spec).jobs:
            paths.append(tmp / f"r{job.index}.toml")
            paths[-1].write_text(dump_spec(job.data))
        t = time.perf_counter()
        for p in paths:
            subprocess.run(cli + ["render", str(p), "-o", str(p.with_suffix(".png"))],
                           env=env, check=True, capture_output=True)
        times["separate_processes"] = time.perf_counter() - t
    ratio = times["separate_processes"] / times["batch_1_worker"]
    scaling = times["batch_1_worker"] / times["batch_2_workers"]
    summary = [f"{jobs} jobs (chart, 320x240, S = 8):",
               f"  {jobs} eyelab render processes: {times['separate_processes']:.1f} s "
               f"({jobs / times['separate_processes']:.2f} images/s)",
               f"  eyelab batch, 1 worker: {times['batch_1_worker']:.1f} s "
               f"({jobs / times['batch_1_worker']:.2f} images/s): x{ratio:.1f}",
               f"  eyelab batch, 2 workers: {times['batch_2_workers']:.1f} s: x{scaling:.2f} "
               f"over 1 worker; same bytes: {one == two}"]
    return {"benchmark": "batch", "jobs": jobs, "times_s": times,
            "throughput_ratio_vs_processes": ratio, "scaling_1_to_2_workers": scaling,
            "same_bytes_1_vs_2_workers": one == two, "summary": summary}
