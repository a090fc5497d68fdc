"""``eyelab psf SPEC [--point N] [--no-lens] -o psf.npy [--json psf.json]``: the eye's
point-spread function at one of the spec's points, per colour channel, in wave optics
(:mod:`eyelab.jobs.psf`): a (3, size, size) float array (R, G, B at their wavelengths;
rows top to bottom), its sampling, Strehl ratios, RMS and coefficients in the JSON."""

from __future__ import annotations

from eyelab.jobs.psf import PITCH_ARCMIN, PSF_LIMITS, SIZE


def add_parser(sub) -> None:
    p = sub.add_parser("psf", help="the eye's point-spread function at a spec point (wave "
                       "optics: defocus through the lens, higher-order aberrations, "
                       "diffraction) as .npy, with Strehl, RMS and MTF in JSON")
    p.add_argument("spec", nargs="?", help="TOML spec file (default: built-in)")
    p.add_argument("--point", type=int, default=0, help="index of the spec's [[points]] "
                   "(default 0)")
    p.add_argument("--no-lens", action="store_true", help="the naked eye")
    p.add_argument("--eye", choices=("right", "left"), help="a two-eye spec's eye (at the "
                   "accommodation both share at the point)")
    p.add_argument("-o", "--output", required=True, help="the PSF as .npy: (3, size, size)")
    p.add_argument("--json", help="also write the report (sampling, Strehl, RMS, MTF, "
                   "coefficients) here")
    p.add_argument("--pitch-arcmin", type=float, default=PITCH_ARCMIN,
                   help=f"arcmin per pixel, in [{PSF_LIMITS['pitch_arcmin'][0]:g}, "
                   f"{PSF_LIMITS['pitch_arcmin'][1]:g}] (default {PITCH_ARCMIN:g})")
    lo, hi = PSF_LIMITS["size"]
    p.add_argument("--size", type=int, default=SIZE,
                   help=f"pixels a side, odd, in [{lo}, {hi}] (default {SIZE})")


def run(args) -> int:
    import io

    import numpy as np

    from eyelab.apps.common import warn
    from eyelab.core.errors import SpecError, renamed
    from eyelab.core.fileio import atomic_group, check_distinct, check_output, json_writer
    from eyelab.jobs.psf import PSF_FLAGS, point_psf
    from eyelab.spec import load_spec

    if not str(args.output).endswith(".npy"):
        raise SpecError("--output", f"must end in .npy, got {args.output!r}")
    check_output("--output", args.output)
    if args.json:
        check_output("--json", args.json)
        check_distinct(**{"--output": args.output, "--json": args.json})
    spec = load_spec(args.spec)
    warn(spec.warnings)
    with renamed(PSF_FLAGS):
        img, rep = point_psf(spec, point=args.point, no_lens=args.no_lens,
                             pitch_arcmin=args.pitch_arcmin, size=args.size, side=args.eye)

    def npy(path):
        buf = io.BytesIO()
        np.save(buf, img)
        with open(path, "wb") as f:
            f.write(buf.getvalue())

    writers = {args.output: npy}
    if args.json:
        writers[args.json] = json_writer(rep)
    atomic_group(writers)
    for ch in rep["channels"]:
        m30 = ch["mtf"]["30"]
        print(f"{ch['wavelength_nm']:g} nm: Strehl {ch['strehl']:.3f}, RMS {ch['rms_um']:.3f} um "
              f"(higher orders {ch['rms_higher_orders_um']:.3f} um), MTF at 30 c/deg "
              + ("beyond the sampling" if m30 is None else f"{m30:.3f}"))
    if rep.get("lenslets"):
        lm = rep["lenslets"]
        tf = lm["through_focus"]
        peaks = ", ".join(f"{v:+.2f} D ({a:.3f})" for v, a in tf["peak_peaks"])
        print(f"through {lm['add_d']:+.2f} D lenslets ({100 * lm['share']:.1f} % of the "
              f"pupil's light): the PSF holds the carrier's image and theirs (RMS is the "
              f"carrier's wave); through focus at {tf['wavelength_nm']:g} "
              f"nm the PSF's peak over the aberration-free one has maxima at {peaks}")
    print(f"wrote {args.output}" + (f" and {args.json}" if args.json else "") +
          f": {args.size} x {args.size} px at {args.pitch_arcmin:g}'/px, pupil "
          f"{rep['pupil_mm']:g} mm")
    return 0
