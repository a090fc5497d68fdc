"""
What a child sees through myopia-control lenses
===============================================

A −3.00 D myope of ten behind three lenses of the same Rx — single vision, a DIMS-like
honeycomb of +3.50 D lenslets (``examples/dims.toml``) and a HALT-like design of 11 rings
(``examples/halt.toml``) — looking straight ahead across the room, 20° down at the page
and 30° down, each view 10° high, drawn by the raster renderer (one view per pupil sample
where its rays meet lenslets). Through the clear centre the three agree; through the
treatment zone the lenslets' defocused image veils the sharp one.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import eyelab

try:                       # this script's folder: examples/gallery/
    HERE = Path(__file__).resolve().parent
except NameError:          # run by the documentation build, from that folder
    HERE = Path.cwd()
lenses = {"single vision": {"eye": {"rx": "-3.00", "pupil_diameter_mm": 4},
                            "lens": {"rx": "-3.00"}},
          "DIMS-like": HERE.parent / "dims.toml",
          "HALT-like": HERE.parent / "halt.toml"}
gazes = (0, 20, 30)

fig, axes = plt.subplots(len(gazes), len(lenses), figsize=(9, 5.6))
for j, (name, spec) in enumerate(lenses.items()):
    for i, down in enumerate(gazes):
        result = eyelab.render(spec, renderer="raster", width=200, height=150,
                               fov_y_deg=10.0, gaze_deg=(0.0, -down))
        axes[i, j].imshow(result.srgb)
        axes[i, j].set_title(f"{name}, {down}° down", fontsize=9)
        axes[i, j].axis("off")
fig.tight_layout()
