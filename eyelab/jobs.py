"""High-level jobs for the apps: pick a renderer, render a spec, the comparison demo, write
images and reports. The one place that knows every renderer by name."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from eyelab.fileio import atomic_path, json_default
from eyelab.imaging import Renderer
from eyelab.scene.scene import Scene


def make_renderer(name: str, quality=None) -> Renderer:
    """A renderer by name ("raster" or "reference", :data:`eyelab.options.RENDERERS`)."""
    if name == "raster":
        from eyelab.render.raster import RasterRenderer

        return RasterRenderer(quality)
    if name == "reference":
        from eyelab.reference.tracer import ReferenceRenderer

        return ReferenceRenderer(quality)
    from eyelab.errors import SpecError
    from eyelab.options import RENDERERS

    raise SpecError("render.renderer", f"must be one of {', '.join(map(repr, RENDERERS))}, "
                                       f"got {name!r}")


def build_scene(source) -> Scene:
    """The scene a :class:`~eyelab.scene.scene.SceneSource` (or a bare name or path)
    describes: a built-in scene (:data:`eyelab.scene.library.SCENES`) or the parts of a
    mesh file, placed, with its background (a mesh file's default: white)."""
    import dataclasses

    from eyelab.scene.library import SCENES
    from eyelab.scene.scene import SceneSource, load_meshes

    src = source if isinstance(source, SceneSource) else SceneSource(str(source))
    if src.name in SCENES:
        # the chart's own parameters, where the spec gave them (only the chart takes them)
        params = {k: v for k, v in (("distance_m", src.chart_distance_m),
                                    ("contrast", src.chart_contrast)) if v is not None}
        scene = SCENES[src.name](**params)
        if src.placed:
            m = src.matrix()
            scene = dataclasses.replace(scene, meshes=[x.transformed(m) for x in scene.meshes])
    else:
        scene = Scene(load_meshes(src.name, transform=src.matrix() if src.placed else None),
                      name=Path(src.name).stem)
    if src.background is not None:
        scene = dataclasses.replace(scene, background=tuple(src.background))
    return scene


def png_writer(image: np.ndarray):
    """A writer (``write(path)``) of an (h, w, 3) uint8 image as PNG."""
    def write(path):
        import matplotlib.image as mpimg

        mpimg.imsave(path, image, format="png")
    return write


def json_writer(obj):
    """A writer (``write(path)``) of ``obj`` as JSON (numpy values converted)."""
    def write(path):
        with open(path, "w") as f:
            json.dump(obj, f, indent=2, default=json_default)
    return write


def write_png(path, image: np.ndarray) -> None:
    """Atomic PNG write of an (h, w, 3) uint8 image (no partial file on failure)."""
    with atomic_path(path, suffix=".png") as tmp:
        png_writer(image)(tmp)


def write_json(path, obj) -> None:
    """Atomic JSON write (numpy values converted)."""
    with atomic_path(path) as tmp:
        json_writer(obj)(tmp)


def render_spec(spec, *, no_lens: bool = False, renderer: Renderer | None = None):
    """Render what the spec's eye sees (through its lens unless ``no_lens``) with the spec's
    renderer, view and quality (:class:`eyelab.spec.RenderSpec`); ``renderer`` reuses an
    open renderer of the same kind."""
    rs = spec.render
    scene = build_scene(rs.scene)
    if renderer is not None:
        return renderer.render(scene, spec.eye, None if no_lens else spec.lens, rs.view,
                               rs.quality)
    with make_renderer(rs.renderer, rs.quality) as r:
        return r.render(scene, spec.eye, None if no_lens else spec.lens, rs.view)


def demo(spec):
    """Three views of the spec's scene: the uncorrected eye, the eye with its lens, and an
    emmetrope of the same accommodation and pupil. Returns (image, report)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rs = spec.render
    scene = build_scene(rs.scene)
    emmetrope = dataclasses.replace(spec.eye, power_min=spec.eye.emmetropic_power,
                                    astigmatism=0.0)
    panels = []
    reports = {}
    with make_renderer(rs.renderer, rs.quality) as r:
        for label, eye, lens in (("uncorrected", spec.eye, None),
                                 ("with the lens", spec.eye, spec.lens),
                                 ("emmetrope", emmetrope, None)):
            if label == "with the lens" and lens is None:
                continue
            res = r.render(scene, eye, lens, rs.view)
            panels.append((label, res.srgb))
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
    return image, {"scene": scene.name, "renderer": rs.renderer, "lens_rx": rx,
                   "eye": dataclasses.asdict(spec.eye),
                   "emmetrope": dataclasses.asdict(emmetrope), "panels": reports}
