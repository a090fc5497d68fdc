"""The reference renderer (distribution ray tracing on embree) and image metrics. No VTK."""

from eyelab.reference.metrics import compare_images
from eyelab.reference.tracer import ReferenceRenderer, ReferenceSettings

__all__ = ["ReferenceRenderer", "ReferenceSettings", "compare_images"]
