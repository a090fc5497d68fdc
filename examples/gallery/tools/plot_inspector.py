"""
The inspector's window, shot offscreen
======================================

``eyelab inspect`` opens one window: what the wearer sees on the left; the scene with the
eye, the lens and the line of sight, the blur field's ellipses and the lens's as-worn
maps on the right; the status and the sliders (Rx, pupil, age, focus, samples) below.
With ``--screenshot`` it renders the view to its target samples, writes it and exits;
``--window-shot`` also writes the whole window. ``--offscreen`` draws it without a
display, as the documentation build does: the picture below is the inspector's own
window on the spec ``examples/first.toml``.
"""

# %%
# Run the inspector offscreen into a temporary folder. Beside the view it writes the spec
# it shows (``view.toml``): what ``s`` saves in the window.
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

try:                        # run as a script: examples/gallery/tools/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
tmp = tempfile.TemporaryDirectory(prefix="eyelab-inspect-")   # removed when the script ends
out = Path(tmp.name)
run = subprocess.run([sys.executable, "-m", "eyelab.apps.cli", "inspect",
                      str(EXAMPLES / "first.toml"), "--size", "320x240", "--samples", "4",
                      "--offscreen", "--screenshot", str(out / "view.png"),
                      "--window-shot", str(out / "window.png")],
                     cwd=out, capture_output=True, text=True, check=True)
print(run.stdout.replace(str(out), "<tmp>"))
print((out / "view.toml").read_text())

# %%
# The window as the inspector drew it.
window = plt.imread(out / "window.png")
print(f"window {window.shape[1]} x {window.shape[0]} px")
fig, ax = plt.subplots(figsize=(9.6, 7.1), layout="constrained")
ax.imshow(window)
ax.axis("off")
plt.show()
