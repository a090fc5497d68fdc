"""
Your first spec, with and without its lens
==========================================

The README's spec, ``examples/first.toml``: a −2.50 / −0.75 × 90 wearer of 30 looks at
the acuity chart at 6 m, once through a polycarbonate lens made for the Rx and once
without it. ``eyelab.render`` returns the image; ``eyelab.analyze`` gives the numbers
behind it, here the size of the retinal blur straight ahead.
"""

# %%
# Render the spec twice: through its lens, and with ``no_lens=True``.
from pathlib import Path

import matplotlib.pyplot as plt

import eyelab

try:                        # run as a script: examples/gallery/first-steps/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
spec = EXAMPLES / "first.toml"
print(spec.read_text())
through = eyelab.render(spec)
naked = eyelab.render(spec, no_lens=True)

# %%
# The point analysis of the same spec: the blur ellipse's semi-axes on the retina for an
# object straight ahead at infinity, through the lens and without it.
blur = {}
for label, no_lens in (("through the lens", False), ("uncorrected", True)):
    point = eyelab.analyze(spec, no_lens=no_lens)["points"][0]
    blur[label] = (point["blur"]["major_arcmin"], point["blur"]["minor_arcmin"])
    print(f"{label:17s} blur {blur[label][0]:5.2f}' x {blur[label][1]:5.2f}' "
          f"(semi-axes, arcmin)")

fig, axes = plt.subplots(1, 2, figsize=(8, 3.6), layout="constrained")
for ax, (label, result) in zip(axes, (("through the lens", through),
                                      ("uncorrected", naked)), strict=True):
    ax.imshow(result.srgb)
    ax.set_title(f"{label}\nblur {blur[label][0]:.1f}' x {blur[label][1]:.1f}'")
    ax.axis("off")

# %%
# Each render's report says what it did and what it skipped:
print(through)
print(through.report["skipped"])
plt.show()
