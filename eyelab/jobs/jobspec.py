"""Job specs for batch generation: a base spec plus axes to sweep, counted, expanded into
jobs and checked before any job runs (:mod:`eyelab.jobs.batch` runs them).

The job spec's format is described in :mod:`eyelab.jobs.batch`.
"""

from __future__ import annotations

import copy
import functools
import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from eyelab.core.cache import content_key
from eyelab.core.errors import SpecError

FORMATS = ("png", "png16")
#: Most jobs a job spec may expand to unless the caller raises it (``--max-jobs``): the
#: grid is counted before it is expanded, so a mistaken sweep is refused at once.
MAX_JOBS = 10_000
#: Most values one range {start, stop, step} may give.
MAX_RANGE_VALUES = 10_000
JOB_KEYS = {"spec", "base", "output", "sweep", "cases"}
OUTPUT_KEYS = {"dir", "formats"}


@dataclass(frozen=True)
class Job:
    """One job: its index, the spec table it renders, and the dotted keys that made it.
    Its key digests the resolved spec, eyelab's version and the contents of the files the
    spec reads (a mesh scene, points surfaces, a frame trace): a job whose input file
    changed is not done."""

    index: int
    data: dict
    params: dict

    @functools.cached_property
    def key(self) -> str:
        from eyelab import __version__

        return content_key(spec=json.dumps(self.data, sort_keys=True, default=str),
                           version=__version__,
                           files=[_file_digest(p) for p in input_files(self.data)])

    @property
    def stem(self) -> str:
        return f"job-{self.index:05d}-{self.key[:10]}"


def input_files(data: dict) -> list:
    """The existing files a spec table reads (:func:`eyelab.spec.surfacefile.file_refs`),
    in a fixed order."""
    from eyelab.spec.surfacefile import file_refs

    return [t[k] for t, k, _ in file_refs(data) if Path(t[k]).is_file()]


def _file_digest(path: str) -> str:
    """SHA-256 of a file's bytes (memoised by path, size and modification time)."""
    st = Path(path).stat()
    return _digest(str(Path(path).resolve()), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=256)
def _digest(path: str, size: int, mtime_ns: int) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class JobSpec:
    """jobs : the expanded :class:`Job` list; out_dir : absolute output folder; formats;
    source : the job spec's path; axes : ((dotted key, values), ...) of the sweep;
    cases : the [[cases]] tables."""

    jobs: tuple
    out_dir: Path
    formats: tuple
    source: str
    axes: tuple = ()
    cases: tuple = ()
    #: Where the base's keys came from: the ``spec = FILE`` path (None: the built-in
    #: spec) and the ``[base]`` table merged over it (a bad key is blamed on its source).
    spec_file: str | None = None
    base_table: dict | None = None

    def base_origin(self, field: str) -> str:
        """The job spec's part that set the base spec's ``field`` (a spec field name such
        as "eye.model" or "points[0].distance_m"): ``jobspec.base`` when its ``[base]``
        holds it, else the spec file (``jobspec.spec (FILE)``)."""
        import re

        t = self.base_table or {}
        for part in (p for p in re.split(r"[.\[\]]", field) if p):
            if isinstance(t, list) and part.isdigit() and int(part) < len(t):
                t = t[int(part)]
            elif isinstance(t, dict) and part in t:
                t = t[part]
            else:
                return ("jobspec.base" if self.spec_file is None else
                        f"jobspec.spec ({Path(self.spec_file).name})")
            if not isinstance(t, (dict, list)):
                break
        return "jobspec.base"


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


def load_job_spec(path, *, out_dir=None, max_jobs: int = MAX_JOBS) -> JobSpec:
    """Read and expand a job spec file (every field checked, errors name it): the grid is
    counted before it is expanded (more than ``max_jobs`` is refused), the output folder
    checked and made absolute. Values are checked as specs by :func:`validate_jobs`."""
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
    cases = js.get("cases", [])
    if not isinstance(cases, list) or not all(isinstance(c, dict) for c in cases):
        raise SpecError("jobspec.cases", "must be an array of tables ([[cases]])")
    axes = _axes(js.get("sweep", {}), max_jobs, len(cases))
    combos = _combinations(axes) + [dict(c) for c in cases] or [{}]
    jobs = []
    for i, params in enumerate(combos):
        data = copy.deepcopy(base)
        for k, v in params.items():
            _set(data, k, v, f"jobspec.job[{i}].{k}")
        jobs.append(Job(i, data, params))
    spec_file = js.get("spec")
    return JobSpec(tuple(jobs), folder, formats, str(p), tuple(axes[1].items()),
                   tuple(dict(c) for c in cases),
                   None if spec_file is None else str(spec_file),
                   copy.deepcopy(js.get("base", {})))


