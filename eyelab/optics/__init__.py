"""The optics engine: pure numpy, no display, no VTK.

Prescriptions -> eye model and lens design -> surfaces -> exact rays and wavefronts ->
chief-ray paths -> retinal blur (Kakimoto et al. 2007, §3-4).
"""

from eyelab.optics.chain.analysis import PointAnalysis, analyze_points, trace_chain
from eyelab.optics.eye.prescription import Prescription, vertex_effective_power
from eyelab.optics.eye.thin import Eye, ReducedEye, hofstetter_amplitude, watson_yellott_pupil
from eyelab.optics.lens.spectacle import LensPose, SpectacleLens
from eyelab.optics.rays.materials import CATALOGUE, Material, get_material
from eyelab.optics.rays.paths import ChiefRays, ObjectPoints, find_chief_rays
from eyelab.optics.rays.surfaces import Asphere, Plane, Sphere, Toric
from eyelab.optics.rays.trace import Status
from eyelab.optics.rays.wavefront import Wavefront

__all__ = [
    "CATALOGUE", "Asphere", "ChiefRays", "Eye", "LensPose", "Material", "ObjectPoints",
    "Plane", "PointAnalysis", "Prescription", "ReducedEye", "SpectacleLens", "Sphere",
    "Status", "Toric", "Wavefront", "analyze_points", "find_chief_rays", "get_material",
    "hofstetter_amplitude", "trace_chain", "vertex_effective_power", "watson_yellott_pupil",
]
