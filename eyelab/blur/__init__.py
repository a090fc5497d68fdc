"""Blur fields (Kakimoto et al. 2007, §4): precomputed defocus volumes over a view."""

from eyelab.blur.field import BlurField, VoxelStatus
from eyelab.blur.wavefront import compute_blur_field

__all__ = ["BlurField", "VoxelStatus", "compute_blur_field"]
