"""
A batch job: a small sweep and its contact sheet
================================================

``eyelab batch`` renders a grid of jobs from one job spec: a base spec, with axes swept
over any dotted spec key. Here two myopes (−1.00 and −3.00 DS) each in a CR-39 and a
polycarbonate lens made for their Rx, looking at the chart: four jobs, written into a
temporary folder with a JSON sidecar each, a ``summary.csv`` and an ``index.html``
contact sheet. Run again, the batch finds every job done and renders nothing.
"""

# %%
# The job spec, written into the temporary folder beside a copy of its base,
# ``examples/base.toml`` (a relative path is read from the job spec's folder).
import csv
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

try:                        # run as a script: examples/gallery/tools/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
tmp = tempfile.TemporaryDirectory(prefix="eyelab-batch-")   # removed when the script ends
out = Path(tmp.name)
shutil.copy(EXAMPLES / "base.toml", out)
print((out / "base.toml").read_text())
job = out / "job.toml"
job.write_text('''spec = "base.toml"
[base]
# small images, few passes and a coarse blur field (the default: 128 x 32 x 32): quick
render = {width = 120, height = 90, samples = 4, field_shape = [64, 16, 16]}
[output]
formats = ["png"]
[sweep]
mode = "product"
"eye.rx" = ["-1.00 DS", "-3.00 DS"]
"lens.material" = ["cr39", "polycarbonate"]
''')
print(job.read_text())

# %%
# Run it twice: the second run finds each job's sidecar and image and skips it.
command = [sys.executable, "-m", "eyelab.apps.cli", "batch", str(job), "-o",
           str(out / "batch-out"), "--quiet"]
for _ in range(2):
    run = subprocess.run(command, cwd=out, capture_output=True, text=True, check=True)
    print(run.stdout.replace(str(out), "<tmp>"))

# %%
# The summary, one row per job, and the images as a contact sheet.
with open(out / "batch-out" / "summary.csv", newline="") as f:
    rows = list(csv.DictReader(f))
fig, axes = plt.subplots(1, len(rows), figsize=(2.4 * len(rows), 2.4), layout="constrained")
for ax, row in zip(axes, rows, strict=True):
    print(f"job {row['index']}: {row['param:eye.rx']}, {row['param:lens.material']}: "
          f"{row['status']}, rendered in {float(row['render_s']):.2f} s")
    ax.imshow(plt.imread(out / "batch-out" / row["image"]))
    ax.set_title(f"{row['param:eye.rx']}\n{row['param:lens.material']}", fontsize=9)
    ax.axis("off")
plt.show()
