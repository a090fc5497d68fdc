"""
What a child sees through myopia-control lenses
===============================================

A −3.00 D myope behind three lenses of the same Rx: single vision, a DIMS-like honeycomb
of +3.50 D lenslets around a clear centre (``examples/dims.toml``) and a HALT-like design
of 11 rings of lenslets (``examples/halt.toml``). Straight ahead the eye looks through
the clear centre at the chart across the room, and the three lenses give the same view.
Looking 20° down at the page, through the treatment zone, the lenslets' defocused image
lies over the sharp one as a veil that softens every edge of the text. Each view is 4°
high, drawn by the raster renderer.
"""

# %%
# Three specs, two gaze directions, the same render settings for all (``dims.toml`` asks
# for the reference renderer at 32 rays a pixel: overridden here).
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                        # run as a script: examples/gallery/myopia-control/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
lenses = {"single vision": {"eye": {"rx": "-3.00", "pupil_diameter_mm": 4},
                            "lens": {"rx": "-3.00"}},
          "DIMS-like": EXAMPLES / "dims.toml",
          "HALT-like": EXAMPLES / "halt.toml"}
gazes = {"straight ahead": 0.0, "20° down": -20.0}


views = {}
for name, spec in lenses.items():
    for where, down in gazes.items():
        views[name, where] = eyelab.render(spec, renderer="raster", samples=8, width=240,
                                           height=180, fov_y_deg=4.0, gaze_deg=(0.0, down))
for name in ("DIMS-like", "HALT-like"):
    diff = [np.abs(views[name, where].linear - views["single vision", where].linear).mean()
            for where in gazes]
    print(f"{name:13s} mean difference from single vision (linear light, 0-1): "
          f"straight ahead {diff[0]:.4f}, 20° down {diff[1]:.4f}")

# %%
# The views: the chart at 6 m through the clear centre (top), the page at 0.4 m through
# the treatment zone (middle), and the luminance down one column of the page's views,
# the one that crosses the most text (bottom): the lenslets' light softens every edge.
fig, axes = plt.subplot_mosaic([["0", "1", "2"], ["3", "4", "5"], ["p", "p", "p"]],
                               figsize=(9, 7.4), layout="constrained",
                               height_ratios=(1, 1, 0.9))
for (name, where), result in views.items():
    ax = axes[str(3 * list(gazes).index(where) + list(lenses).index(name))]
    ax.imshow(result.srgb)
    ax.set_title(f"{name}, {where}", fontsize=9)
    ax.axis("off")
to_luminance = np.array([0.2126, 0.7152, 0.0722])
column = int(np.argmin((views["single vision", "20° down"].linear @ to_luminance).mean(0)))
for name, colour in zip(lenses, ("black", "tab:red", "tab:blue"), strict=True):
    luminance = views[name, "20° down"].linear @ to_luminance
    axes["p"].plot(luminance[:, column], color=colour, label=name)
axes["p"].set_xlabel(f"pixel row, down column {column} of the views 20° down")
axes["p"].set_ylabel("luminance (linear)")
axes["p"].legend(fontsize=8)
plt.show()
