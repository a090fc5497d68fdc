"""
A progressive lens's views: far, near and the blurred sides
===========================================================

The 60-year-old −2.00 D myope of ``docs/gallery/pal_analytic.toml`` has little
accommodation left: through a single-vision −2.00 lens the chart at 6 m is sharp and
the page at 0.4 m is not. Through the progressive lens (add +2.00) the eye reads the
page by looking down the corridor, and the lower sides of the view blur and bend where
the lens's unwanted cylinder lies. Each pixel is seen as the eye sees a point it turns to
look at, so one wide view shows the whole lens.
"""

# %%
# Two lenses for the same eye, as spec dicts: the progressive one read from its file.
# One wide view of the room (50° high, the eye turned 12° down) each, and ``analyze`` at
# the page's centre, 0.4 m away and 30° down (the eye turning to look at it).
import tomllib
from pathlib import Path

import matplotlib.pyplot as plt

import eyelab

try:                        # run as a script: examples/gallery/lenses/
    ROOT = Path(__file__).resolve().parents[3]
except NameError:           # run by the documentation build, in this script's folder
    ROOT = Path.cwd().parents[2]
progressive = tomllib.loads((ROOT / "docs" / "gallery" / "pal_analytic.toml").read_text())
lenses = {"progressive, add +2.00": progressive,
          "single vision -2.00": {"eye": progressive["eye"], "lens": {"rx": "R -2.00 DS"}}}
page = [{"distance_m": 0.4, "field_deg": [0.0, -30.0]}]
views, blur = {}, {}
for label, spec in lenses.items():
    views[label] = eyelab.render(spec, width=320, height=240, fov_y_deg=50.0,
                                 gaze_deg=(0.0, -12.0), samples=4)
    point = eyelab.analyze({**spec, "points": page})["points"][0]
    blur[label] = point["blur"]["major_arcmin"]
    print(f"{label:23s} at the page: accommodation {point['accommodation_d']:.2f} D, "
          f"blur {point['blur']['major_arcmin']:.1f}' x {point['blur']['minor_arcmin']:.1f}'")

# %%
# The two views, and the page enlarged below each.
fig, axes = plt.subplots(2, 2, figsize=(9, 6.4), layout="constrained",
                         height_ratios=(1.0, 0.9))
for j, (label, result) in enumerate(views.items()):
    axes[0, j].imshow(result.srgb)
    axes[0, j].set_title(label, fontsize=10)
    axes[1, j].imshow(result.srgb[150:240, 100:220], interpolation="nearest")
    axes[1, j].set_title(f"the page: blur {blur[label]:.1f}' (semi-major axis)", fontsize=10)
for ax in axes.flat:
    ax.axis("off")
plt.show()
