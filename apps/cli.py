"""The ``eyelab`` command: ``analyze``, ``render``, ``demo``, ``inspect``, ``batch``,
``bench``.

Thin: parses arguments and calls the library. User mistakes (bad spec, bad option)
print one line naming the field and exit with status 2; no partial output file is left.
"""

from __future__ import annotations

import argparse
import json
import sys

from eyelab.apps.common import add_max_memory, add_quiet
from eyelab.core.errors import SpecError
from eyelab.core.fileio import atomic_path


def _atomic_write(path: str, text: str) -> None:
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        fh.write(text)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (the usage is what ``--help`` is for)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="eyelab", description="What a person sees through "
                                 "spectacle lenses: point analysis, benchmarks.")
    sub = ap.add_subparsers(dest="command", required=True)
    an = sub.add_parser("analyze", help="chief rays, wavefronts and retinal blur for object "
                        "points of a spec file (default: the built-in scene)")
    an.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    an.add_argument("--json", action="store_true", help="print JSON instead of text")
    an.add_argument("-o", "--output", help="also write the JSON report to this file")
    an.add_argument("--no-lens", action="store_true", help="naked-eye values")
    an.add_argument("--fixation", choices=("fixed", "rotating"),
                    help="override the spec's fixation model")
    rn = sub.add_parser("render", help="render what the spec's eye sees to a PNG")
    rn.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    rn.add_argument("-o", "--output", default="eyelab-render.png", help="PNG file")
    rn.add_argument("--report", help="also write the render report (JSON) here")
    rn.add_argument("--no-lens", action="store_true", help="the naked eye")
    _render_overrides(rn)
    dm = sub.add_parser("demo", help="side-by-side image: uncorrected, corrected, emmetrope")
    dm.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    dm.add_argument("-o", "--output", default="eyelab-demo.png", help="PNG file (its JSON "
                    "report is written beside it, .json)")
    _render_overrides(dm)
    from eyelab.apps import batch, inspector

    inspector.add_parser(sub)
    batch.add_parser(sub)
    mp = sub.add_parser("maps", help="as-worn maps of the spec's lens: mean power error and "
                        "cylinder over gaze directions (PNG contour maps, JSON)")
    mp.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    mp.add_argument("-o", "--output", default="eyelab-maps.png", help="PNG file")
    mp.add_argument("--json", help="also write the maps as JSON here")
    mp.add_argument("--half-angle", type=float, default=30.0,
                    help="gazes within +-this many degrees (default 30)")
    mp.add_argument("--points", type=int, default=31, help="gazes per axis (default 31)")
    be = sub.add_parser("bench", help="benchmarks (print numbers and write JSON)")
    be.add_argument("what", choices=("optics", "blurfield", "render", "quality", "stability",
                                     "memory", "inspect", "batch", "imagebased"))
    pre = be.add_mutually_exclusive_group()
    pre.add_argument("--quick", action="store_true",
                     help="quality: 160x120, two configurations (the default; CI runs it); "
                     "stability: 10^4 engine cases (CI runs it; the default is 10^5)")
    pre.add_argument("--full", action="store_true",
                     help="quality: 1024x768 and every configuration; stability: 10^6 cases")
    add_quiet(be)
    be.add_argument("--plot", help="quality: also write the error-vs-time plot (PNG) here")
    be.add_argument("-o", "--output", help="JSON output file (default bench-WHAT.json)")
    be.add_argument("--points", type=int, default=1_000_000,
                    help="optics: points per wavefront-tracing batch (default 1e6)")
    be.add_argument("--repeats", type=int, default=3)
    be.add_argument("--truth-spp", type=int,
                    help="quality: samples per pixel of the converged reference")
    be.add_argument("--reference-spp", help="quality: the reference's ladder, e.g. 4,16,64")
    be.add_argument("--configs", help="quality: only these eye/lens configurations or "
                    "camera cases (comma-separated names)")
    be.add_argument("--scenes", help="quality: only these scenes (comma-separated names)")
    be.add_argument("--merge", nargs="+", metavar="JSON",
                    help="quality: combine these partial runs' JSON files into one "
                    "(checks, summary and plot recomputed) instead of running")
    be.add_argument("--omit", help="quality: leave out these optional rows (comma-"
                    "separated: variants, imagebased), for partial runs on small machines")
    be.add_argument("--truth-cache", help="quality: folder where converged references are "
                    "kept and re-used (keyed by scene, configuration, size and spp)")
    return ap


