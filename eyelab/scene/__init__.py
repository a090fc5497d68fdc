"""Scenes: meshes with colours or textures (numpy), loaders, ray casting, refinement.
No VTK here."""

from eyelab.scene.scene import Scene, SceneMesh

__all__ = ["Scene", "SceneMesh"]
