"""High-level jobs for the apps: render a spec, and the comparison demo."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from eyelab.errors import SpecError
from eyelab.fileio import atomic_path, json_default
from eyelab.render.raster import RasterRenderer, RenderSettings
from eyelab.scene.scene import Scene


def build_scene(name_or_path: str) -> Scene:
    from data_generators.scenes import SCENES

    if name_or_path in SCENES:
        return SCENES[name_or_path]()
    from eyelab.scene.scene import load_mesh

    return Scene([load_mesh(name_or_path)], name=Path(name_or_path).stem)


def settings_from(spec, **overrides) -> RenderSettings:
    kw = dict((spec.render or {}).get("settings", {}))
    kw.update({k: v for k, v in overrides.items() if v is not None})
    try:
        return RenderSettings(**kw)
    except SpecError as e:
        raise SpecError(e.field, e.message) from None


def write_png(path, image: np.ndarray) -> None:
    """Atomic PNG write (no partial file on failure)."""
    import matplotlib.image as mpimg

    with atomic_path(path, suffix=".png") as tmp:
        mpimg.imsave(tmp, image)


def write_json(path, obj) -> None:
    with atomic_path(path) as tmp, open(tmp, "w") as f:
        json.dump(obj, f, indent=2, default=json_default)


def render_spec(spec, *, no_lens=False, renderer=None, **overrides):
    """Render what the spec's eye sees (through its lens unless ``no_lens``)."""
    scene = build_scene(spec.render["scene"] if spec.render else "room")
    settings = settings_from(spec, **overrides)
    own = renderer is None
    r = renderer or RasterRenderer(settings)
    try:
        return r.render(scene, spec.eye, None if no_lens else spec.lens)
    finally:
        if own:
            r.close()


def demo(spec, **overrides):
    """Three views of the spec's scene: the uncorrected eye, the eye with its lens, and an
    emmetrope of the same accommodation and pupil. Returns (image, report)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = build_scene(spec.render["scene"] if spec.render else "room")
    settings = settings_from(spec, **overrides)
    emmetrope = dataclasses.replace(spec.eye, power_min=spec.eye.emmetropic_power,
                                    astigmatism=0.0)
    panels = []
    reports = {}
    with RasterRenderer(settings) as r:
        for label, eye, lens in (("uncorrected", spec.eye, None),
                                 ("with the lens", spec.eye, spec.lens),
                                 ("emmetrope", emmetrope, None)):
            if label == "with the lens" and lens is None:
                continue
            res = r.render(scene, eye, lens)
            panels.append((label, res.image))
            reports[label] = res.report
    h, w = panels[0][1].shape[:2]
    fig = plt.figure(figsize=(len(panels) * w / 100, h / 100 + 0.5), dpi=100)
    for i, (label, img) in enumerate(panels):
        ax = fig.add_axes([i / len(panels), 0, 1 / len(panels), h / (h + 50)])
        ax.imshow(img)
        ax.set_axis_off()
        fig.text((i + 0.5) / len(panels), 1 - 25 / (h + 50), label, ha="center", va="center",
                 fontsize=14)
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    rx = None if spec.lens is None or spec.lens.rx is None else spec.lens.rx.format()
    return image, {"scene": scene.name, "lens_rx": rx, "eye": dataclasses.asdict(spec.eye),
                   "emmetrope": dataclasses.asdict(emmetrope), "panels": reports}
