"""``eyelab bench WHAT``: one subcommand per benchmark (each with only its own flags), the
run it starts, and its JSON written atomically with the summary printed."""

from __future__ import annotations

import json
import re

from eyelab.apps.common import add_quiet
from eyelab.core.errors import SpecError
from eyelab.core.fileio import write_report
from eyelab.imaging.contract import View

#: The image sizes a benchmark's --size takes: the view's own range (render.width; the
#: height's is the same).
_SIZE_RANGE = View.LIMITS["render.width"]

#: The benchmarks: name -> (help, the flags it takes beyond -o/--quiet).
BENCHES = {
    "optics": ("throughput of the optics engine", ("points", "repeats")),
    "blurfield": ("blur-field precompute time and accuracy", ("repeats",)),
    "render": ("raster frame times per stage and per skip; the default frames, old vs new",
               ("repeats", "against", "quality_json", "frames_only")),
    "quality": ("error against converged references vs time, every renderer",
                ("preset", "size", "plot", "truth_spp", "reference_spp", "configs", "scenes",
                 "merge", "omit", "truth_cache")),
    "stability": ("random configurations against the engine and the renderers", ("preset",)),
    "memory": ("resident memory over many renders; estimate vs peak of mesh files",
               ("quick", "mesh_triangles", "memory_only")),
    "inspect": ("the inspector's response to changes", ("quick",)),
    "batch": ("eyelab batch against one process per image", ("quick",)),
    "imagebased": ("Heidrich's image-based model per angle threshold", ("quick", "repeats")),
    "design": ("the progressive design, analytic vs optimised as worn: optimiser time and "
               "figures of merit", ()),
    "psf": ("the eye's wave-optics PSF: its cost; the frame with higher-order aberrations",
            ("repeats",)),
    "schematic": ("a schematic eye's retinal image: raster frame cost against the thin "
                  "eye's, raster against the reference's rays from the retina, and both "
                  "against forward rays on small dots across the field",
                  ("repeats", "quick")),
    "lenslets": ("myopia-control lenses in the raster: frame cost against the "
                 "single-vision lens, raster against the reference", ("repeats", "quick")),
}


def add_parser(sub) -> None:
    """``eyelab bench WHAT``: one subcommand per benchmark, each with its own flags (a flag
    of another benchmark is refused by argparse)."""
    be = sub.add_parser("bench", help="benchmarks (print numbers and write JSON)")
    sub = be.add_subparsers(dest="what", required=True, metavar="WHAT")
    for name, (text, flags) in BENCHES.items():
        b = sub.add_parser(name, help=text, description=text)
        add_quiet(b)
        b.add_argument("-o", "--output", help=f"JSON output file (default bench-{name}.json)")
        for flag in flags:
            _BENCH_FLAGS[flag](b, name)


def _add_preset(b, name) -> None:
    pre = b.add_mutually_exclusive_group()
    quick, full = (("160x120, two configurations (the default; CI runs it)",
                    "1024x768 and every configuration") if name == "quality" else
                   ("10^4 engine cases (CI runs it; the default is 10^5)", "10^6 cases"))
    pre.add_argument("--quick", action="store_true", help=quick)
    pre.add_argument("--full", action="store_true", help=full)