def validate_jobs(js: JobSpec) -> None:
    """Refuse up front (:class:`SpecError`, before anything is written) what would make
    jobs invalid: the first job as a whole (base spec and the first value of every axis:
    parsed, one eye or two, within the memory limit), then every axis value in the first job's
    place and every case. The field names where the bad value came from: the job spec's
    ``[base]``, a sweep value or a case, and the spec key."""
    first = js.jobs[0]
    origin = ({k: f'jobspec.sweep."{k}"[0]' for k, _ in js.axes} if js.axes else
              dict.fromkeys(first.params, "jobspec.cases[0]"))
    _check_job(first.data, origin, js.base_origin)
    for key, values in js.axes:
        for i, v in enumerate(values[1:], 1):
            data = copy.deepcopy(first.data)
            _set(data, key, v, f'jobspec.sweep."{key}"[{i}]')
            _check_job(data, {}, f'jobspec.sweep."{key}"[{i}]')
    first_case = len(js.jobs) - len(js.cases)
    for i, job in enumerate(js.jobs[first_case:]):
        if job.index != 0:
            _check_job(job.data, {}, f"jobspec.cases[{i}]")


def fixed_lens_note(js: JobSpec) -> str | None:
    """One line for a grid whose jobs change the eye's Rx while their lens keeps a
    prescription of its own (the base spec's ``lens.rx`` or surfaces, e.g. the built-in
    default's): such a lens is not made for each job's eye. None where every lens follows
    its eye (a ``[lens]`` without ``rx``) or the jobs set the lens themselves."""
    for job in js.jobs:
        eye_keys = [k for k in job.params if k == "eye" or (k.startswith("eye.")
                                                            and k.endswith(".rx"))]
        if not eye_keys or any(k == "lens" or k.startswith("lens.rx") or
                               k.startswith(("lens.right", "lens.left", "lens.front",
                                             "lens.back")) for k in job.params):
            continue
        lens = job.data.get("lens")
        if not isinstance(lens, dict):
            continue
        own = [k for k in ("rx", "front", "back") if k in lens]
        if own:
            what = (f"lens.rx = {lens['rx']!r}" if "rx" in lens else
                    "its lens.front / lens.back surfaces")
            return (f"note: the jobs change {eye_keys[0]} but keep {what} from the base "
                    f"spec: the lens is not made for each eye (sweep \"lens.rx\" too, or "
                    f"name a base spec = \"FILE\" whose [lens] has no rx)")
    return None


def _check_job(data: dict, origin: dict, where) -> None:
    """Parse one job's spec as the job would; a :class:`SpecError` is re-raised naming
    where the bad value came from — ``origin[key]`` when the field is under a dotted key
    of ``origin``, else ``where`` (a name, or a function of the field giving one) — and the
    spec field. The memory limit is checked for one image: a job with two eyes renders
    them one after the other."""
    from eyelab.imaging.memory import check_memory, memory_limit
    from eyelab.spec import parse_spec

    try:
        spec = parse_spec(copy.deepcopy(data), "eyelab batch")
        check_memory(spec.render, memory_limit())
    except SpecError as e:
        # the key itself, a field under it, or a table on its path (a swept "eye.middle.rx"
        # makes the table eye.middle)
        hit = [k for k in origin if e.field == k or e.field.startswith((k + ".", k + "["))
               or k.startswith(e.field + ".")]
        blame = origin[hit[0]] if hit else where if isinstance(where, str) else where(e.field)
        raise SpecError(f"{blame} ({e.field})", e.message) from None


