"""eyelab: what a person sees through spectacle lenses.

The public API — everything a notebook needs, imported on first use (``import eyelab``
loads no VTK and no embree)::

    import eyelab
    result = eyelab.render("spec.toml", width=320, samples=8)   # or a dict, a Spec, None
    result.save("view.png")                                     # Jupyter shows `result`
    eye = eyelab.Eye.from_rx("-3.00 / -1.00 x 180")

Functions: :func:`render`, :func:`analyze`, :func:`maps`, :func:`psf`, :func:`load_spec`,
:func:`make_renderer` (a renderer by name), :func:`builtin_scene`. Types:
:class:`Session` (open renderers and built scenes kept between calls; the functions use a
shared default one unless given ``session=``), :class:`Eye`, :class:`Prescription`,
:class:`SpectacleLens`, :class:`LensPose`, :class:`Material`, :class:`Scene`,
:class:`View`, :class:`RenderResult`, :class:`Spec`, :class:`SpecError`,
:class:`NotebookInspector` (the live view with sliders in Jupyter). The packages
below are the layers (docs/ARCHITECTURE.md).
"""

from __future__ import annotations

import functools
import importlib
import sys
import types

__version__ = "0.1.0"

#: Public name -> the module that defines it (imported on first use).
_API = {
    "SpecError": "eyelab.core.errors",
    "Prescription": "eyelab.optics.eye.prescription",
    "Eye": "eyelab.optics.eye.thin",
    "SpectacleLens": "eyelab.optics.lens.spectacle",
    "LensPose": "eyelab.optics.lens.spectacle",
    "Material": "eyelab.optics.rays.materials",
    "get_material": "eyelab.optics.rays.materials",
    "Scene": "eyelab.scene.scene",
    "SCENE_NAMES": "eyelab.scene.library",
    "View": "eyelab.imaging.contract",
    "RenderResult": "eyelab.imaging.contract",
    "RENDERERS": "eyelab.imaging.registry",
    "make_renderer": "eyelab.imaging.registry",
    "Spec": "eyelab.spec",
    "load_spec": "eyelab.spec",
    "render": "eyelab.jobs.api",
    "analyze": "eyelab.jobs.api",
    "maps": "eyelab.jobs.api",
    "psf": "eyelab.jobs.api",
    "Session": "eyelab.jobs.session",
    "NotebookInspector": "eyelab.apps.notebook",
    "builtin_scene": "eyelab.jobs.api",
}
__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        value = getattr(importlib.import_module(_API[name]), name)
        if name == "render":
            value = RenderFunction(value)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'eyelab' has no attribute {name!r}")


def __dir__():
    """The public API only (not this module's imports, nor the layers' packages)."""
    return sorted(__all__)


class RenderFunction:
    """``eyelab.render``: the function :func:`eyelab.jobs.api.render` when called, the GL
    package :mod:`eyelab.render` for attributes — so ``eyelab.render(spec)``, ``import
    eyelab.render.raster as m``, ``from eyelab.render import raster`` and
    ``mock.patch("eyelab.render.raster.X")`` all work under the one name."""

    def __init__(self, function):
        functools.update_wrapper(self, function)

    def __call__(self, *args, **kwargs):
        return self.__wrapped__(*args, **kwargs)

    def __get__(self, obj, objtype=None):
        # a (non-data) descriptor is a routine to inspect and pydoc: help(eyelab.render)
        # documents the function, with its signature (inspect follows __wrapped__)
        return self

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(importlib.import_module("eyelab.render"), name)

    def __repr__(self) -> str:
        return "<function eyelab.render (and the package eyelab.render)>"


class _Package(types.ModuleType):
    """``eyelab`` itself: importing the subpackage ``eyelab.render`` (the GL renderers)
    binds it as an attribute of the package, which would hide the function
    :func:`render`; the function stays and reaches the package's attributes
    (:class:`RenderFunction`)."""

    def __setattr__(self, name, value):
        if name in _API and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
