"""eyelab: what a person sees through spectacle lenses.

The optics engine (:mod:`eyelab.optics`) is pure numpy and needs no display.
"""

from eyelab.core.errors import SpecError

__all__ = ["SpecError", "__version__"]
__version__ = "0.1.0"
