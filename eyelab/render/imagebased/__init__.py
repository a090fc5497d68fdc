"""The image-based lens model of Heidrich, Slusallek & Seidel (1997): ray makers
(:mod:`.rays`), the COP fit (:mod:`.cop`), the projection plan (:mod:`.plan`), the morph
(:mod:`.morph`) and the GL renderer (:mod:`.renderer`)."""

from eyelab.render.imagebased.renderer import ImageBasedRenderer

__all__ = ["ImageBasedRenderer"]
