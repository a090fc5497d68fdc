"""
Two lens materials: colour fringes
==================================

A −6.00 D lens of CR-39 (Abbe number 58) and the same lens of polycarbonate (Abbe number
30). Away from its optical centre a lens deviates light (prism), and blue more than red:
the lower the Abbe number, the wider the colour fringes at every edge. Here each lens is
decentred 10 mm, so that the line of sight to the chart crosses it 10 mm from its
optical centre, as when the eye looks through the lens's side. The two views look alike
at a glance; their difference shows the fringes, and ``analyze`` prints the prism at
each end of the spectrum.
"""

# %%
# The same eye and Rx, two materials. ``[analysis] wavelength_nm`` sets the wavelength
# ``analyze`` traces at: the prism at the F line (486 nm, blue) less the prism at the C
# line (656 nm, red) is the lens's transverse chromatic aberration there.
import math

import matplotlib.pyplot as plt
import numpy as np

import eyelab

views, tca = {}, {}
for material in ("cr39", "polycarbonate"):
    spec = {"eye": {"rx": "-6.00 DS", "age": 30, "pupil_diameter_mm": 4.0},
            "lens": {"material": material, "decentration_mm": [10.0, 0.0], "coating": "ar"},
            "render": {"scene": "chart", "fov_y_deg": 2.5, "width": 240, "height": 180,
                       "gaze_deg": [3.0, 0.0]}}
    views[material] = eyelab.render(spec)
    prism = {}
    for nm in (486.13, 656.27):
        point = eyelab.analyze({**spec, "analysis": {"wavelength_nm": nm}})["points"][0]
        prism[nm] = point["prism"]["prism_d"]
    tca[material] = prism[486.13] - prism[656.27]
    arcmin = math.degrees(math.atan(tca[material] / 100)) * 60
    print(f"{material:13s} prism {prism[656.27]:.2f} (656 nm) to {prism[486.13]:.2f} "
          f"(486 nm) prism dioptres: fringes {tca[material]:.3f} prism dioptres, "
          f"{arcmin:.1f} arcmin")

# %%
# The two views, and their difference in linear light (polycarbonate less CR-39, each
# channel on its own, scaled up four times about grey): red and blue edges where the
# polycarbonate lens spreads the colours further.
diff = views["polycarbonate"].linear - views["cr39"].linear
print(f"largest difference {np.abs(diff).max():.3f} (linear light, 0-1)")
fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="constrained")
for ax, material in zip(axes, views, strict=False):
    ax.imshow(views[material].srgb)
    ax.set_title(f"{material}: colour fringes {tca[material]:.3f} Δ", fontsize=10)
axes[2].imshow(np.clip(0.5 + 4 * diff, 0, 1))
axes[2].set_title("difference x 4 (grey: none)", fontsize=10)
for ax in axes:
    ax.axis("off")
plt.show()
