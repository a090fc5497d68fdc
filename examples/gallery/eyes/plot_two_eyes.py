"""
Two eyes behind one frame
=========================

An anisometrope (right −1.00 DS, left −3.50 / −0.75 × 180) of 45 in lenses made for
each eye, both looking at the acuity chart at 6 m, in a frame whose optical centres are
60 mm apart for pupils 64 mm apart. eyelab renders both eyes with one accommodation, as
a real pair shares it, and reports each eye's blur and the prism the frame puts before
the eyes. The two views side by side, and as a red/cyan anaglyph.
"""

# %%
# A two-eye spec: ``[eye.right]`` and ``[eye.left]`` hold each eye's own keys over the
# shared ``[eye]``; ``[binocular]`` the pupils' and the lenses' distances.
import matplotlib.pyplot as plt

import eyelab

spec = {"eye": {"age": 45, "right": {"rx": "-1.00 DS"}, "left": {"rx": "-3.50 -0.75 x 180"}},
        "lens": {"pantoscopic_tilt_deg": 8.0},
        "binocular": {"pd_mm": 64, "frame_pd_mm": 60},
        "render": {"scene": "chart", "fov_y_deg": 8.0, "width": 240, "height": 180}}
result = eyelab.render(spec)
print(result)
both = result.report["binocular"]
print(f"accommodation {both['accommodation_d']:.2f} D ({both['accommodation_rule']})")
for side, eye in both["eyes"].items():
    major, minor = eye["blur_at_fixation_arcmin"]
    print(f"{side:5s} eye {eye['rx']:20s} blur at fixation {major:.2f}' x {minor:.2f}'")
prism = both["prism_at_fixation"]["binocular"]
print(f"prism the frame induces: {prism['horizontal']}, {prism['vertical']}")

# %%
# ``srgb(output)`` composes the two eyes' images as the spec's ``binocular.output`` would.
fig, axes = plt.subplots(2, 1, figsize=(6, 5.4), layout="constrained")
axes[0].imshow(result.srgb("side-by-side"))
axes[0].set_title("side by side (the left eye's view on the left)", fontsize=10)
axes[1].imshow(result.srgb("anaglyph"))
axes[1].set_title("anaglyph", fontsize=10)
for ax in axes:
    ax.axis("off")
plt.show()
