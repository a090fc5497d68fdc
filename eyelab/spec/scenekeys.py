"""The ``[render] scene = {…}`` table's rows of the spec's reference
(:data:`eyelab.spec.schema.KEYS`) and the ranges only the spec knows for them, apart from
their parser (:func:`eyelab.spec.render.parse_scene`, which reads the schema): the schema
builds them with its own ``Key``, so no import runs in a circle."""

from __future__ import annotations

from eyelab.scene.scene import PLAIN_GREY, UNITS
from eyelab.scene.shading import AMBIENT, LIGHT_DIRECTION, SHADINGS

#: The reference's heading of the table (:data:`eyelab.spec.schema.TABLES`).
SCENE_TABLE = ("`[render] scene = {…}` (a mesh file placed in the world: a vertex v goes to "
               "R_z R_y R_x (units × scale × v) + position_m)")
#: Ranges of the table's keys (the schema's :data:`~eyelab.spec.schema.LIMITS` has them).
SCENE_LIMITS = {
    "render.scene.distance_m": (0.1, 100.0), "render.scene.contrast": (0.0, 1.0),
    "render.scene.scale": (1e-9, 1e9), "render.scene.rotation_deg": (-360.0, 360.0),
    "render.scene.position_m": (-1e4, 1e4)}
#: A spec the table's keys are read in.
SCENE_BASE = {"render": {"scene": {"path": "room"}}}


def _light_text() -> str:
    """The shading model in words, with its constants (:mod:`eyelab.scene.shading`)."""
    lx, ly, lz = (f"{c:.3f}".replace("-", "−") for c in LIGHT_DIRECTION)
    return (f"albedo × ({AMBIENT:g} + {1 - AMBIENT:g} max(0, n·l)) in linear light, l = "
            f"({lx}, {ly}, {lz}) toward the light (upper left, behind the head), baked into "
            "the vertex colours before any blur")


def scene_keys(key) -> list:
    """The ``[render] scene = {…}`` rows, made by the schema's ``key`` class
    (:class:`eyelab.spec.schema.Key`)."""
    chart = {"render": {"scene": {"path": "chart"}}}
    return [
        key("render.scene", "path", "text", "", "required", "a mesh file (any format "
            "trimesh reads; relative to the spec) or a built-in scene's name",
            range_text="an existing file or a built-in name"),
        key("render.scene", "distance_m", "number", "m", "6", 'the built-in chart\'s '
            'distance (path = `"chart"` only)', base=chart),
        key("render.scene", "contrast", "number", "", "1", "the built-in chart's Weber "
            "contrast, in linear light (1: black letters)", base=chart),
        key("render.scene", "units", "choice", "", '`"m"`', "the file's length unit",
            choices=tuple(UNITS), base=SCENE_BASE),
        key("render.scene", "scale", "number", "", "1", "a further scale factor",
            base=SCENE_BASE),
        key("render.scene", "rotation_deg", "triple", "deg", "[0, 0, 0]", "rotations about "
            "x, then y, then z (world axes)", base=SCENE_BASE),
        key("render.scene", "position_m", "triple", "m", "[0, 0, 0]", "where the file's "
            "origin goes (the pupil is at the origin, looking along −z)", base=SCENE_BASE),
        key("render.scene", "shading", "choice", "", '`"auto"`', "how the meshes are lit: "
            f"Lambertian shading, {_light_text()}; `\"auto\"` shades the parts without "
            f"colours or texture (their albedo sRGB {PLAIN_GREY} grey), `\"lambert\"` every part "
            "but textured ones, `\"none\"` draws every part flat in its own colours",
            choices=SHADINGS, base=SCENE_BASE),
    ]


__all__ = ["SCENE_BASE", "SCENE_LIMITS", "SCENE_TABLE", "scene_keys"]
