"""The renderers by name: each name's quality options, where its implementation lives and
whether it can look through a camera lens system instead of an eye.

The one table every other place derives from (the spec's ``render.renderer`` choices and
keys, the command line's ``--renderer``, :func:`make_renderer`). Implementations are
imported on first use, so that validating a spec or importing :mod:`eyelab` loads no VTK
and no embree.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, fields

from eyelab.core.checks import check_choice
from eyelab.imaging.options import ImageBasedQuality, RasterQuality, ReferenceQuality


@dataclass(frozen=True)
class RendererEntry:
    """One renderer: ``name`` (``render.renderer``), its options class ``quality``, its
    implementation ``"module:Class"``, whether it renders camera lens systems and whether
    it renders a schematic eye's retinal image (if not, ``thin_eye_why``: the physical
    reason). Every renderer draws a lenslet lens's simultaneous images
    (:mod:`eyelab.optics.lens.lenslets`)."""

    name: str
    quality: type
    implementation: str
    sees_cameras: bool
    sees_schematic_eyes: bool = False
    thin_eye_why: str = ""

    def load(self) -> type:
        """The renderer class (imports its module)."""
        module, _, cls = self.implementation.partition(":")
        return getattr(importlib.import_module(module), cls)


REGISTRY = {e.name: e for e in (
    RendererEntry("raster", RasterQuality, "eyelab.render.raster:RasterRenderer", False,
                  sees_schematic_eyes=True),
    RendererEntry("reference", ReferenceQuality, "eyelab.reference.tracer:ReferenceRenderer",
                  True, sees_schematic_eyes=True),
    RendererEntry("imagebased", ImageBasedQuality,
                  "eyelab.render.imagebased:ImageBasedRenderer", True,
                  sees_schematic_eyes=True),
)}
#: Renderer names, the default first, which ``[render] renderer`` and
#: :func:`make_renderer` take. "raster": the real-time renderer (Kakimoto et al. 2007, on
#: VTK); "reference": per-pixel distribution ray tracing; "imagebased": the image-based
#: lens model of Heidrich, Slusallek & Seidel (1997).
#:
#: Examples
#: --------
#: >>> import eyelab
#: >>> eyelab.RENDERERS
#: ('raster', 'reference', 'imagebased')
RENDERERS = tuple(REGISTRY)
#: Options class of each renderer.
QUALITIES = {name: e.quality for name, e in REGISTRY.items()}
#: Renderers that can look through a camera lens system instead of the eye.
CAMERA_RENDERERS = tuple(name for name, e in REGISTRY.items() if e.sees_cameras)
#: Renderers that render a schematic eye's retinal image at fixation.
SCHEMATIC_RENDERERS = tuple(name for name, e in REGISTRY.items() if e.sees_schematic_eyes)


def quality_keys(renderer: str) -> tuple:
    """The option names (spec keys) of a renderer's quality class."""
    return tuple(f.name for f in fields(QUALITIES[renderer]))


def make_renderer(name: str, quality=None, **options):
    """A new renderer by name (one of :data:`RENDERERS`) with its quality options: an
    options object, or the options by keyword (``make_renderer("raster", samples=16)``),
    or neither (the defaults). Use it as a context manager, or :meth:`close` it, to
    release its GL contexts and caches.

    The renderer draws what an eye sees of a scene through a lens:
    ``renderer.render(scene, eye, lens, view)`` (lens None: the naked eye) returns a
    :class:`~eyelab.imaging.contract.RenderResult`. :func:`eyelab.render` does this for a
    spec; a renderer of your own renders the scenes, eyes and lenses you build in Python.

    Examples
    --------
    >>> import eyelab
    >>> scene = eyelab.builtin_scene("chart")
    >>> eye = eyelab.Eye.from_rx("-2.00 DS")
    >>> lens = eyelab.SpectacleLens.from_rx(eyelab.Prescription.parse("-2.00 DS"))
    >>> view = eyelab.View(width=64, height=48, fov_y_deg=8.0)
    >>> with eyelab.make_renderer("raster", samples=2) as renderer:
    ...     result = renderer.render(scene, eye, lens, view)
    >>> result.shape, result.report["renderer"], result.report["samples"]["target"]
    ((48, 64, 3), 'raster', 2)
    """
    check_choice("render.renderer", name, RENDERERS)
    if options:
        if quality is not None:
            raise TypeError("give quality or its options by keyword, not both")
        quality = QUALITIES[name](**options)
    return REGISTRY[name].load()(quality)
