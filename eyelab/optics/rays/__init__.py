"""Rays and wavefronts: surfaces (conicoids, torics, aspheres, free forms), exact ray
intersection and Snell refraction, wavefront (curvature) tracing, ray transfer matrices,
optical materials and their dispersion, Fresnel transmission, chief-ray path finding through
a lens, and the pinhole cameras the renderers look through. The bottom of the optics layer:
it imports nothing else of :mod:`eyelab.optics`."""
