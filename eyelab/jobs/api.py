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

    ``spec`` is any of: None (the built-in default, ``eyelab/data/default.toml``); a spec
    file's path (str or Path); a dict of its tables (``{"eye": {"rx": "-2.00 DS"}}``,
    read as a file of those tables: a table left out takes its defaults, and without
    ``"lens"`` there is no lens); a :class:`~eyelab.spec.Spec` (``eyelab.load_spec(path)``).
    ``overrides``: ``[render]`` keys, e.g. ``width=320, samples=8,
    renderer="reference", scene="chart", gaze_deg=(10, -20)``, checked as the file's
    are (a bad one raises :class:`~eyelab.core.errors.SpecError` naming it). ``session``: the
    :class:`~eyelab.jobs.session.Session` whose renderers and scenes to reuse (None: the
    default one); the report's ``cache.session`` says what was reused. Returns a
    :class:`~eyelab.imaging.contract.RenderResult` (one eye; ``.save(path)``, shown by
    Jupyter) or an :class:`~eyelab.imaging.stereo.BinocularResult` (two)."""
    return session_or_default(session).render(spec, no_lens=no_lens, **overrides)


def analyze(spec=None, *, no_lens: bool = False, session: Session | None = None) -> dict:
    """The lens designer's point analysis of the spec's ``[[points]]`` (``eyelab analyze``'s
    JSON report, as a dict)."""
    return session_or_default(session).analyze(spec, no_lens=no_lens)


def maps(spec=None, *, half_angle_deg: float = 30.0, n: int = 31, eye: str | None = None,
         session: Session | None = None):
    """As-worn maps of the spec's lens over an n x n grid of eye rotations (Fick angles
    about the centre of rotation) within ±half_angle_deg
    (:class:`~eyelab.optics.lens.asworn.AsWornMaps`); ``eye``: a two-eye spec's "right" or
    "left"."""
    return session_or_default(session).maps(spec, half_angle_deg=half_angle_deg, n=n,
                                            eye=eye)


def psf(spec=None, *, point: int = 0, no_lens: bool = False,
        pitch_arcmin: float = PITCH_ARCMIN, size: int = SIZE, eye: str | None = None,
        session: Session | None = None) -> tuple:
    """The eye's point-spread function at the spec's ``[[points]]`` entry ``point``, per
    colour channel, in wave optics (``eyelab psf``): (psf (3, size, size) float64, rows
    top to bottom as the wearer sees, each channel summing to the energy inside the
    square; report dict, its units first). ``pitch_arcmin``: arcmin per pixel (0.01-10),
    ``size``: pixels a side (odd, 3-1025); ``eye``: a two-eye spec's "right" or "left"
    (at the accommodation both share at the point). Any eye model: a schematic eye's PSF
    is of its wave at the retina by exact optical paths."""
    return session_or_default(session).psf(spec, point=point, no_lens=no_lens,
                                           pitch_arcmin=pitch_arcmin, size=size, eye=eye)


#: The built-in scenes' distance and contrast arguments and the spec key whose range they
#: take (:data:`eyelab.spec.scenekeys.SCENE_LIMITS`).
SCENE_ARGUMENTS = {"distance_m": "render.scene.distance_m", "near_m": "render.scene.distance_m",
                   "far_m": "render.scene.distance_m", "contrast": "render.scene.contrast"}


def builtin_scene(name: str = "room", **params):
    """A built-in scene by name (:data:`eyelab.scene.library.SCENE_NAMES`), with its
    parameters (e.g. ``builtin_scene("chart", distance_m=6.0)``); distances and contrast
    are checked against the spec's ranges (:data:`SCENE_ARGUMENTS`), naming the
    argument."""
    from eyelab.core.checks import check_argument, check_choice
    from eyelab.scene.library import SCENE_NAMES, SCENES
    from eyelab.spec.scenekeys import SCENE_LIMITS

    check_choice("name", name, SCENE_NAMES)
    for key, value in params.items():
        if key in SCENE_ARGUMENTS:
            check_argument(key, value, *SCENE_LIMITS[SCENE_ARGUMENTS[key]])
    return SCENES[name](**params)
