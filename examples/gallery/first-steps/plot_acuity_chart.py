"""
Reading the acuity chart through a lens that is a little off
============================================================

The built-in ``chart`` scene is an ETDRS chart at 6 m: five Sloan letters a row, from
logMAR 1.0 at the top to −0.3 at the bottom. The −2.50 / −0.75 × 90 wearer of
``examples/first.toml`` reads it through a lens made for the Rx, and through lenses whose
sphere falls 0.50 D and 1.00 D short, as an old pair of glasses would. The view takes
the chart's lower rows, from logMAR 0.5 down, at 0.75 arcminute a pixel, the eye turned
2.1° down to them.
"""

# %%
# One spec, three lenses: ``lens.rx`` sets what the lens is made for, while ``eye.rx``
# stays the wearer's.
import matplotlib.pyplot as plt

import eyelab

eye = {"rx": "-2.50 -0.75 x 90", "age": 30, "pupil_diameter_mm": 4.0}
lenses = {"made for the Rx": "-2.50 -0.75 x 90",
          "0.50 D short": "-2.00 -0.75 x 90",
          "1.00 D short": "-1.50 -0.75 x 90"}
view = {"scene": "chart", "fov_y_deg": 2.8, "width": 288, "height": 224,
        "gaze_deg": [0.0, -2.1]}
pixel = 60 * view["fov_y_deg"] / view["height"]
print(f"{pixel:.2f} arcmin a pixel: a logMAR 0 letter (5 arcmin) is {5 / pixel:.1f} pixels")
views, blur = {}, {}
for label, rx in lenses.items():
    spec = {"eye": eye, "lens": {"rx": rx, "material": "polycarbonate"}, "render": view}
    views[label] = eyelab.render(spec)
    point = eyelab.analyze(spec)["points"][0]            # straight ahead, at infinity
    blur[label] = point["blur"]["major_arcmin"]
    print(f"{label:16s} blur {point['blur']['major_arcmin']:.2f}' x "
          f"{point['blur']['minor_arcmin']:.2f}' (semi-axes, arcmin)")

# %%
# The letters at 6 m. A letter of logMAR 0 (6/6, 20/20) is 5 arcminutes tall, its strokes
# one arcminute wide. The blur printed above is the blur ellipse's semi-axes on the
# retina, in arcminutes of the visual angle.
fig, axes = plt.subplots(1, 3, figsize=(9, 3.2), layout="constrained")
for ax, (label, result) in zip(axes, views.items(), strict=True):
    ax.imshow(result.srgb, interpolation="nearest")
    ax.set_title(f"{label}\nblur {blur[label]:.1f}' (semi-major axis)", fontsize=10)
    ax.axis("off")
plt.show()
