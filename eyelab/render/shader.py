"""GLSL replacement helper: the one place that knows VTK's shader replacement tags."""

from __future__ import annotations

from importlib import resources

#: Vertex shader tags measured to exist in VTK 9.7 (shared/docs/VTK_NOTES.md, Q5).
VERTEX_TAGS = ("//VTK::PositionVC::Dec", "//VTK::PositionVC::Impl",
               "//VTK::CustomBegin::Impl", "//VTK::CustomEnd::Impl")


def glsl(name: str) -> str:
    """Text of ``eyelab/render/shaders/<name>.glsl``."""
    return resources.files("eyelab.render").joinpath(f"shaders/{name}.glsl").read_text()


def inject_vertex(shader_property, name: str) -> None:
    """Apply ``shaders/<name>.glsl`` as a vertex-shader replacement. The file's first line
    must be the VTK tag it replaces (kept in the replacement, so VTK's own code stays)."""
    text = glsl(name)
    tag = text.splitlines()[0].strip()
    if tag not in VERTEX_TAGS:
        raise ValueError(f"shader {name!r} starts with unknown tag {tag!r}; known: {VERTEX_TAGS}")
    shader_property.AddVertexShaderReplacement(tag, True, text, False)
