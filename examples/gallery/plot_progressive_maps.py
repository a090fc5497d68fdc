"""
A progressive lens as worn
==========================

The analytic progressive design of ``docs/gallery/pal_analytic.toml``: its mean power
error and unwanted cylinder over the eye's rotations, as ``eyelab maps`` draws them.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                       # this script's folder: examples/gallery/
    HERE = Path(__file__).resolve().parent
except NameError:          # run by the documentation build, from that folder
    HERE = Path.cwd()
root = HERE.parents[1]
maps = eyelab.maps(root / "docs" / "gallery" / "pal_analytic.toml", n=31)
print(maps)

fig, axes = plt.subplots(1, 2, figsize=(9, 4))
x, y = maps.eye_rotation_x_deg, maps.eye_rotation_y_deg
for ax, z, title, levels, cmap in (
        (axes[0], maps.mean_error_d, "mean power error (D)", np.arange(-2, 2.01, 0.25),
         "RdBu_r"),
        (axes[1], maps.cylinder_d, "cylinder (D)", np.arange(-3, 0.01, 0.25), "magma")):
    filled = ax.contourf(x, y, np.ma.masked_invalid(z), levels=levels, cmap=cmap,
                         extend="both")
    fig.colorbar(filled, ax=ax, shrink=0.8)
    ax.set_title(title)
    ax.set_xlabel("eye rotation right (deg)")
    ax.set_aspect("equal")
axes[0].set_ylabel("eye rotation up (deg)")
fig.tight_layout()
