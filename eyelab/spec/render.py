"""``[render]``: the scene, the renderer and its view and quality options, and a camera
lens that may see the scene instead of the eye."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

from eyelab.core.checks import check_choice, check_range, check_rgb
from eyelab.core.errors import SpecError
from eyelab.imaging.contract import View
from eyelab.imaging.options import RasterQuality
from eyelab.imaging.registry import CAMERA_RENDERERS, QUALITIES, RENDERERS, quality_keys
from eyelab.optics.cameralens.system import LensSystem
from eyelab.scene.library import SCENE_NAMES
from eyelab.scene.scene import UNITS, SceneSource
from eyelab.scene.shading import SHADINGS
from eyelab.spec.schema import LIMITS, check
from eyelab.spec.tables import check_keys, check_rules


@dataclass(frozen=True)
class RenderSpec:
    """The ``[render]`` table, validated: the scene (a built-in name or a mesh file path),
    the renderer's name, the :class:`~eyelab.imaging.contract.View` and the renderer's quality
    options (:mod:`eyelab.imaging.options`). ``table`` keeps the keys as written, so that
    :meth:`with_changes` can re-validate them for another renderer or with overrides."""

    scene: SceneSource = SceneSource("room")
    renderer: str = "raster"
    view: View = View()
    quality: object = field(default_factory=RasterQuality)
    table: dict = field(default_factory=dict)
    #: A camera lens (:class:`eyelab.optics.cameralens.system.LensSystem`, focused) that sees the
    #: scene instead of the eye: ``[render] camera`` (renderers in :data:`CAMERA_RENDERERS`).
    camera: LensSystem | None = None

    def with_changes(self, **changes) -> RenderSpec:
        """The same table with some keys replaced (None values are ignored), validated
        again; ``renderer`` may name another renderer (keys only the old one has are then
        dropped, as if never written)."""
        t = dict(self.table)
        t.update({k: v for k, v in changes.items() if v is not None})
        if "camera" in t and t.get("renderer") not in CAMERA_RENDERERS:
            # blame the key the caller changed: the renderer asked for, else the camera
            blamed = "renderer" if changes.get("renderer") is not None else "camera"
            raise SpecError(f"render.{blamed}", f"a camera lens renders with "
                            f"{' or '.join(map(repr, CAMERA_RENDERERS))}, not "
                            f"{t.get('renderer')!r} (render.camera = {t['camera']!r})")
        if "renderer" in changes and changes["renderer"] is not None:
            check_choice("render.renderer", changes["renderer"], RENDERERS)
            other = set(renderer_keys(self.renderer)) - set(renderer_keys(t["renderer"]))
            for k in other:
                t.pop(k, None)
        new = parse_render(t, None)
        # the eye's accommodation comes from [eye], not from this table: keep it
        return dataclasses.replace(new, view=dataclasses.replace(
            new.view, focus_d=self.view.focus_d))


#: Keys of ``[render]`` that every renderer takes (the rest are renderers' quality options).
RENDER_VIEW_KEYS = {"width": "width", "height": "height", "fov_y_deg": "fov_y_deg",
                    "near_m": "near", "far_m": "far", "cvd": "cvd",
                    "cvd_severity": "cvd_severity", "gaze_deg": "gaze_deg"}


#: Quality options that are display choices rather than spec keys.
_NOT_SPEC_KEYS = {"progress"}


#: The keys of a camera lens that sees the scene instead of the eye (renderers in
#: :data:`~eyelab.imaging.registry.CAMERA_RENDERERS`).
CAMERA_KEYS = ("camera", "camera_focus_m", "camera_f_number")


def renderer_keys(renderer: str) -> tuple:
    """The ``[render]`` keys a renderer takes: scene, renderer, the view's and its quality
    options'."""
    return ("scene", "renderer", "background", *RENDER_VIEW_KEYS,
            *(CAMERA_KEYS if renderer in CAMERA_RENDERERS else ()),
            *(k for k in quality_keys(renderer) if k not in _NOT_SPEC_KEYS))


def parse_render(t: dict, base: Path | None = None) -> RenderSpec:
    """The [render] table -> :class:`RenderSpec` (every key checked; a key another renderer
    takes is refused with the renderer it belongs to)."""
    if not isinstance(t, dict):
        raise SpecError("render", f"must be a table, got {t!r}")
    renderer = check_choice("render.renderer", t.get("renderer", "raster"), RENDERERS)
    allowed = set(renderer_keys(renderer))
    every = {k for r in RENDERERS for k in renderer_keys(r)}
    for key in t:
        if key not in allowed and key in every:
            owners = [r for r in RENDERERS if key in renderer_keys(r)]
            raise SpecError(f"render.{key}", f"only for renderer = {' or '.join(map(repr, owners))}"
                                             f" (this spec uses {renderer!r})")
    check_keys(t, allowed, "render")
    check_rules(t, "render")                 # a camera has no eye to turn (gaze_deg)
    scene, written = parse_scene(t.get("scene", "room"), t.get("background"), base)
    view = View(**{attr: t[key] for key, attr in RENDER_VIEW_KEYS.items() if key in t})
    qkw = {k: t[k] for k in quality_keys(renderer) if k in t}
    for key in ("field_shape", "rim_color", "invalid_color"):
        if key in qkw and isinstance(qkw[key], list):
            qkw[key] = tuple(qkw[key])
    quality = QUALITIES[renderer](**qkw)
    table = dict(t, scene=written, renderer=renderer)
    return RenderSpec(scene, renderer, view, quality, table, parse_camera(t))