def _base_spec(js: dict, here: Path) -> dict:
    """The spec every job starts from: ``spec`` (else the built-in one) with ``[base]``
    merged over it; relative paths (of ``spec``, of a mesh scene file, of ``[base]``'s
    points files) are from ``here``, the job spec's folder; the spec file's own points
    files from its folder."""
    from eyelab.spec import read_spec_data

    base_path = js.get("spec")
    if base_path is not None and not isinstance(base_path, str):
        raise SpecError("jobspec.spec", "must be a spec file path")
    if base_path is not None:
        base_path = Path(base_path) if Path(base_path).is_absolute() else here / base_path
    from eyelab.spec.surfacefile import absolute_files

    base = copy.deepcopy(read_spec_data(base_path)[0])
    if base_path is not None:            # its files are relative to its own folder
        absolute_files(base, base_path.parent)
    extra = js.get("base", {})
    if not isinstance(extra, dict):
        raise SpecError("jobspec.base", "must be a table of spec tables")
    _merge(base, absolute_files(copy.deepcopy(extra), here))
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
    from eyelab.core.fileio import check_output_folder

    flag = "--output" if out_dir is not None else "jobspec.output.dir"
    folder = out_dir if out_dir is not None else out.get("dir", "batch-out")
    if not isinstance(folder, (str, Path)):
        raise SpecError(flag, "must be a folder path")
    if out_dir is None and str(folder) and not Path(folder).is_absolute():
        folder = here / folder                       # the job spec's dir: from its folder
    return check_output_folder(flag, folder), tuple(dict.fromkeys(formats))


def _axes(sw, max_jobs: int, n_cases: int = 0) -> tuple:
    """(mode, {dotted key: values}) of the ``[sweep]`` table, its job count checked before
    any job is made: more than ``max_jobs`` with the ``n_cases`` cases is refused."""
    if not isinstance(sw, dict):
        raise SpecError("jobspec.sweep", "must be a table of dotted keys -> lists")
    sw = dict(sw)
    mode = sw.pop("mode", "product")
    if mode not in ("product", "zip"):
        raise SpecError("jobspec.sweep.mode", f"must be 'product' or 'zip', got {mode!r}")
    for k, v in sw.items():
        if isinstance(v, dict):
            sw[k] = v = _range(v, f'jobspec.sweep."{k}"')
        if not isinstance(v, list) or not v:
            raise SpecError(f'jobspec.sweep."{k}"', "must be a non-empty list of values or a "
                                                  "range {start, stop, step}")
    if mode == "zip" and len({len(v) for v in sw.values()}) > 1:
        raise SpecError("jobspec.sweep", f"zip needs lists of one length, got "
                                         f"{ {k: len(v) for k, v in sw.items()} }")
    count = 0 if not sw else len(next(iter(sw.values()))) if mode == "zip" else \
        math.prod(map(len, sw.values()))
    if count + n_cases > max_jobs:
        shape = " x ".join(str(len(v)) for v in sw.values())
        raise SpecError("jobspec.sweep", f"{count + n_cases:,} jobs ({mode} of {shape}"
                        f"{f', plus {n_cases} cases' if n_cases else ''}); at most "
                        f"{max_jobs:,} (--max-jobs raises the limit)")
    return mode, sw


def _combinations(axes) -> list:
    """The sweep's parameter sets (dicts of dotted key -> value), in order."""
    mode, sw = axes
    if not sw:
        return []
    rows = zip(*sw.values(), strict=True) if mode == "zip" else itertools.product(*sw.values())
    return [dict(zip(sw, r, strict=True)) for r in rows]


def _range(t: dict, where: str) -> list:
    """{start, stop, step} -> the numbers start, start + step, ... up to stop inclusive
    (within 1e-9 of a step), rounded to 10 decimals; at most :data:`MAX_RANGE_VALUES`
    (counted before any is made)."""
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
    steps = (stop - start) / step
    if not steps < MAX_RANGE_VALUES:              # inf and huge counts too, before int()
        count = f"{math.floor(steps) + 1:,}" if steps < 1e15 else f"{steps:.3g}"
        raise SpecError(where, f"{count} values; at most {MAX_RANGE_VALUES:,}")
    n = int(math.floor(steps + 1e-9)) + 1
    return [round(start + i * step, 10) for i in range(n)]
