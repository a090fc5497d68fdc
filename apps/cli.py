"""The ``eyelab`` command: ``analyze``, ``render``, ``demo``, ``inspect``, ``batch``,
``maps``, ``surface``, ``psf``, ``cache``, ``bench``.

Thin: parses arguments and calls the library. User mistakes (bad spec, bad option)
print one line naming the field and exit with status 2; no partial output file is left.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from eyelab.apps import bench
from eyelab.apps.common import add_max_memory, add_no_cache, add_quiet, apply_max_memory, warn
from eyelab.core.errors import SpecError
from eyelab.core.fileio import report_text, write_report
from eyelab.optics.eye.thin import Eye


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (the usage is what ``--help`` is for), and negative
    numbers in scientific notation (``--mesh-position 0 0 -1e0``) taken as numbers, not
    as options (argparse's own pattern knows ``-1`` and ``-1.5`` only)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        import re

        self._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _build_parser() -> argparse.ArgumentParser:
    import eyelab

    ap = _Parser(prog="eyelab", description="What a person sees through spectacle lenses: "
                 "renders and demos (raster, reference, image-based), the interactive "
                 "inspector, batch jobs, point analysis, as-worn maps and figures of merit, "
                 "lens surfaces as lab files, the eye's point-spread function, benchmarks.")
    ap.add_argument("--version", action="version", version=f"eyelab {eyelab.__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    an = sub.add_parser("analyze", help="chief rays, wavefronts and retinal blur for object "
                        "points of a spec file (default: the built-in scene)")
    an.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    an.add_argument("--json", action="store_true", help="print JSON instead of text")
    an.add_argument("-o", "--output", help="also write the JSON report to this file")
    an.add_argument("--no-lens", action="store_true", help="naked-eye values")
    from eyelab.optics.chain.analysis import FIXATIONS

    an.add_argument("--fixation", choices=FIXATIONS,
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
    from eyelab.apps import batch, cache, inspector, psf, surface

    inspector.add_parser(sub)
    batch.add_parser(sub)
    surface.add_parser(sub)
    psf.add_parser(sub)
    mp = sub.add_parser("maps", help="as-worn maps of the spec's lens: mean power error and "
                        "cylinder over gaze directions; or a schematic eye's peripheral "
                        "refraction over the visual field (PNG, JSON)")
    mp.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    mp.add_argument("--kind", choices=MAP_KINDS, default=None,
                    help="asworn: the lens's power error and cylinder over eye rotations (a "
                         "thin eye's default); peripheral: refraction M, J0, J45 and the "
                         "relative peripheral refraction over the visual field of a "
                         "schematic eye fixating straight ahead, naked and through the lens "
                         "(a schematic eye's default)")
    mp.add_argument("-o", "--output", default="eyelab-maps.png", help="PNG file")
    mp.add_argument("--json", help="also write the maps as JSON here")
    mp.add_argument("--eye", choices=("right", "left"), help="a two-eye spec's eye")
    mp.add_argument("--half-angle", type=float, default=30.0,
                    help="eye rotations (Fick angles about the centre of rotation), or "
                         "field angles (peripheral), within +-this many degrees (default 30)")
    mp.add_argument("--points", type=int, default=31,
                    help="eye rotations (field angles) per axis (default 31)")
    cache.add_parser(sub)
    bench.add_parser(sub)
    for name in _CACHED:
        add_no_cache(sub.choices[name])
    return ap


#: ``eyelab maps --kind``: a lens's as-worn maps, or a schematic eye's peripheral refraction.
MAP_KINDS = ("asworn", "peripheral")
#: The subcommands that read specs, so may make an optimised progressive design (taken
#: from the on-disk cache unless ``--no-cache``).
_CACHED = ("analyze", "render", "demo", "inspect", "batch", "surface", "psf", "maps")


#: [render] keys whose command-line flag has another name.
_FLAGS = {"gaze_deg": "gaze"}


def _render_overrides(parser) -> None:
    from eyelab.imaging.registry import RENDERERS
    from eyelab.imaging.stereo import OUTPUTS

    parser.add_argument("--renderer", choices=RENDERERS,
                        help="override render.renderer")
    parser.add_argument("--samples", type=int, help="override render.samples (passes S of "
                        "the raster renderer, rays per pixel of the reference, lens sample "
                        "points of the image-based model)")
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
                        choices=("spec", *OUTPUTS),
                        help="two eyes: a spec without [binocular] gets both eyes from [eye] "
                        "and [lens] (PD 64 mm); OUTPUT overrides binocular.output: "
                        + ", ".join(OUTPUTS))


@contextlib.contextmanager
def _quiet_numerics():
    """numpy's floating-point warnings are not shown: the command reports what matters
    (e.g. "nothing in view") in its own lines."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def main(argv=None) -> int:
    """The command line; returns the exit status (0 done, 1 some jobs or checks not ok, 2
    bad input, 130 interrupted by Ctrl-C, 143 terminated by SIGTERM)."""
    import signal

    from eyelab.core import interrupt

    try:
        # Ctrl-C / SIGTERM: outputs are atomic, so unwinding leaves none half-written
        with interrupt.handling():
            args = _build_parser().parse_args(argv)
            from eyelab.imaging.memory import memory_limit_scope

            with memory_limit_scope(), _quiet_numerics():
                rc = _main(args)      # --max-memory lasts for this command only
        sys.stdout.flush()        # a closed pipe shows here, not at interpreter exit
        return rc
    except BaseException as e:
        # an interrupt, or an error an interrupt caused inside native code (an extension's
        # initialisation turning KeyboardInterrupt into ImportError): one line either way
        signum = getattr(e, "eyelab_signal", None)
        if signum is None and not isinstance(e, (KeyboardInterrupt, interrupt.Terminated)):
            if isinstance(e, BrokenPipeError):
                return _broken_pipe()
            raise
        sigterm = isinstance(e, interrupt.Terminated) or signum == signal.SIGTERM
        print(f"eyelab: {'terminated' if sigterm else 'interrupted'}", file=sys.stderr)
        return 143 if sigterm else 130