#: [render] keys whose command-line flag has another name.
_FLAGS = {"gaze_deg": "gaze"}
#: binocular.output's choices (eyelab.optics.binocular.OUTPUTS; listed here so that building the
#: parser imports nothing heavy).
BINOCULAR_OUTPUTS = ("side-by-side", "crossed", "anaglyph", "right", "left")


def _render_overrides(parser) -> None:
    parser.add_argument("--renderer", choices=("raster", "reference", "imagebased"),
                        help="override render.renderer")
    parser.add_argument("--samples", type=int, help="override render.samples (passes S of "
                        "the raster renderer, rays per pixel of the reference)")
    parser.add_argument("--width", type=int, help="override render.width (pixels)")
    parser.add_argument("--height", type=int, help="override render.height (pixels)")
    parser.add_argument("--scene", help="override render.scene: a built-in scene's name or "
                        "a mesh file (placed by [render] scene = {path, position_m, ...})")
    add_max_memory(parser)
    add_quiet(parser)
    parser.add_argument("--gaze", type=float, nargs=2, metavar=("RIGHT", "UP"),
                        help="override render.gaze_deg: the eye turned this many degrees "
                        "right and up behind the lens (both eyes' cyclopean gaze, binocular)")
    parser.add_argument("--binocular", nargs="?", const="spec", metavar="OUTPUT",
                        choices=("spec", *BINOCULAR_OUTPUTS),
                        help="two eyes: a spec without [binocular] gets both eyes from [eye] "
                        "and [lens] (PD 64 mm); OUTPUT overrides binocular.output: "
                        + ", ".join(BINOCULAR_OUTPUTS))


def main(argv=None) -> int:
    ap = _build_parser()
    args = ap.parse_args(argv)
    try:
        rc = _main(args)
        sys.stdout.flush()        # a closed pipe shows here, not at interpreter exit
        return rc
    except BrokenPipeError:
        # the reader went away (`eyelab analyze --json | head -1`): stop quietly
        import os

        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1


