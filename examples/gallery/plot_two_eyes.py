"""
Two eyes behind one frame
=========================

An anisometrope (right −1.00 DS, left −3.50 / −0.75 × 180) in lenses made for each eye:
both eyes' views side by side as the spec asks, and as a red/cyan anaglyph.
"""

import matplotlib.pyplot as plt

import eyelab

spec = {"eye": {"age": 45, "right": {"rx": "-1.00 DS"}, "left": {"rx": "-3.50 -0.75 x 180"}},
        "lens": {"pantoscopic_tilt_deg": 8.0},
        "binocular": {"pd_mm": 64},
        "render": {"scene": "chart", "fov_y_deg": 8.0, "width": 240, "height": 180}}
result = eyelab.render(spec)
print(result)

fig, axes = plt.subplots(2, 1, figsize=(6, 5.4))
axes[0].imshow(result.srgb("side-by-side"))
axes[0].set_title("side by side (left eye's view on the left)")
axes[1].imshow(result.srgb("anaglyph"))
axes[1].set_title("anaglyph")
for ax in axes:
    ax.axis("off")
fig.tight_layout()