def _broken_pipe() -> int:
    """The reader went away (`eyelab analyze --json | head -1`): stop quietly."""
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 1


def _main(args) -> int:
    from eyelab.core.diskcache import OFF_ENV, check_environment
    from eyelab.core.parallel import scoped_environ
    from eyelab.core.progress import quiet_if

    # --no-cache: EYELAB_NO_CACHE=1 for this command and the processes it starts
    off = {OFF_ENV: "1"} if getattr(args, "no_cache", False) else {}
    try:
        with scoped_environ(**off), quiet_if(getattr(args, "quiet", False)):
            check_environment()      # $EYELAB_CACHE_DIR / _MAX_MB: one line, before any work
            return _COMMANDS[args.command](args)
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


def _app(module: str):
    """The ``run(args)`` of a front end in ``eyelab.apps``, imported when called."""
    def run(args):
        import importlib

        return importlib.import_module(f"eyelab.apps.{module}").run(args)
    return run


#: Each subcommand's run.
_COMMANDS = {"analyze": lambda a: _analyze(a), "bench": lambda a: bench.run(a),
             "render": lambda a: _render(a), "demo": lambda a: _render(a),
             "maps": lambda a: _maps(a), "inspect": _app("inspector"), "batch": _app("batch"),
             "surface": _app("surface"), "psf": _app("psf"), "cache": _app("cache")}


def _analyze(args) -> int:
    from dataclasses import replace

    from eyelab.jobs.analyze import analyze_spec, format_report
    from eyelab.spec import load_spec

    if args.output is not None:
        from eyelab.core.fileio import check_output

        check_output("--output", args.output)
    spec = load_spec(args.spec)
    if args.fixation:
        spec = replace(spec, fixation=args.fixation)
    warn(spec.warnings)
    rep = analyze_spec(spec, no_lens=args.no_lens)
    if spec.warnings:
        rep["warnings"] = list(spec.warnings)
    text = report_text(rep).rstrip("\n") if args.json else format_report(rep)
    if args.output:
        write_report(args.output, rep)
    print(text)
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
    if getattr(args, "no_lens", False) and rs.camera is not None:
        raise SpecError("--no-lens", f"shows the naked eye; this spec renders through a "
                        f"camera lens (render.camera = {rs.camera.name!r}), which has no eye")
    from eyelab.imaging.memory import check_memory

    apply_max_memory(args)
    check_memory(rs)          # up front, before the scene is built (each render checks too)
    # outputs as one set: all written to temporaries, then renamed back to back
    if args.command == "demo":
        _write_demo(args, spec)
    elif spec.binocular is not None:
        _write_binocular(args, spec)
    else:
        _write_render(args, spec)
    return 0


def _write_outputs(args, image, report) -> None:
    """The image and (with ``--report``) its report, written as one set."""
    from eyelab.core.fileio import atomic_group, png_writer, report_writer

    writers = {args.output: png_writer(image)}
    if args.report:
        writers[args.report] = report_writer(report)
    atomic_group(writers)


def _write_render(args, spec) -> None:
    from eyelab.jobs.render import render_spec

    res = render_spec(spec, no_lens=args.no_lens)
    _write_outputs(args, res.srgb, res.report)
    rep = res.report
    done = ", ".join(f"{k} {v}" for k, v in rep["samples"]["done"].items())
    print(f"wrote {args.output} ({res.srgb.shape[1]}x{res.srgb.shape[0]}, "
          f"{rep['renderer']}: {done} of {rep['samples']['target']} samples, "
          f"{rep['timings_s']['total']:.2f} s)")
    for why in rep["skipped"]:
        print(f"  skipped {why}")
    warn(rep["warnings"])


