"""
A schematic eye's periphery: peripheral refraction and the retinal image
========================================================================

``examples/myope.toml`` is a −3 D axial myope as a wide-angle schematic eye (Escudero-Sanz
& Navarro 1999) wearing the single-vision lens that corrects it. ``eyelab maps`` traces
its refraction over the visual field while it fixates straight ahead, naked and through
the lens; the relative peripheral refraction (RPR: the refraction less that on the axis)
is what myopia research measures. Off the axis the tangential and sagittal foci part
(oblique astigmatism). ``eyelab.render`` draws the room on the retina of the eye
fixating straight ahead through its lens.
"""

# %%
# Run ``eyelab maps`` into a temporary folder (its JSON holds the maps and the 1°
# profiles along both meridians); it prints its summary.
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import eyelab

try:                        # run as a script: examples/gallery/eyes/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
tmp = tempfile.TemporaryDirectory(prefix="eyelab-periphery-")   # removed when the script ends
out = Path(tmp.name)
run = subprocess.run([sys.executable, "-m", "eyelab.apps.cli", "maps",
                      str(EXAMPLES / "myope.toml"), "--points", "11", "-o",
                      str(out / "periphery.png"), "--json", str(out / "periphery.json")],
                     cwd=out, capture_output=True, text=True, check=True)
print(run.stdout.replace(str(out), "<tmp>"))
maps = json.loads((out / "periphery.json").read_text())
for part in ("naked", "lens"):
    for p in maps[part]["profiles"]["horizontal"]["points"]:
        angle = int(round(p["field_deg"][0]))
        if angle in (0, 30):
            print(f"{part:5s} {angle:+3d}°: M {p['m_d']:+.2f} D, tangential "
                  f"{p['tangential_d']:+.2f} D, sagittal {p['sagittal_d']:+.2f} D")

# %%
# The refraction along the horizontal meridian, naked and through the lens, and the
# retinal image of the room (the eye fixating straight ahead through its lens), drawn
# with a coarser blur field than the default (128 x 32 x 32 voxels) to keep it quick.
retina = eyelab.render(EXAMPLES / "myope.toml", width=240, height=180, samples=4,
                       field_shape=[64, 16, 16])
print(retina)

fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), layout="constrained",
                         width_ratios=(1, 1.2))
for part, style, label in (("naked", "--", "naked eye"), ("lens", "-", "through the lens")):
    profile = maps[part]["profiles"]["horizontal"]
    x = profile["field_deg"]
    for key, colour, name in (("rpr_d", "k", "RPR"), ("tangential_d", "tab:red", "tangential"),
                              ("sagittal_d", "tab:blue", "sagittal")):
        y = [p[key] - (maps[part]["m_on_axis_d"] if key != "rpr_d" else 0.0)
             for p in profile["points"]]
        axes[0].plot(x, y, style, color=colour, label=f"{name}, {label}")
axes[0].set_xlabel("field angle, horizontal meridian (deg)")
axes[0].set_ylabel("refraction less the axis's (D)")
axes[0].legend(fontsize=7, ncol=2)
axes[1].imshow(retina.srgb)
axes[1].set_title("the room on the retina, through the lens", fontsize=10)
axes[1].axis("off")
plt.show()
