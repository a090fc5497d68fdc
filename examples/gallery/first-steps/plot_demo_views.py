"""
The demo's three views
======================

``eyelab demo`` renders the built-in room (an acuity chart on the far wall, boxes, a page
to read) for its built-in wearer, a myope with astigmatism, three ways: uncorrected,
through a CR-39 lens made for the Rx, and as an emmetrope with the same accommodation
and pupil sees it. Here the command runs from Python into a temporary folder at a small
size, and the chart is enlarged below each view: the myope's blur is in the distance.
"""

# %%
# Run the command as you would in a shell, into a temporary folder. It writes the picture
# and, beside it, a JSON report of the eyes and of every view's render.
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

tmp = tempfile.TemporaryDirectory(prefix="eyelab-demo-")   # removed when the script ends
out = Path(tmp.name)
command = [sys.executable, "-m", "eyelab.apps.cli", "demo", "--width", "320", "--height",
           "240", "--samples", "4", "--quiet", "-o", str(out / "demo.png")]
run = subprocess.run(command, cwd=out, capture_output=True, text=True, check=True)
print(run.stdout.replace(str(out), "<tmp>"))
image = plt.imread(out / "demo.png")
report = json.loads((out / "demo.json").read_text())
print("the lens's Rx:", report["lens_rx"])
for label, panel in report["panels"].items():
    print(f"{label:14s} rendered in {panel['timings_s']['total']:.2f} s")

# %%
# The demo's picture on top. The three views sit side by side, each 320 pixels wide, at
# the bottom of the picture (a band above holds the labels); below, the middle of each
# view, where the chart hangs, enlarged pixel for pixel. Through the lens the view is a
# little smaller (a minus lens minifies) and darker (the uncoated lens reflects some
# light).
width, height = 320, 240
fig = plt.figure(figsize=(9, 5.6), layout="constrained")
top, bottom = fig.subfigures(2, 1, height_ratios=(1.0, 1.1))
ax = top.subplots()
ax.imshow(image)
ax.axis("off")
axes = bottom.subplots(1, 3)
views = image[-height:]
for i, (ax, label) in enumerate(zip(axes, report["panels"], strict=True)):
    view = views[:, i * width:(i + 1) * width]
    ax.imshow(view[96:144, 124:196], interpolation="nearest")
    ax.set_title(f"{label}: the chart", fontsize=10)
    ax.axis("off")
plt.show()
