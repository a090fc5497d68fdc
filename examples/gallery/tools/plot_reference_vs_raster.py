"""
The reference renderer against the raster renderer
==================================================

eyelab has three renderers behind one interface. The raster renderer (the default) draws
Kakimoto's blur fields on the GPU's rasteriser in a second or two; the reference
renderer traces rays through the lens and the pupil for every pixel, slower and exact up
to its sampling noise. Here both draw the first spec's wearer without the lens (the blur
is where they could differ), and their difference and SSIM (structural similarity, 1
for equal images) compare them in linear light. A second reference image, its rays
drawn with another seed, shows how much of the difference is the reference's own noise.
"""

# %%
# The same spec twice; ``renderer`` and ``samples`` are ``[render]`` keys (for the
# reference renderer, rays per pixel and colour channel).
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

import eyelab

try:                        # run as a script: examples/gallery/tools/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
size = {"width": 128, "height": 96}
raster = eyelab.render(EXAMPLES / "first.toml", no_lens=True, **size)
reference, again = (eyelab.render(EXAMPLES / "first.toml", no_lens=True,
                                  renderer="reference", samples=64, seed=seed, **size)
                    for seed in (0, 1))
print(raster)
print(reference)

# %%
# SSIM and PSNR against the reference's image, in linear light (0-1).
b = reference.linear
for label, image in (("raster", raster), ("reference, seed 1", again)):
    ssim = structural_similarity(image.linear, b, channel_axis=2, data_range=1.0)
    psnr = peak_signal_noise_ratio(b, image.linear, data_range=1.0)
    print(f"{label:17s} against the reference (seed 0): SSIM {ssim:.4f}, PSNR {psnr:.1f} dB")
a = raster.linear
ssim = structural_similarity(a, b, channel_axis=2, data_range=1.0)

fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), layout="constrained")
axes[0].imshow(raster.srgb)
axes[0].set_title(f"raster, {raster.report['timings_s']['total']:.1f} s", fontsize=10)
axes[1].imshow(reference.srgb)
axes[1].set_title(f"reference, 64 rays a pixel, {reference.report['timings_s']['total']:.1f} s",
                  fontsize=10)
axes[2].imshow(np.clip(0.5 + 4 * (a - b), 0, 1))
axes[2].set_title(f"raster less reference x 4: SSIM {ssim:.3f}", fontsize=10)
for ax in axes:
    ax.axis("off")
plt.show()