def parse_camera(t: dict):
    """``[render] camera`` (a named lens system of
    :data:`eyelab.optics.cameralens.system.EXAMPLES`), ``camera_focus_m`` (object distance in focus
    from the first vertex, m, or "inf"; default "inf") and ``camera_f_number`` (the stop made
    smaller: f / stop diameter; default the lens's full aperture) -> the focused
    :class:`~eyelab.optics.cameralens.system.LensSystem`, or None without ``camera``."""
    from eyelab.optics.cameralens.system import EXAMPLES, full_f_number, get_system

    if "camera" not in t:
        for key in CAMERA_KEYS[1:]:
            if key in t:
                raise SpecError(f"render.{key}", "only with render.camera")
        return None
    name = check_choice("render.camera", t["camera"], tuple(EXAMPLES))
    system = get_system(name)
    focus = t.get("camera_focus_m", "inf")
    if isinstance(focus, str) and focus.strip().lower() in ("inf", "infinity"):
        focus = math.inf
    else:
        focus = check("render.camera_focus_m", focus)
    full = full_f_number(system)
    if "camera_f_number" in t:
        fnum = check_range("render.camera_f_number", t["camera_f_number"], full,
                           LIMITS["render.camera_f_number"][1])
        system = system.with_stop(system.cardinal()["efl_m"] / (2 * fnum))
    return system.focused(focus)


#: Keys of a ``[render] scene`` table (a mesh file placed in the world).
SCENE_KEYS = {"path", "position_m", "scale", "rotation_deg", "units", "distance_m",
              "contrast", "shading"}


def parse_scene(value, background, base: Path | None) -> tuple:
    """``[render] scene`` (a built-in name, a mesh path, or a table {path, position_m,
    scale, rotation_deg, units, shading; distance_m, contrast for the built-in chart}) and
    ``[render] background`` -> (:class:`SceneSource`,
    the value with its path resolved, as the spec table keeps it)."""
    table = value if isinstance(value, dict) else {"path": value}
    if not isinstance(value, (str, dict)):
        raise SpecError("render.scene", f"must be one of {SCENE_NAMES}, a mesh file path or "
                                        "a table {path, position_m, scale, rotation_deg, "
                                        f"units}}, got {value!r}")
    where = "render.scene" if isinstance(value, str) else "render.scene.path"
    if isinstance(value, dict):
        check_keys(value, SCENE_KEYS, "render.scene")
        if "path" not in value:
            raise SpecError("render.scene.path", "a scene table needs the mesh file's path")
    name = table["path"]
    if not isinstance(name, str):
        raise SpecError(where, f"must be a built-in scene name or a mesh file path, "
                               f"got {name!r}")
    name = _scene_path(name, where, base)

    def triple(key):
        v = table.get(key, [0.0, 0.0, 0.0])
        if not (isinstance(v, list) and len(v) == 3):
            raise SpecError(f"render.scene.{key}", f"must be [x, y, z], got {v!r}")
        return tuple(check(f"render.scene.{key}[{i}]", x)
                     for i, x in enumerate(v))

    units = table.get("units", "m")
    check_choice("render.scene.units", units, tuple(UNITS))
    shading = check_choice("render.scene.shading", table.get("shading", "auto"), SHADINGS)
    bg = None if background is None else check_rgb("render.background", background)
    chart = {}
    for key in ("distance_m", "contrast"):
        if key in table:
            if name != "chart":
                raise SpecError(f"render.scene.{key}", "only for the built-in chart "
                                                       "(path = \"chart\")")
            chart[key] = check(f"render.scene.{key}", table[key])
    src = SceneSource(name, chart_distance_m=chart.get("distance_m"),
                      chart_contrast=chart.get("contrast"),
                      position_m=triple("position_m"),
                      scale=check("render.scene.scale", table.get("scale", 1.0)),
                      rotation_deg=triple("rotation_deg"), units=units,
                      background=bg, shading=shading)
    return src, (dict(value, path=name) if isinstance(value, dict) else name)


def _scene_path(name: str, where: str, base: Path | None) -> str:
    """A built-in scene's name as it is, or a mesh file's path resolved against the spec's
    folder ``base`` (refused, naming ``where``, unless the file exists)."""
    if name in SCENE_NAMES:
        return name
    p = Path(name) if base is None or Path(name).is_absolute() else base / name
    try:
        ok = p.is_file()
    except OSError:
        ok = False
    if not ok:
        raise SpecError(where, f"{name[:80]!r} is neither a built-in scene "
                               f"({', '.join(SCENE_NAMES)}) nor an existing mesh file")
    return str(p)
