"""Spectacle lenses: the lens and its pose (:mod:`~eyelab.optics.lens.spectacle`),
progressive designs and their as-worn optimisation, as-worn maps and figures of merit,
frames, DCS records and surface points files, and the maps kept on disk. The top of the
optics layer."""
