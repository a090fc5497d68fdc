"""The bottom layer (stdlib + numpy): errors and checks, tolerances, vector maths, caches,
thread pools, progress bars, atomic file writing and the image/JSON writers, colour
(sRGB, colour-vision deficiency) and sample sets."""