_BENCH_FLAGS = {
    "preset": _add_preset,
    "quick": lambda b, name: b.add_argument("--quick", action="store_true",
                                            help="a small, fast run"),
    "frames_only": lambda b, name: b.add_argument(
        "--frames-only", action="store_true",
        help="only the default frames (uncorrected, through the lens, emmetrope, the API's "
             "first and second call), three rounds of processes"),
    "points": lambda b, name: b.add_argument(
        "--points", type=int, default=1_000_000,
        help="points per wavefront-tracing batch (default 1e6)"),
    "repeats": lambda b, name: b.add_argument("--repeats", type=int, default=3,
                                              help="repeats, best taken (default 3)"),
    "size": lambda b, name: b.add_argument(
        "--size", metavar="WxH", help="image size instead of the preset's (each in the "
        f"range of render.width / render.height: {_SIZE_RANGE[0]}-{_SIZE_RANGE[1]})"),
    "plot": lambda b, name: b.add_argument("--plot", help="also write the error-vs-time "
                                           "plot (PNG) here"),
    "truth_spp": lambda b, name: b.add_argument(
        "--truth-spp", type=int, help="samples per pixel of the converged reference"),
    "reference_spp": lambda b, name: b.add_argument(
        "--reference-spp", help="the reference's ladder, e.g. 4,16,64"),
    "configs": lambda b, name: b.add_argument(
        "--configs", help="only these eye/lens configurations or camera cases "
        "(comma-separated names)"),
    "scenes": lambda b, name: b.add_argument("--scenes", help="only these scenes "
                                             "(comma-separated names)"),
    "merge": lambda b, name: b.add_argument(
        "--merge", nargs="+", metavar="JSON", help="combine these partial runs' JSON files "
        "into one (checks, summary and plot recomputed) instead of running"),
    "omit": lambda b, name: b.add_argument(
        "--omit", help="leave out these optional rows (comma-separated: variants, "
        "imagebased), for partial runs on small machines"),
    "mesh_triangles": lambda b, name: b.add_argument(
        "--mesh-triangles", help="triangle counts of the mesh files whose peak is measured "
        "against the estimate (comma-separated; default 10000,1000000,8000000; with "
        "--quick 10000,100000)"),
    "memory_only": lambda b, name: b.add_argument(
        "--only", choices=("renders", "meshes"), help="only the many-renders scenarios or "
        "only the mesh files"),
    "against": lambda b, name: b.add_argument(
        "--against", metavar="REF", help="also time the default frame of this git ref "
        "(checked out with git worktree), side by side in interleaved processes"),
    "quality_json": lambda b, name: b.add_argument(
        "--quality", metavar="JSON", help="a quality benchmark's JSON: its equal-error "
        "speed-ups over the reference go into this report"),
    "truth_cache": lambda b, name: b.add_argument(
        "--truth-cache", help="folder where converged references are kept and re-used "
        "(keyed by scene, configuration, size and spp)"),
}


def run(args) -> int:
    if getattr(args, "points", None) is not None:
        check_range_int("--points", args.points, 1000, 20_000_000)
    if getattr(args, "repeats", None) is not None:
        check_range_int("--repeats", args.repeats, 1, 50)
    output = f"bench-{args.what}.json" if args.output is None else args.output
    from eyelab.core.fileio import check_distinct, check_output

    check_output("--output", output)
    if getattr(args, "plot", None) is not None:
        if not args.plot.lower().endswith(".png"):
            raise SpecError("--plot", f"must be a .png file, got {args.plot!r}")
        check_output("--plot", args.plot)
        check_distinct(**{"--output": output, "--plot": args.plot})
    res = _BENCH_RUNS[args.what](args)
    write_report(output, res)
    for line in res["summary"]:
        print(line)
    print(f"wrote {output}")
    failed = res.get("failed_checks") or []
    if failed:           # the measurement is written; its own checks say it falls short
        import sys

        print(f"eyelab: bench {args.what}: checks failed: {', '.join(failed)}",
              file=sys.stderr)
        return 1
    return 0


def check_range_int(flag: str, value: int, lo: int, hi: int) -> None:
    """A one-line error naming ``flag`` unless lo <= value <= hi."""
    if not lo <= value <= hi:
        raise SpecError(flag, f"must be in [{lo}, {hi}], got {value}")


def _bench_optics(args):
    from eyelab.bench.optics import run_optics_bench

    return run_optics_bench(points=args.points, repeats=args.repeats)


def _bench_render(args):
    from eyelab.bench.render import run_render_bench

    quality = None if args.quality is None else _read_json("--quality", args.quality)
    return run_render_bench(repeats=min(args.repeats, 3), against=args.against,
                            quality=quality, frames_only=args.frames_only)


