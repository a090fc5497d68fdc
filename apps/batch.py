"""``eyelab batch JOBSPEC [-o DIR] [--workers N] [--scheduler ADDRESS]``: render a job grid
(:mod:`eyelab.jobs.batch`), resumable; exit status 0 when every job succeeded, 1 when some were
invalid or failed (listed), 2 for a bad job spec or option."""

from __future__ import annotations

import sys


def add_parser(sub) -> None:
    b = sub.add_parser("batch", help="render a job grid (scenes x eyes x lenses x views), "
                       "resumable, serially or on Dask")
    b.add_argument("jobspec", help="job spec (TOML): base spec, [output], [sweep], [[cases]]")
    b.add_argument("-o", "--output", help="output folder (overrides output.dir)")
    b.add_argument("--workers", type=int, default=1,
                   help="worker processes of a local Dask cluster (1: in this process)")
    b.add_argument("--scheduler", help="address of a running Dask scheduler "
                   "(tcp://host:port) to send the jobs to instead")
    from eyelab.jobs.batch import MAX_JOBS

    b.add_argument("--max-jobs", type=int, default=MAX_JOBS, metavar="N",
                   help=f"refuse job specs that expand to more than N jobs (default "
                   f"{MAX_JOBS}; the grid is counted before it is made)")
    from eyelab.apps.common import add_max_memory, add_quiet

    add_quiet(b)
    add_max_memory(b)


def run(args) -> int:
    from eyelab.apps.common import apply_max_memory
    from eyelab.core.errors import SpecError
    from eyelab.jobs.batch import load_job_spec, run_batch, validate_jobs
    from eyelab.jobs.jobspec import fixed_lens_note

    if not 1 <= args.max_jobs <= 10**7:
        raise SpecError("--max-jobs", f"must be in [1, 10000000], got {args.max_jobs}")
    if not 1 <= args.workers <= 256:
        raise SpecError("--workers", f"must be in [1, 256], got {args.workers}")
    if args.scheduler is not None and not args.scheduler.startswith(("tcp://", "tls://",
                                                                      "inproc://")):
        raise SpecError("--scheduler", f"must be an address like tcp://host:8786, got "
                                       f"{args.scheduler!r}")
    from eyelab.render import use_offscreen

    use_offscreen()
    apply_max_memory(args)       # the jobs (and Dask workers, via the environment) check it
    js = load_job_spec(args.jobspec, out_dir=args.output, max_jobs=args.max_jobs)
    validate_jobs(js)            # what would fail every job: refused before anything is written
    note = fixed_lens_note(js)   # said before the run (with the output, not the errors):
    if note:                     # a sweep's lens that stays fixed
        print(note, flush=True)
    res = run_batch(js, workers=args.workers, scheduler=args.scheduler,
                    progress=not args.quiet and sys.stderr.isatty())
    print(f"{res['jobs']} jobs: {res['run']} run, {res['skipped_done']} already done, "
          f"{len(res['errors'])} not ok ({res['wall_s']:.1f} s); "
          f"{js.out_dir}/summary.csv, {js.out_dir}/index.html")
    for idx, err in res["errors"]:
        print(f"  job {idx}: {err}")
    return 1 if res["errors"] else 0
