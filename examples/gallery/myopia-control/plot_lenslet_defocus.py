"""
Myopia-control lenses in numbers: the lenslets' light and its defocus
=====================================================================

A myopia-control lens works by the light that passes its lenslets: it forms a second
image in front of the retina (myopic defocus), the rest of the light the sharp one.
``eyelab analyze`` gives, along each line of sight, the share of the pupil's light
through the lenslets, how many it meets, and their image's defocus and blur: here from
straight ahead to 30° down through the DIMS-like and HALT-like lenses of
``examples/dims.toml`` and ``examples/halt.toml``. ``eyelab maps`` of a wide-angle
schematic eye behind the DIMS-like lens maps both over the visual field, where the eye's
own peripheral refraction takes part of the lenslets' add away.
"""

# %%
# ``analyze`` along the vertical meridian: the specs read as dicts, their ``[[points]]``
# replaced by lines of sight from straight ahead to 30° down (the eye turning to each).
import json
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import eyelab

try:                        # run as a script: examples/gallery/myopia-control/
    EXAMPLES = Path(__file__).resolve().parents[2]
except NameError:           # run by the documentation build, in this script's folder
    EXAMPLES = Path.cwd().parents[1]
downs = list(range(0, 31, 5))
shares = {}
for name, file in (("DIMS-like", "dims.toml"), ("HALT-like", "halt.toml")):
    spec = tomllib.loads((EXAMPLES / file).read_text())
    spec["points"] = [{"field_deg": [0.0, -down]} for down in downs]
    shares[name] = []
    for down, point in zip(downs, eyelab.analyze(spec)["points"], strict=True):
        lenslets = point["lenslets"]
        shares[name].append(lenslets["fraction"])
        line = (f"{name} {down:2d}° down: {100 * lenslets['fraction']:4.1f} % of the light "
                f"through {lenslets['count']:2d} lenslets")
        if lenslets["count"]:
            line += (f"; their image: myopic defocus {lenslets['image_defocus_d']:+.2f} D, "
                     f"blur {lenslets['image_blur_arcmin']:.1f}'")
        print(line)

# %%
# ``eyelab maps`` of ``examples/dims_periphery.toml`` (the DIMS-like lens before a
# Navarro eye of the same myope), run into a temporary folder: it prints the lenslets'
# line of its summary, and its JSON holds the share and the defocus at each field point.
tmp = tempfile.TemporaryDirectory(prefix="eyelab-lenslets-")   # removed when the script ends
out = Path(tmp.name)
run = subprocess.run([sys.executable, "-m", "eyelab.apps.cli", "maps",
                      str(EXAMPLES / "dims_periphery.toml"), "--points", "11",
                      "-o", str(out / "maps.png"), "--json", str(out / "maps.json")],
                     cwd=out, capture_output=True, text=True, check=True)
print(run.stdout.replace(str(out), "<tmp>"))
maps = json.loads((out / "maps.json").read_text())
field = maps["grid"]["field_x_deg"]
share = np.array(maps["lens"]["lenslets"]["share"], dtype=float)
defocus = np.array(maps["lens"]["lenslets"]["myopic_defocus_d"], dtype=float)

# %%
# Left: the share of the pupil's light through the lenslets as the eye looks further
# down. Right: the share over the visual field of the schematic eye fixating straight
# ahead, with contours of the lenslets' myopic defocus (D).
fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained", width_ratios=(1, 1.3))
for name, values in shares.items():
    axes[0].plot(downs, 100 * np.array(values), "o-", label=name)
axes[0].set_xlabel("line of sight, degrees down")
axes[0].set_ylabel("pupil's light through lenslets (%)")
axes[0].legend()
shown = axes[1].pcolormesh(field, field, 100 * share, cmap="viridis", shading="nearest")
fig.colorbar(shown, ax=axes[1], label="light through lenslets (%)")
lines = axes[1].contour(field, field, defocus, levels=[1.5, 2.0, 2.5, 3.0], colors="white")
axes[1].clabel(lines, fmt="%+.1f D", fontsize=8)
axes[1].set_xlabel("field angle right (deg)")
axes[1].set_ylabel("field angle up (deg)")
axes[1].set_aspect("equal")
axes[1].set_title("DIMS-like lens before a schematic eye", fontsize=10)
plt.show()
