"""``eyelab inspect``: the desktop inspector (a PyVista window, no Qt).

``eyelab inspect [SPEC] [--mesh FILE]`` opens the window on a spec (default: the built-in
scene); ``--screenshot FILE`` renders to the target S, writes the simulated view as the
window shows it (PNG) and the spec that reproduces it (``FILE`` with ``.toml``), and exits
(offscreen when there is no display); ``--window-shot FILE`` also writes the whole window.
"""

from __future__ import annotations

from eyelab.core.errors import SpecError


def add_parser(sub) -> None:
    ins = sub.add_parser("inspect", help="the interactive inspector window (PyVista, no Qt)")
    ins.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    ins.add_argument("--mesh", help="look at this mesh file (any format trimesh reads) "
                     "instead of the spec's scene")
    ins.add_argument("--size", help="simulated view size WxH in pixels, e.g. 800x600")
    ins.add_argument("--samples", type=int, help="target passes S (1-256)")
    ins.add_argument("--screenshot", help="render to the target S, write the view (PNG) "
                     "and its spec (.toml beside it), and exit")
    ins.add_argument("--window-shot", help="with --screenshot: also the whole window (PNG)")
    from eyelab.apps.common import add_max_memory

    add_max_memory(ins)
    ins.add_argument("--offscreen", action="store_true",
                     help="no window on the screen (implied by --screenshot without a display)")


def _size(text):
    if text is None:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SpecError("--size", f"must be WxH in pixels, e.g. 800x600, got {text!r}") \
            from None
    for name, v in (("width", w), ("height", h)):
        if not 16 <= v <= 4096:
            raise SpecError("--size", f"{name} must be in [16, 4096], got {v}")
    return w, h


def run(args) -> int:
    from eyelab.jobs.inspector import InspectorModel

    size = _size(args.size)
    if args.samples is not None and not 1 <= args.samples <= 256:
        raise SpecError("--samples", f"must be in [1, 256], got {args.samples}")
    for flag in ("screenshot", "window_shot"):
        p = getattr(args, flag)
        if p is not None and not p.lower().endswith(".png"):
            raise SpecError(f"--{flag.replace('_', '-')}", f"must be a .png file, got {p!r}")
    if args.window_shot and not args.screenshot:
        raise SpecError("--window-shot", "only with --screenshot")
    from eyelab.render import has_display, use_offscreen

    offscreen = args.offscreen or (args.screenshot is not None and not has_display())
    if not offscreen and not has_display():
        raise SpecError("inspect", "no display to open a window on (DISPLAY is not set); "
                        "use --screenshot FILE or --offscreen, or run under xvfb-run")
    if offscreen:
        use_offscreen()
    from eyelab.apps.common import apply_max_memory
    from eyelab.imaging.memory import check_memory

    apply_max_memory(args)
    model = InspectorModel(args.spec, size=size, samples=args.samples, scene=args.mesh)
    check_memory(model.spec.render)
    from eyelab.render.inspector import InspectorWindow

    win = InspectorWindow(model, off_screen=offscreen)
    try:
        if args.screenshot:
            win.run_to_target()
            png, spec = win.save(args.screenshot)
            if args.window_shot:
                from eyelab.core.fileio import write_png

                write_png(args.window_shot, win.plotter.screenshot(return_img=True)[..., :3])
            also = f" and the window to {args.window_shot}" if args.window_shot else ""
            print(f"wrote {png} and {spec}{also} ({model.status().splitlines()[0]})")
            return 0
        win.show()
        return 0
    finally:
        win.close()
