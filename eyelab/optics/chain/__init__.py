"""An eye behind a lens: the per-point chain of Kakimoto et al. 2007 (chief ray, wavefront
through the lens, the eye, the retinal blur), exact traces through lens and schematic eye to
the retina, and two eyes' vergence and prism. Imports :mod:`eyelab.optics.rays` and
:mod:`eyelab.optics.eye`; takes any lens with ``trace``/``placed_surfaces``."""