def _bench_quality(args):
    from eyelab.bench.quality import run_quality_bench
    from eyelab.bench.qualitymerge import merge_results

    if args.merge:
        return merge_results([_read_json("--merge", p) for p in args.merge],
                             plot_path=args.plot, names=args.merge)
    ref_spp = _int_list("--reference-spp", args.reference_spp)
    if ref_spp == []:
        raise SpecError("--reference-spp", "must name at least one spp, got "
                        f"{args.reference_spp!r}")
    return run_quality_bench(quick=not args.full, size=_size("--size", args.size),
                             plot_path=args.plot,
                             truth_spp=args.truth_spp,
                             ref_spp=ref_spp,
                             only_configs=_names(args.configs),
                             only_scenes=_names(args.scenes),
                             truth_cache=args.truth_cache, omit=_names(args.omit))


def _bench_inspect(args):
    from eyelab.render import use_offscreen

    use_offscreen()
    from eyelab.bench.inspector import run_inspect_bench

    return run_inspect_bench(*((320, 240, 4) if args.quick else (800, 600)))


def _bench_imagebased(args):
    from eyelab.render import use_offscreen

    use_offscreen()
    from eyelab.bench.imagebased import run_imagebased_bench

    return run_imagebased_bench(quick=args.quick, repeats=min(args.repeats, 3))


def _bench_batch(args):
    from eyelab.bench.batch import run_batch_bench

    return run_batch_bench(10 if args.quick else 100)


def _bench_memory(args):
    from eyelab.bench.memory import run_memory_bench

    renders = (40, 100) if args.quick else (200, 500)
    meshes = _int_list("--mesh-triangles", args.mesh_triangles) or (
        [10_000, 100_000] if args.quick else [10_000, 1_000_000, 8_000_000])
    if any(n < 1 or n > 100_000_000 for n in meshes):
        raise SpecError("--mesh-triangles", f"must be counts in [1, 1e8], got {meshes}")
    return run_memory_bench(*((0, 0) if args.only == "meshes" else renders),
                            mesh_triangles=() if args.only == "renders" else meshes)


def _bench_stability(args):
    from eyelab.bench.stability import QUICK, run_stability_bench

    if args.quick:     # what CI runs (tests/test_bench_quality.py)
        return run_stability_bench(**QUICK)
    return run_stability_bench(cases=1_000_000 if args.full else 100_000)


def _bench_psf(args):
    from eyelab.bench.psf import run_psf_bench

    return run_psf_bench(repeats=args.repeats)


def _bench_schematic(args):
    from eyelab.bench.schematic import run_schematic_bench

    return run_schematic_bench(repeats=args.repeats, quick=args.quick)


def _bench_lenslets(args):
    from eyelab.bench.lenslets import run_lenslets_bench

    return run_lenslets_bench(repeats=args.repeats, quick=args.quick)


def _bench_design(args):
    from eyelab.bench.design import run_design_bench

    return run_design_bench()


def _bench_blurfield(args):
    from eyelab.bench.blurfield import run_blurfield_bench

    return run_blurfield_bench(repeats=args.repeats)


#: Each benchmark's run (the keys of :data:`BENCHES`).
_BENCH_RUNS = {"optics": _bench_optics, "blurfield": _bench_blurfield,
               "render": _bench_render, "quality": _bench_quality,
               "stability": _bench_stability, "memory": _bench_memory,
               "inspect": _bench_inspect, "batch": _bench_batch,
               "imagebased": _bench_imagebased, "design": _bench_design,
               "psf": _bench_psf, "schematic": _bench_schematic,
               "lenslets": _bench_lenslets}


def _read_json(flag, path):
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, ValueError) as e:
        raise SpecError(flag, f"cannot read {path}: {e}") from None


def _size(flag, text):
    """(w, h) of "WxH", each in the view's range, or None."""
    if text is None:
        return None
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(re.fullmatch(r"[0-9]+", p.strip()) for p in parts):
        raise SpecError(flag, f"must be WxH, e.g. 320x240, got {text!r}")
    w, h = (int(p) for p in parts)
    check_range_int(flag, w, *_SIZE_RANGE)
    check_range_int(flag, h, *_SIZE_RANGE)
    return w, h


def _names(text):
    return None if text is None else [t.strip() for t in text.split(",") if t.strip()]


def _int_list(flag, text):
    if text is None:
        return None
    try:
        vals = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise SpecError(flag, f"must be comma-separated integers, got {text!r}") from None
    return vals