def _main(args) -> int:
    if getattr(args, "quiet", False):
        from eyelab.core.progress import set_enabled

        set_enabled(False)
    try:
        if args.command == "analyze":
            return _analyze(args)
        if args.command == "bench":
            return _bench(args)
        if args.command in ("render", "demo"):
            return _render(args)
        if args.command == "maps":
            return _maps(args)
        if args.command == "inspect":
            from eyelab.apps.inspector import run

            return run(args)
        if args.command == "batch":
            from eyelab.apps.batch import run

            return run(args)
    except SpecError as e:
        print(f"eyelab: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        if isinstance(e, BrokenPipeError):
            raise
        # a write that fails after the checks (a full disk, a vanished folder): one line;
        # the atomic writes leave the old outputs in place
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        print(f"eyelab: error: cannot write {where}{e.strerror or e}", file=sys.stderr)
        return 1
    return 1


def _analyze(args) -> int:
    from dataclasses import replace

    from eyelab.jobs.analyze import analyze_spec, format_report
    from eyelab.spec import load_spec

    if args.output:
        from eyelab.core.fileio import check_output

        check_output("--output", args.output)
    spec = load_spec(args.spec)
    if args.fixation:
        spec = replace(spec, fixation=args.fixation)
    rep = analyze_spec(spec, no_lens=args.no_lens)
    text = json.dumps(rep, indent=2)
    if args.output:
        _atomic_write(args.output, text + "\n")
    print(text if args.json else format_report(rep))
    return 0


def _load_for_render(args):
    """The spec, made binocular by ``--binocular`` (its output overridden by the flag's
    value) when asked."""
    from dataclasses import replace

    from eyelab.spec import load_spec, parse_spec, read_spec_data

    spec = load_spec(args.spec)
    if args.binocular is None:
        return spec
    if spec.binocular is None:
        data, source, base = read_spec_data(args.spec)
        data["binocular"] = {}
        spec = parse_spec(data, source, base)
    if args.binocular != "spec":
        spec = replace(spec, binocular=replace(spec.binocular, output=args.binocular))
    return spec


def _render(args) -> int:
    from dataclasses import replace

    spec = _load_for_render(args)
    if not args.output.lower().endswith(".png"):
        raise SpecError("--output", f"must be a .png file, got {args.output!r}")
    from eyelab.core.fileio import check_distinct, check_output

    # every output checked before any work; two outputs at one path refused
    outputs = {"--output": args.output,
               "--report": getattr(args, "report", None) if args.command == "render"
               else args.output[:-4] + ".json"}
    for flag, path in outputs.items():
        if path is not None:
            check_output(flag, path)
    check_distinct(**outputs)
    try:
        rs = spec.render.with_changes(scene=args.scene, renderer=args.renderer,
                                      samples=args.samples,
                                      width=args.width, height=args.height,
                                      gaze_deg=None if args.gaze is None else list(args.gaze))
    except SpecError as e:
        key = e.field.removeprefix("render.").split("[")[0]
        raise SpecError(f"--{_FLAGS.get(key, key)} ({e.field})", e.message) from None
    spec = replace(spec, render=rs)
    from eyelab.imaging.memory import check_memory, memory_limit

    check_memory(rs, memory_limit(args.max_memory))
    from eyelab.core.fileio import atomic_group, json_writer, png_writer
    from eyelab.jobs.render import demo, render_spec

    # outputs as one set: all written to temporaries, then renamed back to back
    if args.command == "render" and spec.binocular is not None:
        from eyelab.jobs.render import render_binocular_spec

        res = render_binocular_spec(spec, no_lens=args.no_lens)
        mode = spec.binocular.output
        image = res.srgb(mode)
        writers = {args.output: png_writer(image)}
        if args.report:
            writers[args.report] = json_writer(res.report)
        atomic_group(writers)
        b = res.report["binocular"]
        print(f"wrote {args.output} ({image.shape[1]}x{image.shape[0]}, {mode}; "
              f"accommodation {b['accommodation_d']:.2f} D, {b['accommodation_rule']})")
        for side, info in b["eyes"].items():
            rep = res.report[side]
            print(f"  {side} eye: gaze ({info['gaze_deg'][0]:+.2f}, {info['gaze_deg'][1]:+.2f})"
                  f" deg, blur at fixation {info['blur_at_fixation_arcmin'][0]:.2f}' x "
                  f"{info['blur_at_fixation_arcmin'][1]:.2f}', {rep['renderer']} "
                  f"{rep['timings_s']['total']:.2f} s")
        if b["prism_at_fixation"] is not None:
            p = b["prism_at_fixation"]["binocular"]
            print(f"  induced prism at fixation: {p['horizontal']}, {p['vertical']}")
        warnings = dict.fromkeys(w for s in ("right", "left") for w in res.report[s]["warnings"])
        for warning in warnings:
            print(f"eyelab: warning: {warning}", file=sys.stderr)
    elif args.command == "render":
        res = render_spec(spec, no_lens=args.no_lens)
        writers = {args.output: png_writer(res.srgb)}
        if args.report:
            writers[args.report] = json_writer(res.report)
        atomic_group(writers)
        rep = res.report
        done = ", ".join(f"{k} {v}" for k, v in rep["samples"]["done"].items())
        print(f"wrote {args.output} ({res.srgb.shape[1]}x{res.srgb.shape[0]}, "
              f"{rep['renderer']}: {done} of {rep['samples']['target']} samples, "
              f"{rep['timings_s']['total']:.2f} s)")
        for why in rep["skipped"]:
            print(f"  skipped {why}")
        for warning in rep["warnings"]:
            print(f"eyelab: warning: {warning}", file=sys.stderr)
    else:
        image, rep = demo(spec)
        atomic_group({args.output: png_writer(image),
                      args.output[:-4] + ".json": json_writer(rep)})
        print(f"wrote {args.output} and {args.output[:-4]}.json: " + ", ".join(rep["panels"]))
        warnings = dict.fromkeys(w for r in rep["panels"].values() for w in r["warnings"])
        for warning in warnings:
            print(f"eyelab: warning: {warning}", file=sys.stderr)
    return 0


def _maps(args) -> int:
    from eyelab.core.fileio import atomic_group, check_distinct, check_output, json_default
    from eyelab.jobs.maps import maps_summary, plot_maps
    from eyelab.optics.asworn import as_worn_maps
    from eyelab.spec import load_spec, one_eye

    spec = one_eye(load_spec(args.spec), "eyelab maps")
    if not args.output.lower().endswith(".png"):
        raise SpecError("--output", f"must be a .png file, got {args.output!r}")
    check_output("--output", args.output)
    if args.json:
        check_output("--json", args.json)
        check_distinct(**{"--output": args.output, "--json": args.json})
    if spec.lens is None:
        raise SpecError("lens", "the spec has no lens to map")
    maps = as_worn_maps(spec.eye, spec.lens, half_angle_deg=args.half_angle, n=args.points,
                        wavelength_nm=spec.wavelength_nm)
    title = f"{spec.lens.rx.format()} in {spec.lens.material.name}, as worn"
    writers = {args.output: lambda tmp: plot_maps(maps, tmp, title)}
    if args.json:
        text = json.dumps(maps.to_json(), indent=1, default=json_default)

        def write_json(tmp):
            with open(tmp, "w") as fh:
                fh.write(text)

        writers[args.json] = write_json
    atomic_group(writers)
    print("\n".join(maps_summary(maps)))
    print(f"wrote {args.output}" + (f" and {args.json}" if args.json else ""))
    return 0


def _bench(args) -> int:
    if args.points < 1000 or args.points > 20_000_000:
        raise SpecError("--points", f"must be in [1000, 20000000], got {args.points}")
    if args.repeats < 1 or args.repeats > 50:
        raise SpecError("--repeats", f"must be in [1, 50], got {args.repeats}")
    output = args.output or f"bench-{args.what}.json"
    from eyelab.core.fileio import check_distinct, check_output

    check_output("--output", output)
    if args.plot:
        check_output("--plot", args.plot)
        check_distinct(**{"--output": output, "--plot": args.plot})
    if args.what == "optics":
        from eyelab.bench.optics import run_optics_bench

        res = run_optics_bench(points=args.points, repeats=args.repeats)
    elif args.what == "render":
        from eyelab.bench.render import run_render_bench

        res = run_render_bench(repeats=min(args.repeats, 3))
    elif args.what == "quality":
        from eyelab.bench.quality import run_quality_bench

        if args.merge:
            from eyelab.bench.quality import merge_results

            res = merge_results([_read_json("--merge", p) for p in args.merge],
                                plot_path=args.plot)
        else:
            res = run_quality_bench(quick=not args.full, plot_path=args.plot,
                                    truth_spp=args.truth_spp,
                                    ref_spp=_int_list("--reference-spp", args.reference_spp),
                                    only_configs=_names(args.configs),
                                    only_scenes=_names(args.scenes),
                                    truth_cache=args.truth_cache,
                                    omit=_names(args.omit))
    elif args.what == "inspect":
        import os

        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
        from eyelab.bench.inspector import run_inspect_bench

        res = run_inspect_bench(*((320, 240, 4) if args.quick else (800, 600, 16)))
    elif args.what == "imagebased":
        import os

        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
        from eyelab.bench.imagebased import run_imagebased_bench

        res = run_imagebased_bench(quick=args.quick, repeats=min(args.repeats, 3))
    elif args.what == "batch":
        from eyelab.bench.batch import run_batch_bench

        res = run_batch_bench(10 if args.quick else 100)
    elif args.what == "memory":
        from eyelab.bench.memory import run_memory_bench

        res = run_memory_bench(*((40, 100) if args.quick else (200, 500)))
    elif args.what == "stability":
        from eyelab.bench.stability import QUICK, run_stability_bench

        if args.quick:     # what CI runs (tests/test_bench_quality.py)
            res = run_stability_bench(**QUICK)
        else:
            res = run_stability_bench(cases=1_000_000 if args.full else 100_000)
    else:
        from eyelab.bench.blurfield import run_blurfield_bench

        res = run_blurfield_bench(repeats=args.repeats)
    args.output = output
    _atomic_write(output, json.dumps(res, indent=2) + "\n")
    for line in res["summary"]:
        print(line)
    print(f"wrote {args.output}")
    return 0


def _read_json(flag, path):
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, ValueError) as e:
        raise SpecError(flag, f"cannot read {path}: {e}") from None


def _names(text):
    return None if text is None else [t.strip() for t in text.split(",") if t.strip()]


def _int_list(flag, text):
    if text is None:
        return None
    try:
        vals = [int(t) for t in text.split(",")]
    except ValueError:
        raise SpecError(flag, f"must be comma-separated integers, got {text!r}") from None
    return vals


if __name__ == "__main__":
    sys.exit(main())
