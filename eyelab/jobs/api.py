"""The functions of eyelab's public API (:mod:`eyelab`): from a spec — a TOML file's path,
a :class:`~eyelab.spec.Spec`, the spec's dict, or None for the built-in default — to an
image, a point analysis or as-worn maps, with ``[render]`` keys overridden by keyword.

>>> import eyelab
>>> eyelab.render(None, width=96, height=72, samples=2)       # doctest: +SKIP
<RenderResult 96x72 raster, 2 of 2 samples, 0.61 s>
"""

from __future__ import annotations

from pathlib import Path

from eyelab.core.errors import SpecError
from eyelab.spec import Spec, load_spec, one_eye, parse_spec


def as_spec(spec=None) -> Spec:
    """A :class:`~eyelab.spec.Spec` from a path (str or :class:`~pathlib.Path`), a spec's
    dict (the TOML's tables), a Spec (returned as is) or None (the built-in default)."""
    if spec is None or isinstance(spec, (str, Path)):
        return load_spec(spec)
    if isinstance(spec, Spec):
        return spec
    if isinstance(spec, dict):
        return parse_spec(spec, "<dict>")
    raise TypeError(f"a spec is a path, a dict, a Spec or None, got {type(spec).__name__}")


def with_render(spec: Spec, overrides: dict) -> Spec:
    """``spec`` with ``[render]`` keys replaced (validated again, errors naming the key)."""
    import dataclasses

    if not overrides:
        return spec
    gaze = overrides.get("gaze_deg")
    if isinstance(gaze, tuple):
        overrides = dict(overrides, gaze_deg=list(gaze))   # as a TOML array; else checked as is
    return dataclasses.replace(spec, render=spec.render.with_changes(**overrides))


def render(spec=None, *, no_lens: bool = False, **overrides):
    """What the spec's eye sees (through its lens unless ``no_lens``), or both eyes' images
    for a two-eye spec. ``overrides``: ``[render]`` keys, e.g. ``width=320, samples=8,
    renderer="reference", scene="chart", gaze_deg=(10, -20)``. Returns a
    :class:`~eyelab.imaging.contract.RenderResult` (one eye; ``.save(path)``, shown by
    Jupyter) or an :class:`~eyelab.imaging.stereo.BinocularResult` (two)."""
    from eyelab.jobs.render import render_binocular_spec, render_spec

    s = with_render(as_spec(spec), overrides)
    if s.binocular is not None:
        return render_binocular_spec(s, no_lens=no_lens)
    return render_spec(s, no_lens=no_lens)


def analyze(spec=None, *, no_lens: bool = False) -> dict:
    """The lens designer's point analysis of the spec's ``[[points]]`` (``eyelab analyze``'s
    JSON report, as a dict)."""
    from eyelab.jobs.analyze import analyze_spec

    return analyze_spec(as_spec(spec), no_lens=no_lens)


def maps(spec=None, *, half_angle_deg: float = 30.0, n: int = 31):
    """As-worn maps of the spec's lens over an n x n grid of eye rotations (Fick angles
    about the centre of rotation) within ±half_angle_deg
    (:class:`~eyelab.optics.asworn.AsWornMaps`)."""
    from eyelab.optics.asworn import as_worn_maps

    s = one_eye(as_spec(spec), "maps")
    if s.lens is None:
        raise SpecError("lens", "the spec has no lens to map")
    return as_worn_maps(s.eye, s.lens, half_angle_deg=half_angle_deg, n=n,
                        wavelength_nm=s.wavelength_nm)


def builtin_scene(name: str = "room", **params):
    """A built-in scene by name (:data:`eyelab.scene.library.SCENE_NAMES`), with its
    parameters (e.g. ``builtin_scene("chart", distance_m=6.0)``)."""
    from eyelab.core.checks import check_choice
    from eyelab.scene.library import SCENE_NAMES, SCENES

    check_choice("scene", name, SCENE_NAMES)
    return SCENES[name](**params)
