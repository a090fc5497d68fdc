"""Spec files: the TOML a user writes, read into the engine's objects.

:mod:`.tables` reads one table, :mod:`.parse` the eye, the lens and the object points
(:mod:`.eyemodel` a schematic eye's keys),
:mod:`.render` the ``[render]`` table, :mod:`.sides` the eyes' sides (one eye or two),
:mod:`.load` the whole document; :mod:`.eyerx` derives the powers ``eye.rx`` takes from the
eye's limits; :mod:`.docs` writes the spec reference's tables.
"""

from eyelab.spec.load import (
    Spec,
    dump_spec,
    load_spec,
    no_camera,
    one_eye,
    parse_spec,
    pick_eye,
    read_spec_data,
    thin_eye,
)
from eyelab.spec.parse import (
    ANALYSIS_KEYS,
    BINOCULAR_KEYS,
    EYE_KEYS,
    LENS_KEYS,
    POINT_KEYS,
    SURFACE_KEYS,
)
from eyelab.spec.render import SCENE_KEYS, RenderSpec, parse_render, renderer_keys

__all__ = ["ANALYSIS_KEYS", "BINOCULAR_KEYS", "EYE_KEYS", "LENS_KEYS", "POINT_KEYS",
           "SCENE_KEYS", "SURFACE_KEYS", "RenderSpec", "Spec", "dump_spec", "load_spec",
           "no_camera", "one_eye", "parse_render", "parse_spec", "pick_eye", "read_spec_data",
           "renderer_keys", "thin_eye"]