def _write_binocular(args, spec) -> None:
    from eyelab.jobs.render import render_binocular_spec

    res = render_binocular_spec(spec, no_lens=args.no_lens)
    mode = spec.binocular.output
    image = res.srgb(mode)
    _write_outputs(args, image, res.report)
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
    warn(w for s in ("right", "left") for w in res.report[s]["warnings"])


def _write_demo(args, spec) -> None:
    from eyelab.core.fileio import atomic_group, png_writer, report_writer
    from eyelab.jobs.render import demo

    image, rep = demo(spec)
    atomic_group({args.output: png_writer(image),
                  args.output[:-4] + ".json": report_writer(rep)})
    # the panels as the image lays them out: a line per row (binocular: an eye a row)
    rows = rep.get("rows", {"": list(rep["panels"])})
    lines = [f"{name}: " * bool(name) + " | ".join(cols) for name, cols in rows.items()]
    print(f"wrote {args.output} and {args.output[:-4]}.json:"
          + (f" {lines[0]}" if len(lines) == 1 else "".join(f"\n  {line}" for line in lines)))
    warn(w for r in rep["panels"].values() for w in r["warnings"])


def _maps(args) -> int:
    from dataclasses import replace

    from eyelab.core.fileio import atomic_group, check_distinct, check_output, report_writer
    from eyelab.jobs import maps as job
    from eyelab.spec import load_spec, no_camera, pick_eye

    spec = pick_eye(no_camera(load_spec(args.spec), "maps"), args.eye, "eyelab maps")
    warn(spec.warnings)
    if not args.output.lower().endswith(".png"):
        raise SpecError("--output", f"must be a .png file, got {args.output!r}")
    check_output("--output", args.output)
    if args.json is not None:
        check_output("--json", args.json)
        check_distinct(**{"--output": args.output, "--json": args.json})
    kind = args.kind or ("asworn" if isinstance(spec.eye, Eye) else "peripheral")
    if kind == "peripheral":
        return _peripheral(args, spec)
    spec = replace(spec, eye=job.lens_wearer(spec.eye))
    if spec.lens is None:
        raise SpecError("lens", "the spec has no lens to map")
    maps, maps_origin = job.cli_maps(spec.eye, spec.lens, half_angle_deg=args.half_angle,
                                     n=args.points, wavelength_nm=spec.wavelength_nm)
    figures, figures_origin = job.figures_and_origin(spec.eye, spec.lens, maps=maps,
                                                     wavelength_nm=spec.wavelength_nm)
    title = f"{spec.lens.rx.format()} in {spec.lens.material.name}, as worn"
    origin = job.design_origin(spec.lens)
    writers = {args.output: lambda tmp: job.plot_maps(maps, tmp, title)}
    if args.json:
        extra = {} if origin is None else {"design": origin}
        writers[args.json] = report_writer(dict(maps.to_json(), figures=figures, **extra,
                                                maps_origin=maps_origin,
                                                figures_origin=figures_origin))
    atomic_group(writers)
    print("\n".join(job.design_summary(origin) + job.origin_summary("maps", maps_origin)
                    + job.origin_summary("figures of merit", figures_origin)
                    + job.maps_summary(maps) + job.figures_summary(figures)))
    print(f"wrote {args.output}" + (f" and {args.json}" if args.json else ""))
    return 0


def _peripheral(args, spec) -> int:
    from eyelab.core.fileio import atomic_group, report_writer
    from eyelab.jobs import retinal

    if isinstance(spec.eye, Eye):
        raise SpecError("eye.model", "a peripheral refraction map needs a schematic eye "
                        "(eye.model = \"navarro\"): the thin eye images every line of sight "
                        "as the fovea does")
    from eyelab.jobs.maps import MAPS_FLAGS, named_as

    with named_as(MAPS_FLAGS):
        rep = retinal.peripheral_map(spec, half_angle_deg=args.half_angle, n=args.points)
    lens = "naked eye" if spec.lens is None else f"{spec.lens.rx.format()} lens" \
        if spec.lens.rx is not None else "lens"
    title = (f"peripheral refraction: {spec.eye.model} eye, axial length "
             f"{spec.eye.axial_length * 1e3:.2f} mm; {lens}; fixating straight ahead")
    writers = {args.output: lambda tmp: retinal.plot_peripheral(rep, tmp, title)}
    if args.json:
        writers[args.json] = report_writer(rep)
    atomic_group(writers)
    print("\n".join(retinal.peripheral_summary(rep)))
    print(f"wrote {args.output}" + (f" and {args.json}" if args.json else ""))
    return 0


def entry() -> None:
    """The ``eyelab`` console command: :func:`main`, its status the process's. After an
    interruption (130 / 143, outputs already unwound) the process ends at once: the
    interpreter would otherwise re-raise SIGINT on itself at exit when a native
    extension had seen the KeyboardInterrupt, and tear down VTK and the thread pools
    mid-way."""
    rc = main()
    if rc in (130, 143):
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(rc)
    sys.exit(rc)


if __name__ == "__main__":
    entry()
