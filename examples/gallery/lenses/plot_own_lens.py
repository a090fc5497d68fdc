"""
Bring your own lens: surfaces from a lab's points files
=======================================================

A lens need not come from an Rx: ``[lens.front]`` and ``[lens.back]`` can read the
surfaces a lab's software writes, as grids of sags. ``examples/points.toml`` reads a
−3.00 / −1.50 × 30 CR-39 lens back from its two files — the front from a Vision
Council DCS file (``front.sdf``), the back from a CSV grid of sags (``back.csv``) — and
``examples/lens.toml`` is the lens they were written from. Their as-worn maps agree:
the difference printed and drawn below is what the points grids leave out.
"""

# %%
# The two specs, side by side: the points-file lens names its files relative to the
# spec.
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                        # run as a script: examples/gallery/lenses/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
print((EXAMPLES / "points.toml").read_text())

# %%
# The as-worn maps of both lenses over ±30° of eye rotation, and their differences.
from_rx = eyelab.maps(EXAMPLES / "lens.toml", n=21)
from_points = eyelab.maps(EXAMPLES / "points.toml", n=21)
print("from its Rx:         ", from_rx)
print("from its points files:", from_points)
diff = {name: np.asarray(getattr(from_points, name)) - np.asarray(getattr(from_rx, name))
        for name in ("mean_error_d", "cylinder_d")}
for name, d in diff.items():
    print(f"{name}: largest difference {np.nanmax(np.abs(d)):.4f} D")

fig, axes = plt.subplots(1, 3, figsize=(10, 3.3), layout="constrained")
x, y = from_rx.eye_rotation_x_deg, from_rx.eye_rotation_y_deg
for ax, maps, title in ((axes[0], from_rx, "cylinder (D), lens from its Rx"),
                        (axes[1], from_points, "cylinder (D), from points files")):
    filled = ax.contourf(x, y, maps.cylinder_d, levels=np.arange(-0.5, 0.01, 0.05),
                         cmap="magma")
    ax.set_title(title, fontsize=10)
fig.colorbar(filled, ax=axes[:2], shrink=0.8)
d = 1000 * diff["mean_error_d"]
span = np.nanmax(np.abs(d))
shown = axes[2].pcolormesh(x, y, d, vmin=-span, vmax=span, cmap="RdBu_r")
fig.colorbar(shown, ax=axes[2], shrink=0.8)
axes[2].set_title("mean power error, points less Rx (mD)", fontsize=10)
for ax in axes:
    ax.set_aspect("equal")
    ax.set_xlabel("eye rotation right (deg)")
axes[0].set_ylabel("eye rotation up (deg)")
plt.show()
