"""
A progressive lens's power and astigmatism maps
===============================================

The analytic progressive design of ``docs/gallery/pal_analytic.toml`` (−2.00 DS, add
+2.00, a 14 mm corridor) worn by a 60-year-old: its mean power error and unwanted
cylinder over the eye's rotations, as ``eyelab maps`` draws them. Looking down the
corridor the lens gives the add for a page that comes nearer; beside the corridor the
cylinder grows. The maps compare the lens with what each gaze direction needs: far
objects above, nearer ones below (printed below the code).
"""

# %%
# ``eyelab.maps`` traces the lens over an n x n grid of eye rotations (Fick angles about
# the eye's centre of rotation) and returns the maps as arrays.
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                        # run as a script: examples/gallery/lenses/
    ROOT = Path(__file__).resolve().parents[3]
except NameError:           # run by the documentation build, in this script's folder
    ROOT = Path.cwd().parents[2]
spec = ROOT / "docs" / "gallery" / "pal_analytic.toml"
print(spec.read_text())
maps = eyelab.maps(spec, half_angle_deg=40, n=33)
print(maps)
print("objects looked at:", maps.model["up"], "above;", maps.model["down"])
print("reference points (eye rotation right, up; deg):",
      {name: tuple(round(v, 1) for v in xy) for name, xy in maps.marks.items()})

# %%
# The two maps, with the design's reference points: the fitting cross, the distance
# reference above it and the near reference down the corridor, set in toward the nose.
fig, axes = plt.subplots(1, 2, figsize=(9, 4), layout="constrained")
x, y = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
for ax, z, title, levels, cmap in (
        (axes[0], maps.mean_error_d, "mean power error (D)", np.arange(-2, 2.01, 0.25),
         "RdBu_r"),
        (axes[1], maps.cylinder_d, "cylinder (D)", np.arange(-3, 0.01, 0.25), "magma")):
    filled = ax.contourf(x, y, np.ma.masked_invalid(z), levels=levels, cmap=cmap,
                         extend="both")
    fig.colorbar(filled, ax=ax, shrink=0.8)
    for name, (mx, my) in maps.marks.items():
        ax.plot(mx, my, "k+", markersize=10)
        ax.annotate(name, (mx, my), textcoords="offset points", xytext=(5, 4), fontsize=8)
    ax.set_title(title)
    ax.set_xlabel("eye rotation right (deg)")
    ax.set_aspect("equal")
axes[0].set_ylabel("eye rotation up (deg)")
plt.show()
