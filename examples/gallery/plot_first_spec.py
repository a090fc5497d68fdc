"""
Your first spec, with and without its lens
==========================================

The README's spec (``examples/first.toml``): a −2.50 / −0.75 × 90 wearer looking at the
acuity chart at 6 m, through a polycarbonate lens made for the Rx and without it.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import eyelab

try:                       # this script's folder: examples/gallery/
    HERE = Path(__file__).resolve().parent
except NameError:          # run by the documentation build, from that folder
    HERE = Path.cwd()
spec = HERE.parent / "first.toml"
through = eyelab.render(spec)
naked = eyelab.render(spec, no_lens=True)

fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
for ax, result, title in ((axes[0], through, "through the lens"),
                          (axes[1], naked, "uncorrected")):
    ax.imshow(result.srgb)
    ax.set_title(title)
    ax.axis("off")
fig.tight_layout()

# %%
# The report says what each render did and skipped:
print(through.report["skipped"])
