"""Camera lens systems (a sequence of real surfaces, a stop and a film) and the rays from
their film, for renders through a camera instead of an eye. Imports only
:mod:`eyelab.optics.rays`."""
