"""``eyelab surface SPEC --side front|back -o FILE [--spacing-mm S] [--size-mm D]``: a spec
lens's surface (sphere, toric, asphere, progressive free-form, points) as a points file
(:mod:`eyelab.optics.lens.pointsfile`): a Vision Council DCS ``.sdf`` — what a lab's generator
receives — or a ``.csv`` / ``.npy`` sag grid, by the output's extension; the file reads back
as ``[lens.front]`` / ``[lens.back]`` ``type = "points"``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: The default grid spacing (mm).
SPACING_MM = 0.5
#: Samples a lenslet surface's grid puts across each lenslet at least (its spacing at most
#: the lenslets' diameter / this, and the finest spacing the format takes).
LENSLET_SAMPLES = 8


def add_parser(sub) -> None:
    s = sub.add_parser("surface", help="write a spec lens's front or back surface as a points "
                       "file: a Vision Council DCS .sdf (a lab generator's input), .csv or .npy")
    s.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    s.add_argument("--side", required=True, choices=("front", "back"),
                   help="which surface of the lens")
    s.add_argument("-o", "--output", required=True,
                   help="the points file: .sdf (DCS SURFMT + ZZ records), .csv or .npy")
    s.add_argument("--spacing-mm", type=float, metavar="S",
                   help=f"grid spacing in mm (default {SPACING_MM:g}; a surface with "
                   f"lenslets: their diameter / {LENSLET_SAMPLES}, and no coarser)")
    s.add_argument("--size-mm", type=float, metavar="D", help="side of the square grid in mm "
                   "(default: the lens's diameter plus 2 mm on each side, within a free-form "
                   "surface's own grid)")
    s.add_argument("--eye", choices=("right", "left"), default="right",
                   help="the lens of a two-eye spec (default right)")


def _lens(spec, eye: str):
    """The spec's lens (of ``eye`` for two eyes) and its eye letter (R/L)."""
    from eyelab.core.errors import SpecError

    if spec.render.camera is not None:
        raise SpecError("render.camera", "a camera spec has no spectacle lens to write")
    if spec.binocular is not None:
        lens = getattr(spec.binocular, f"{eye}_lens")
        letter = eye[0].upper()
    else:
        lens = spec.lens
        letter = "L" if lens is not None and lens.rx is not None and lens.rx.eye == "L" \
            else "R"
    if lens is None:
        raise SpecError("lens", "the spec has no lens whose surface to write")
    return lens, letter


def _spacing(asked, surface, finest: float) -> float:
    """The grid's spacing (mm): ``asked``, or the default; a surface with lenslets takes at
    most their diameter / :data:`LENSLET_SAMPLES` (not below ``finest``): a coarser grid
    would miss them, and is refused naming ``--spacing-mm``."""
    from eyelab.core.errors import SpecError

    radius = getattr(surface, "radius", None)
    if radius is None or not len(radius):
        return SPACING_MM if asked is None else asked
    d_mm = 2e3 * float(np.min(radius))
    most = max(finest, math.floor(d_mm / LENSLET_SAMPLES * 1e3) / 1e3)
    if asked is None:
        return most
    if asked > most + 1e-12:
        raise SpecError("--spacing-mm", f"{asked:g} mm puts {d_mm / asked:.1f} samples "
                        f"across the surface's {d_mm:g} mm lenslets; at most {most:g} mm "
                        f"({LENSLET_SAMPLES} across)")
    return asked


def run(args) -> int:
    from eyelab.apps.common import warn
    from eyelab.core.checks import check_range
    from eyelab.core.errors import SpecError
    from eyelab.core.fileio import check_output
    from eyelab.optics.lens.pointsfile import (
        FORMATS,
        LIMITS,
        SAG_DECIMALS,
        default_size_mm,
        sample_surface,
        write_points,
    )
    from eyelab.spec import load_spec

    if Path(args.output).suffix.lower() not in FORMATS:
        raise SpecError("--output", f"must end in {', '.join(FORMATS)} (the format), got "
                                    f"{args.output!r}")
    check_output("--output", args.output)
    if args.spacing_mm is not None:
        check_range("--spacing-mm", args.spacing_mm, *LIMITS["lens.front.spacing_mm"])
    if args.size_mm is not None:
        check_range("--size-mm", args.size_mm, *LIMITS["surface.size_mm"])
    spec = load_spec(args.spec)
    warn(spec.warnings)
    lens, letter = _lens(spec, args.eye)
    surface = getattr(lens, args.side)
    spacing = _spacing(args.spacing_mm, surface, LIMITS["lens.front.spacing_mm"][0])
    size = args.size_mm if args.size_mm is not None else default_size_mm(lens, spacing, surface)
    if size < lens.diameter * 1e3 - 1e-9:
        raise SpecError("--size-mm", f"{size:g} mm does not reach the rim of the "
                                     f"{lens.diameter * 1e3:g} mm lens: at least "
                                     f"{lens.diameter * 1e3:g}")
    grid = sample_surface(surface, spacing, size, "--size-mm")
    face = args.side[0].upper()
    fmt = write_points(args.output, grid, side=letter, surface=face)
    n = len(grid.x)
    side_mm = grid.x[-1] - grid.x[0]
    made = lens.rx.format() if lens.rx is not None else "explicit surfaces"
    radius = getattr(surface, "radius", None)
    if radius is not None and len(radius):
        d_mm = 2e3 * float(np.min(radius))
        made += (f"; {len(radius)} lenslets of {d_mm:g} mm, {d_mm / spacing:.1f} samples "
                 "across each")
    print(f"wrote {args.output}: the {args.side} surface of the lens ({made}), {n} x {n} "
          f"sags at {spacing:g} mm over {side_mm:g} x {side_mm:g} mm ({fmt}; "
          + ("float64, mm" if fmt == "npy" else f"mm, {SAG_DECIMALS} decimals") + ")")
    keys = f'type = "points", file = "{Path(args.output).name}"'
    if fmt != "sdf":
        keys += f", spacing_mm = {spacing:g}"
    # the centre thickness rounded up (0.1 um): the edge stays at least as thick
    ct = math.ceil(round(lens.center_thickness * 1e7, 3)) / 1e4
    print(f"read it back as [lens.{args.side}] {keys}; the lens: center_thickness_mm = "
          f"{ct:.4f}, diameter_mm = {lens.diameter * 1e3:g}, material = "
          f"{lens.material.name!r}")
    return 0
