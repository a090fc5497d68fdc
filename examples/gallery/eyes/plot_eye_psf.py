"""
The eye's point-spread function and the pupil
=============================================

``eyelab.psf`` gives the eye's point-spread function in wave optics: diffraction at the
pupil, the defocus and astigmatism left through the lens, and the eye's own chromatic
aberration, per colour channel, with its Strehl ratio and MTF. Here the corrected wearer
of ``examples/first.toml`` looks at a distant point through pupils of 2, 4 and 6 mm. The
eye's refraction, and the lens, are for the d line (588 nm, yellow): green and, more,
blue light focus in front of the retina. A small pupil spreads every colour by
diffraction; a large one turns that chromatic defocus into a wider blur.
"""

# %%
# The same spec with three pupils. ``pitch_arcmin`` and ``size`` set the PSF's sampling.
import matplotlib.pyplot as plt
import numpy as np

import eyelab

spec = {"eye": {"rx": "-2.50 -0.75 x 90", "age": 30},
        "lens": {"material": "polycarbonate"}}
pupils = (2.0, 4.0, 6.0)
results = {}
for pupil in pupils:
    spec["eye"]["pupil_diameter_mm"] = pupil
    psf, report = eyelab.psf(spec, pitch_arcmin=0.25, size=65)
    results[pupil] = psf, report
    print(f"{pupil:g} mm pupil: Strehl " + ", ".join(
        f"{c['strehl']:.3f} at {c['wavelength_nm']:.0f} nm" for c in report["channels"]))

# %%
# The green channel's PSF for each pupil, and its MTF (contrast passed against spatial
# frequency, from the report) for all three.
fig, axes = plt.subplots(1, 4, figsize=(11, 3), layout="constrained",
                         width_ratios=(1, 1, 1, 1.4))
for ax, (pupil, (psf, report)) in zip(axes, results.items(), strict=False):
    half = report["pitch_arcmin"] * (psf.shape[-1] // 2)
    green = psf[1]
    ax.imshow(np.sqrt(green / green.max()), cmap="magma", extent=(-half, half, -half, half))
    ax.set_title(f"{pupil:g} mm, 546 nm: Strehl {report['channels'][1]['strehl']:.2f}",
                 fontsize=10)
    ax.set_xlabel("arcmin")
    mtf = report["channels"][1]["mtf"]
    axes[3].plot([float(f) for f in mtf], list(mtf.values()), "o-", label=f"{pupil:g} mm")
axes[3].set_xlabel("cycles per degree")
axes[3].set_ylabel("MTF, 546 nm")
axes[3].legend()
plt.show()
