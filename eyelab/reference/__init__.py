"""The reference renderer (distribution ray tracing on embree) and image metrics. No VTK."""

from eyelab.imaging.options import ReferenceQuality
from eyelab.reference.metrics import compare_images
from eyelab.reference.tracer import ReferenceRenderer

__all__ = ["ReferenceQuality", "ReferenceRenderer", "compare_images"]
