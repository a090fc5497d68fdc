"""The quality benchmark's plot: error against wall time per case and method."""

from __future__ import annotations


def plot_error_vs_time(cases, path) -> None:
    """Error (RMSE, 1 - SSIM) against wall time: one line per case and method; colour =
    scene, solid circles = raster (S = 1, 2, 4 ...), dashed squares = reference (spp)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    names = sorted({c["scene"] for c in cases})
    colour = {n: f"C{i}" for i, n in enumerate(names)}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), dpi=100)
    for ax, key, label in ((axes[0], "rmse", "RMSE vs converged reference (linear RGB)"),
                           (axes[1], "ssim", "1 - SSIM vs converged reference")):
        for c in cases:
            for meth, style in (("raster", "o-"), ("reference", "s--"), ("imagebased", "^:")):
                if meth not in c:
                    continue
                t = [m["time_s"] for m in c[meth]]
                e = [m[key] if key == "rmse" else max(1.0 - m[key], 1e-5) for m in c[meth]]
                ax.loglog(t, e, style, color=colour[c["scene"]], alpha=0.55, ms=3, lw=1)
        ax.set_xlabel("wall time per image (s)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.2)
    handles = [Line2D([], [], color="k", marker="o", ls="-", ms=3, label="raster (S passes)"),
               Line2D([], [], color="k", marker="s", ls="--", ms=3,
                      label="reference (spp)"),
               Line2D([], [], color="k", marker="^", ls=":", ms=3,
                      label="image-based (lens samples)")]
    handles += [Line2D([], [], color=colour[n], lw=2, label=n) for n in names]
    axes[1].legend(handles=handles, fontsize=7)
    configs_ = sorted({c["config"] for c in cases})
    fig.suptitle(f"eyelab: error against time ({len(cases)} cases; "
                 f"{', '.join(configs_)})", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
