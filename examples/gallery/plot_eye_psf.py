"""
An aberrometer's eye: its point-spread function
===============================================

The keratoconic eye of ``examples/aberrometer.toml`` (Zernike coefficients from
``examples/zernike.csv``, measured over 6 mm), its wave-optics PSF over a 5 mm pupil at
three wavelengths, each with its Strehl ratio.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                       # this script's folder: examples/gallery/
    HERE = Path(__file__).resolve().parent
except NameError:          # run by the documentation build, from that folder
    HERE = Path.cwd()
spec = HERE.parent / "aberrometer.toml"
psf, report = eyelab.psf(spec)          # (3, 129, 129): one PSF per colour channel

half = report["pitch_arcmin"] * (psf.shape[-1] // 2)
fig, axes = plt.subplots(1, len(psf), figsize=(9, 3.2))
for ax, image, channel in zip(axes, psf, report["channels"], strict=True):
    ax.imshow(np.sqrt(image / image.max()), cmap="magma",
              extent=(-half, half, -half, half))
    ax.set_title(f"{channel['wavelength_nm']:.0f} nm, Strehl {channel['strehl']:.3f}")
    ax.set_xlabel("arcmin")
fig.tight_layout()
