"""
A patient's aberrometry: point-spread function and view
=======================================================

The keratoconic eye of ``examples/aberrometer.toml``: Zernike coefficients from an
aberrometer's export (``examples/zernike.csv``, measured over 6 mm), seen through a
5 mm pupil. Its second-order terms are its refraction, so a lens can be made for them;
its coma and trefoil stay. The point-spread function at three wavelengths, then the
acuity chart naked and through a lens made for the refraction.
"""

# %%
# The spec as a dict (its coefficient file named by its full path), and the same with a
# ``[lens]`` that has no ``rx``: a lens made for the Rx the second order gives.
import tomllib
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                        # run as a script: examples/gallery/eyes/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
print((EXAMPLES / "aberrometer.toml").read_text())
naked = tomllib.loads((EXAMPLES / "aberrometer.toml").read_text())
naked["eye"]["aberrations"]["file"] = str(EXAMPLES / "zernike.csv")
with_lens = {**naked, "lens": {"material": "cr39"}}

# %%
# ``eyelab.psf``: the wave-optics PSF of the naked eye per colour channel, each at its
# own wavelength (the eye's chromatic aberration included), with its wave's RMS, Strehl
# ratio and MTF; 65 x 65 pixels of half an arcminute (the default: 129 of a quarter).
psf, report = eyelab.psf(naked, pitch_arcmin=0.5, size=65)
for c in report["channels"]:
    print(f"{c['wavelength_nm']:.0f} nm: wave {c['rms_um']:.3f} um RMS "
          f"({c['rms_higher_orders_um']:.3f} above second order) over "
          f"{report['pupil_mm']:g} mm, Strehl {c['strehl']:.4f}, "
          f"MTF at 10 c/deg {c['mtf']['10']:.3f}")

# %%
# The chart at 6 m, naked and through the lens: the lens takes away the sphere and
# cylinder, and the coma's smear stays.
views = {"naked": eyelab.render(naked), "through a lens for its Rx": eyelab.render(with_lens)}

fig = plt.figure(figsize=(9, 6.4), layout="constrained")
top, bottom = fig.subfigures(2, 1, height_ratios=(1.0, 1.25))
half = report["pitch_arcmin"] * (psf.shape[-1] // 2)
for ax, image, channel in zip(top.subplots(1, 3), psf, report["channels"], strict=True):
    ax.imshow(np.sqrt(image / image.max()), cmap="magma",
              extent=(-half, half, -half, half))
    ax.set_title(f"{channel['wavelength_nm']:.0f} nm, Strehl {channel['strehl']:.3f}",
                 fontsize=10)
    ax.set_xlabel("arcmin")
top.suptitle("the naked eye's PSF (square root of intensity)", fontsize=10)
for ax, (label, result) in zip(bottom.subplots(1, 2), views.items(), strict=True):
    ax.imshow(result.srgb)
    ax.set_title(label, fontsize=10)
    ax.axis("off")
plt.show()
