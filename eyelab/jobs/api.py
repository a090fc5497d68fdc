"""The functions of eyelab's public API (:mod:`eyelab`): from a spec — a TOML file's path,
a :class:`~eyelab.spec.Spec`, the spec's dict, or None for the built-in default — to an
image, a point analysis, as-worn maps or a point-spread function, with ``[render]`` keys
overridden by keyword.

Each function runs in a :class:`~eyelab.jobs.session.Session`: ``session=None`` (the
default) is the process's shared one (:func:`~eyelab.jobs.session.default_session`),
which keeps open renderers and built scenes between calls, so that rendering the same
spec again (or with another eye or lens) costs about a warm renderer's frame; pass your
own ``eyelab.Session()`` to hold them apart and close them when you are done.

>>> import eyelab
>>> eyelab.render(None, width=96, height=72, samples=2)       # doctest: +SKIP
<RenderResult 96x72 raster, 2 of 2 samples, 0.61 s>
"""

from __future__ import annotations

from eyelab.jobs.psf import PITCH_ARCMIN, SIZE
from eyelab.jobs.session import Session, as_spec, session_or_default, with_render

__all__ = ["analyze", "as_spec", "builtin_scene", "maps", "psf", "render", "with_render"]


def render(spec=None, *, no_lens: bool = False, session: Session | None = None,
           **overrides):
    """What the spec's eye sees (through its lens unless ``no_lens``), or both eyes' images
    for a two-eye spec.

    Parameters
    ----------
    spec : None, str, Path, dict or Spec
        None: the built-in default (``eyelab/data/default.toml``); a spec file's path
        (str or Path); a dict of its tables (``{"eye": {"rx": "-2.00 DS"}}``, read as a
        file of those tables: a table left out takes its defaults, and without ``"lens"``
        there is no lens); a :class:`~eyelab.spec.Spec` (``eyelab.load_spec(path)``).
    no_lens : bool
        Render the naked eye: the spec's lens left out.
    session : Session or None
        The :class:`~eyelab.jobs.session.Session` whose renderers and scenes to reuse
        (None: the default one); the report's ``cache.session`` says what was reused.
    **overrides
        ``[render]`` keys, e.g. ``width=320, samples=8, renderer="reference",
        scene="chart", gaze_deg=(10, -20)``, checked as the file's are (a bad one raises
        :class:`~eyelab.core.errors.SpecError` naming it).

    Returns
    -------
    RenderResult or BinocularResult
        One eye: a :class:`~eyelab.imaging.contract.RenderResult` (``.save(path)``, shown
        by Jupyter); two: a :class:`~eyelab.imaging.stereo.BinocularResult`.

    Examples
    --------
    The first spec of the repository's ``examples/`` (an acuity chart through a
    polycarbonate lens), small and with few samples:

    >>> import eyelab
    >>> result = eyelab.render("examples/first.toml", width=64, height=48, samples=2)
    >>> result.srgb.shape, result.report["renderer"]
    ((48, 64, 3), 'raster')

    A spec as a dict, without a lens: a -2.00 D myope's naked view of the chart:

    >>> naked = eyelab.render({"eye": {"rx": "-2.00 DS"}}, scene="chart", width=64,
    ...                       height=48, samples=2)
    >>> naked.report["view"]["width"], naked.report["view"]["height"]
    (64, 48)
    """
    return session_or_default(session).render(spec, no_lens=no_lens, **overrides)


def analyze(spec=None, *, no_lens: bool = False, session: Session | None = None) -> dict:
    """The lens designer's point analysis of the spec's ``[[points]]``: ``eyelab analyze``'s
    JSON report, as a dict.

    Per point (the report's ``points``, in the spec's order): the chief ray through the
    lens, the wave at the lens's exit, on the vertex sphere and at the eye, the prism, the
    power error against the prescription, the accommodation used, the retinal blur and
    the wave aberration over the pupil; the report's ``units`` names the units.
    ``no_lens``: the naked eye; ``session``: as for :func:`render`.

    Examples
    --------
    A -4.00 D eye wearing its single-vision lens, looking straight ahead and 30 degrees to
    the right (the eye turns about its centre of rotation, the default fixation): the
    power error (D) is zero on axis and small off it.

    >>> import eyelab
    >>> spec = {"eye": {"rx": "-4.00 DS"}, "lens": {"rx": "-4.00 DS"},
    ...         "points": [{"field_deg": [0, 0]}, {"field_deg": [30, 0]}]}
    >>> report = eyelab.analyze(spec)
    >>> [p["power_error"]["mean_d"] for p in report["points"]]
    [0.0, 0.027]
    """
    return session_or_default(session).analyze(spec, no_lens=no_lens)


