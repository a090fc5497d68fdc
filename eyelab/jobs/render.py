"""High-level jobs for the apps: build a spec's scene, render a spec (one eye or two), the
comparison demo."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from eyelab.imaging.contract import Renderer
from eyelab.imaging.registry import make_renderer
from eyelab.scene.scene import Scene


def build_scene(source) -> Scene:
    """The scene a :class:`~eyelab.scene.scene.SceneSource` (or a bare name or path)
    describes: a built-in scene (:data:`eyelab.scene.library.SCENES`) or the parts of a
    mesh file, placed, lit as its ``shading`` says, with its background (a mesh file's
    default: white)."""
    import dataclasses

    from eyelab.scene.library import SCENES
    from eyelab.scene.scene import SceneSource, apply_shading, load_meshes

    src = source if isinstance(source, SceneSource) else SceneSource(str(source))
    if src.name in SCENES:
        # the chart's own parameters, where the spec gave them (only the chart takes them)
        params = {k: v for k, v in (("distance_m", src.chart_distance_m),
                                    ("contrast", src.chart_contrast)) if v is not None}
        scene = SCENES[src.name](**params)
        if src.placed:
            m = src.matrix()
            scene = dataclasses.replace(scene, meshes=[x.transformed(m) for x in scene.meshes])
        scene = dataclasses.replace(scene, meshes=apply_shading(scene.meshes, src.shading))
    else:
        scene = Scene(load_meshes(src.name, transform=src.matrix() if src.placed else None,
                                  shading=src.shading), name=Path(src.name).stem)
    if src.background is not None:
        scene = dataclasses.replace(scene, background=tuple(src.background))
    return scene


def render_spec(spec, *, no_lens: bool = False, renderer: Renderer | None = None,
                scene: Scene | None = None):
    """Render what the spec's eye sees (through its lens unless ``no_lens``) with the spec's
    renderer, view and quality (:class:`eyelab.spec.RenderSpec`); ``renderer`` reuses an
    open renderer of the same kind, ``scene`` the spec's scene built already (what
    :func:`build_scene` makes of ``spec.render.scene``)."""
    rs = spec.render
    scene = build_scene(rs.scene) if scene is None else scene
    # the observer: the spec's camera lens where it has one, else its eye (and lens)
    observer = spec.eye if rs.camera is None else rs.camera
    lens = None if no_lens or rs.camera is not None else spec.lens
    if renderer is not None:
        return _with_spec_warnings(renderer.render(scene, observer, lens, rs.view,
                                                   rs.quality), spec)
    with make_renderer(rs.renderer, rs.quality) as r:
        return _with_spec_warnings(r.render(scene, observer, lens, rs.view), spec)


def _with_spec_warnings(result, spec):
    """``result`` with the spec's own warnings first in its report's ``warnings``."""
    if spec.warnings:
        result.report["warnings"] = list(dict.fromkeys([*spec.warnings,
                                                        *result.report["warnings"]]))
    return result


def render_binocular_spec(spec, *, no_lens: bool = False, renderer: Renderer | None = None,
                          scene: Scene | None = None):
    """Both eyes of a binocular spec (:func:`eyelab.imaging.stereo.render_binocular`) with
    the spec's renderer, view and quality; ``renderer`` reuses an open renderer of that
    kind, ``scene`` the spec's scene built already. Returns a
    :class:`~eyelab.imaging.stereo.BinocularResult`."""
    from eyelab.imaging.stereo import render_binocular

    rs = spec.render
    scene = build_scene(rs.scene) if scene is None else scene
    if renderer is not None:
        res = render_binocular(renderer, scene, spec.binocular, rs.view, rs.quality,
                               no_lens=no_lens)
    else:
        with make_renderer(rs.renderer, rs.quality) as r:
            res = render_binocular(r, scene, spec.binocular, rs.view, no_lens=no_lens)
    for side in (res.right, res.left):
        _with_spec_warnings(side, spec)
    return res


def _emmetrope(eye):
    """The eye made emmetropic (same accommodation, pupil and chromatic aberration): a thin
    eye's powers set to its emmetropic power; a schematic eye of the same model, its axial
    length the one that images infinity on its retina (its ``rx`` 0)."""
    if hasattr(eye, "power_min"):
        return dataclasses.replace(eye, power_min=eye.emmetropic_power, astigmatism=0.0)
    return type(eye).from_rx("+0.00", model=eye.model, accommodation_max=eye.accommodation_max,
                             pupil_diameter=eye.pupil_diameter,
                             rotation_centre=eye.rotation_centre)


def demo(spec):
    """Three views of the spec's scene: the uncorrected eye, the eye with its lens, and an
    emmetrope of the same accommodation and pupil (a binocular spec: a row per eye, each
    column rendered binocularly — vergence and one accommodation for both eyes). Returns
    (image, report): the report's units first (:func:`eyelab.core.fileio.with_units`), the
    eyes as their spec keys (:func:`eyelab.jobs.analyze.eye_table`), each panel's render
    report under its label in ``panels`` (binocular: ``rows`` names the figure's rows,
    top first, and their columns; a panel's label is "<row>, <column>")."""
    rs = spec.render
    if rs.camera is not None:
        from eyelab.core.errors import SpecError

        raise SpecError("render.camera", "the demo compares eyes; render a camera lens with "
                                         "eyelab render")
    scene = build_scene(rs.scene)
    if spec.binocular is not None:
        return _demo_binocular(spec, scene)
    emmetrope = _emmetrope(spec.eye)
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
    from eyelab.core.fileio import with_units
    from eyelab.jobs.analyze import eye_table

    rx = None if spec.lens is None or spec.lens.rx is None else spec.lens.rx.format()
    return panel_figure([panels]), with_units({
        "scene": scene.name, "renderer": rs.renderer, "lens_rx": rx,
        "eye": eye_table(spec.eye), "emmetrope": eye_table(emmetrope), "panels": reports})


def _demo_binocular(spec, scene):
    from eyelab.imaging.stereo import render_binocular
    from eyelab.optics.chain.binocular import SIDES

    rs = spec.render
    b = spec.binocular
    emm = dataclasses.replace(b.without_lenses(), right=_emmetrope(b.right),
                              left=_emmetrope(b.left))
    configs = [("uncorrected", b.without_lenses()), ("with the lenses", b),
               ("emmetropes", emm)]
    if b.right_lens is None:
        configs.pop(1)
    rows = {s: [] for s in SIDES}
    reports, binocular = {}, {}
    with make_renderer(rs.renderer, rs.quality) as r:
        for label, wearer in configs:
            res = render_binocular(r, scene, wearer, rs.view)
            binocular[label] = res.report["binocular"]
            for side in SIDES:
                rows[side].append((f"{side} eye, {label}", getattr(res, side).srgb))
                reports[f"{side} eye, {label}"] = res.report[side]
    from eyelab.core.fileio import with_units
    from eyelab.jobs.analyze import eye_table

    rx = {s: None if b.lens(s) is None or b.lens(s).rx is None else b.lens(s).rx.format()
          for s in SIDES}
    return panel_figure([rows["right"], rows["left"]]), with_units({
        "scene": scene.name, "renderer": rs.renderer, "lens_rx": rx,
        "eye": {s: eye_table(b.eye(s)) for s in SIDES}, "binocular": binocular,
        "rows": {f"{s} eye": [label for label, _ in configs] for s in SIDES},
        "panels": reports})


#: The panels' frame: a neutral mid grey (sRGB code) that reads on white and on black
#: scenes, ``PANEL_FRAME_PX`` pixels wide, drawn over each panel's outermost pixels.
PANEL_FRAME_GREY = 128
PANEL_FRAME_PX = 2
#: The label band above each panel (pixels) and the labels' largest font size (points).
LABEL_BAND_PX = 50
LABEL_PT = 14


def framed(img: np.ndarray) -> np.ndarray:
    """A copy of an (h, w, 3) uint8 panel with its :data:`PANEL_FRAME_PX` outermost pixels
    :data:`PANEL_FRAME_GREY`."""
    out = np.array(img, dtype=np.uint8, copy=True)
    k = PANEL_FRAME_PX
    out[:k] = out[-k:] = PANEL_FRAME_GREY
    out[:, :k] = out[:, -k:] = PANEL_FRAME_GREY
    return out


def _fit_label(text, width_px: float, height_px: float) -> None:
    """Set a matplotlib ``text`` on one line or on two (broken at its first comma),
    whichever fits ``width_px`` x ``height_px`` at the larger font size, at that size
    (at most :data:`LABEL_PT`; one line where both fit whole)."""
    renderer = text.figure.canvas.get_renderer()
    label = text.get_text()
    best_scale, best = 0.0, label
    for candidate in dict.fromkeys((label, label.replace(", ", "\n", 1))):
        text.set_text(candidate)
        text.set_fontsize(LABEL_PT)
        box = text.get_window_extent(renderer)
        scale = min(1.0, width_px / box.width, height_px / box.height)
        if scale > best_scale:
            best_scale, best = scale, candidate
    text.set_text(best)
    text.set_fontsize(LABEL_PT * best_scale)


def panel_figure(rows: list) -> np.ndarray:
    """(H, W, 3) uint8 image of labelled panels: ``rows`` of [(label, (h, w, 3) uint8)],
    every panel the same size, framed (:func:`framed`), a :data:`LABEL_BAND_PX` band above
    each holding its label (shrunk or broken at its comma to fit the panel's width)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h, w = rows[0][0][1].shape[:2]
    ncol, nrow = max(len(r) for r in rows), len(rows)
    band = h + LABEL_BAND_PX
    fig = plt.figure(figsize=(ncol * w / 100, nrow * band / 100), dpi=100)
    for j, row in enumerate(rows):
        for i, (label, img) in enumerate(row):
            bottom = (nrow - 1 - j) * band / (nrow * band)
            ax = fig.add_axes([i / ncol, bottom, 1 / ncol, h / (nrow * band)])
            ax.imshow(framed(img), interpolation="nearest")
            ax.set_axis_off()
            text = fig.text((i + 0.5) / ncol, bottom + (h + LABEL_BAND_PX / 2) / (nrow * band),
                            label, ha="center", va="center_baseline", linespacing=1.0)
            _fit_label(text, 0.9 * w, 0.9 * LABEL_BAND_PX)
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return image
