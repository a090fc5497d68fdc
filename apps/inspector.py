"""``eyelab inspect``: the desktop inspector (a PyVista window, no Qt).

``eyelab inspect [SPEC] [--mesh FILE]`` opens the window on a spec (default: the built-in
scene; a two-eye spec shows both eyes); ``--mesh FILE`` looks at a mesh file instead of
the spec's scene, placed and lit by ``--mesh-position``, ``--mesh-scale``,
``--mesh-units``, ``--mesh-rotation`` and ``--mesh-shading`` (the keys of ``[render]
scene = {path, ...}``); ``--screenshot FILE`` renders to the target S, writes the
simulated view as the window shows it (PNG) and the spec that reproduces it (``FILE``
with ``.toml``), and exits (offscreen when there is no display); ``--window-shot FILE``
also writes the whole window. The scene's warnings (the eye inside a mesh, nothing in
view) are printed as ``eyelab render`` prints them.
"""

from __future__ import annotations

import contextlib

from eyelab.core.errors import SpecError


def add_parser(sub) -> None:
    ins = sub.add_parser("inspect", help="the interactive inspector window (PyVista, no Qt)")
    ins.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    ins.add_argument("--mesh", help="look at this mesh file (any format trimesh reads) "
                     "instead of the spec's scene")
    ins.add_argument("--mesh-position", type=float, nargs=3, metavar=("X", "Y", "Z"),
                     help="where the mesh file's origin goes (m; the pupil at the origin, "
                     "looking along -z, y up), e.g. 0 0 -1")
    ins.add_argument("--mesh-scale", type=float, help="a factor on the mesh's size")
    ins.add_argument("--mesh-units", help="the mesh file's length unit (m, cm, mm, in)")
    ins.add_argument("--mesh-rotation", type=float, nargs=3, metavar=("RX", "RY", "RZ"),
                     help="rotations (deg) about x, then y, then z")
    from eyelab.scene.shading import SHADINGS

    ins.add_argument("--mesh-shading", choices=SHADINGS,
                     help="how the mesh is lit (auto: Lambertian when it has no colours)")
    ins.add_argument("--window", help="window size WxH in pixels, e.g. 1280x800 (default: "
                     "what shows the view one pixel per pixel)")
    ins.add_argument("--size", help="simulated view size WxH in pixels, e.g. 800x600")
    ins.add_argument("--samples", type=int, help="target passes S (1-256)")
    ins.add_argument("--screenshot", help="render to the target S, write the view (PNG) "
                     "and its spec (.toml beside it), and exit")
    ins.add_argument("--window-shot", help="with --screenshot: also the whole window (PNG)")
    from eyelab.apps.common import add_max_memory

    add_max_memory(ins)
    ins.add_argument("--offscreen", action="store_true",
                     help="no window on the screen (implied by --screenshot without a display)")


#: ``--mesh-*`` flags and the scene-table keys they set.
MESH_FLAGS = {"mesh_position": "position_m", "mesh_scale": "scale", "mesh_units": "units",
              "mesh_rotation": "rotation_deg", "mesh_shading": "shading"}


def _size(text, flag="--size", lo=(16, 16)):
    if text is None:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SpecError(flag, f"must be WxH in pixels, e.g. 800x600, got {text!r}") \
            from None
    for name, v, low in (("width", w, lo[0]), ("height", h, lo[1])):
        if not low <= v <= 4096:
            raise SpecError(flag, f"{name} must be in [{low}, 4096], got {v}")
    return w, h


def _scene(args):
    """The ``--mesh`` override: the file's path, or the scene table placing it."""
    placed = {key: getattr(args, flag) for flag, key in MESH_FLAGS.items()
              if getattr(args, flag) is not None}
    if placed and args.mesh is None:
        flag = next(f for f in MESH_FLAGS if getattr(args, f) is not None)
        raise SpecError("--" + flag.replace("_", "-"), "only with --mesh FILE")
    if args.mesh is None or not placed:
        return args.mesh
    return {"path": args.mesh, **{k: list(v) if isinstance(v, list) else v
                                  for k, v in placed.items()}}


def run(args) -> int:
    size = _size(args.size)
    from eyelab.render.inspector import MIN_WINDOW

    window = _size(args.window, "--window", MIN_WINDOW)
    if args.samples is not None and not 1 <= args.samples <= 256:
        raise SpecError("--samples", f"must be in [1, 256], got {args.samples}")
    for flag in ("screenshot", "window_shot"):
        p = getattr(args, flag)
        if p is not None and not p.lower().endswith(".png"):
            raise SpecError(f"--{flag.replace('_', '-')}", f"must be a .png file, got {p!r}")
    if args.window_shot and not args.screenshot:
        raise SpecError("--window-shot", "only with --screenshot")
    if args.mesh is not None:              # the scene table the flags make, checked now
        from pathlib import Path

        from eyelab.spec.render import parse_scene

        with _mesh_flag_errors(args):
            parse_scene(_scene(args), None, Path.cwd())
    if args.spec is not None:            # a bad spec is named before a missing display
        from eyelab.spec import load_spec

        load_spec(args.spec)
    from eyelab.render import NO_WINDOW_WAYS, display_error, use_offscreen

    why = None if args.offscreen else display_error()
    offscreen = args.offscreen or (args.screenshot is not None and why is not None)
    if not offscreen and why is not None:
        raise SpecError("inspect", f"{why}; {NO_WINDOW_WAYS}")
    if offscreen:
        use_offscreen()
    from eyelab.apps.common import apply_max_memory
    from eyelab.imaging.memory import check_memory

    apply_max_memory(args)
    model = _model(args, size)
    from eyelab.imaging.memory import memory_limit

    # two eyes: two renderers hold their fields at once, each within half the limit
    check_memory(model.spec.render, memory_limit() / (2 if model.two_eyes else 1))
    from eyelab.render.inspector import InspectorWindow

    win = InspectorWindow(model, off_screen=offscreen, window_size=window)
    try:
        if args.screenshot:
            win.run_to_target()
            from eyelab.apps.common import warn

            warn(model.warnings())
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


def _model(args, size):
    """The inspector's model; a bad ``--mesh-*`` value named by its flag."""
    from eyelab.jobs.inspector import InspectorModel

    with _mesh_flag_errors(args):
        return InspectorModel(args.spec, size=size, samples=args.samples, scene=_scene(args))


@contextlib.contextmanager
def _mesh_flag_errors(args):
    """An error in a ``render.scene`` key that a ``--mesh-*`` flag set, named by the flag."""
    try:
        yield
    except SpecError as e:
        for flag, key in MESH_FLAGS.items():
            if args.mesh is not None and e.field.startswith(f"render.scene.{key}"):
                raise SpecError("--" + flag.replace("_", "-"), e.message) from None
        raise