def maps(spec=None, *, half_angle_deg: float = 30.0, n: int = 31, eye: str | None = None,
         session: Session | None = None):
    """As-worn maps of the spec's lens over an n x n grid of eye rotations.

    The rotations are Fick angles about the eye's centre of rotation, from
    ``-half_angle_deg`` to ``half_angle_deg`` degrees right and up; ``eye``: a two-eye
    spec's "right" or "left"; ``session``: as for :func:`render`. Returns an
    :class:`~eyelab.optics.lens.asworn.AsWornMaps`: the mean power error, cylinder, axis,
    prism and the other maps as (n, n) arrays, rows from down to up, columns from the
    wearer's left to right.

    Examples
    --------
    >>> import eyelab
    >>> m = eyelab.maps({"eye": {"rx": "-4.00 DS"}, "lens": {"rx": "-4.00 DS"}},
    ...                 half_angle_deg=20, n=3)
    >>> m.eye_rotation_x_deg.tolist(), m.mean_error_d.shape
    ([-20.0, 0.0, 20.0], (3, 3))
    >>> round(float(m.mean_error_d.max()), 2), round(float(m.cylinder_d.min()), 2)
    (0.09, -0.1)
    """
    return session_or_default(session).maps(spec, half_angle_deg=half_angle_deg, n=n,
                                            eye=eye)


def psf(spec=None, *, point: int = 0, no_lens: bool = False,
        pitch_arcmin: float = PITCH_ARCMIN, size: int = SIZE, eye: str | None = None,
        session: Session | None = None) -> tuple:
    """The eye's point-spread function at the spec's ``[[points]]`` entry ``point``, per
    colour channel, in wave optics (``eyelab psf``).

    Returns (psf, report): psf a (3, size, size) float64 array, R, G, B, rows top to bottom
    as the wearer sees, each channel summing to the energy inside the square; report a
    dict, its units first. ``pitch_arcmin``: arcmin per pixel (0.01-10); ``size``: pixels
    a side (odd, 3-1025); ``no_lens``: the naked eye; ``eye``: a two-eye spec's "right" or
    "left" (at the accommodation both share at the point); ``session``: as for
    :func:`render`. Any eye model: a schematic eye's PSF is of its wave at the retina by
    exact optical paths.

    Examples
    --------
    >>> import eyelab
    >>> image, report = eyelab.psf({"eye": {"rx": "-2.00 DS"}, "lens": {"rx": "-2.00 DS"}},
    ...                            size=33)
    >>> image.shape, report["pitch_arcmin"]
    ((3, 33, 33), 0.25)
    >>> [channel["wavelength_nm"] for channel in report["channels"]]
    [656.27, 546.07, 486.13]
    """
    return session_or_default(session).psf(spec, point=point, no_lens=no_lens,
                                           pitch_arcmin=pitch_arcmin, size=size, eye=eye)


#: The built-in scenes' distance and contrast arguments and the spec key whose range they
#: take (:data:`eyelab.spec.scenekeys.SCENE_LIMITS`).
SCENE_ARGUMENTS = {"distance_m": "render.scene.distance_m", "near_m": "render.scene.distance_m",
                   "far_m": "render.scene.distance_m", "contrast": "render.scene.contrast"}


def builtin_scene(name: str = "room", **params):
    """A built-in scene by name (:data:`eyelab.scene.library.SCENE_NAMES`), with its
    parameters.

    E.g. ``builtin_scene("chart", distance_m=6.0)``; distances and contrast are checked
    against the spec's ranges (:data:`SCENE_ARGUMENTS`), an error naming the argument.
    Returns a :class:`~eyelab.scene.scene.Scene`, for a renderer made with
    :func:`~eyelab.imaging.registry.make_renderer`.

    Examples
    --------
    >>> import eyelab
    >>> chart = eyelab.builtin_scene("chart", distance_m=6.0)
    >>> chart.name, chart.n_triangles
    ('chart_6m', 268)
    >>> eyelab.builtin_scene("chart", distance_m=0.01)
    Traceback (most recent call last):
    ...
    eyelab.core.errors.SpecError: distance_m: must be in [0.1, 100], got 0.01
    """
    from eyelab.core.checks import check_argument, check_choice
    from eyelab.scene.library import SCENE_NAMES, SCENES
    from eyelab.spec.scenekeys import SCENE_LIMITS

    check_choice("name", name, SCENE_NAMES)
    for key, value in params.items():
        if key in SCENE_ARGUMENTS:
            check_argument(key, value, *SCENE_LIMITS[SCENE_ARGUMENTS[key]])
    return SCENES[name](**params)
