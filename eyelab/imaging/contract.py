"""What every renderer takes and returns: the :class:`View`, the :class:`RenderResult`, the
report schema and the :class:`Renderer` base class.

One call shape for every renderer (the raster renderer of Kakimoto et al. 2007, the
reference distribution ray tracer, and those to come)::

    result = renderer.render(scene, eye, lens, view, quality)

``scene`` an :class:`eyelab.scene.Scene`; ``eye`` an :class:`eyelab.optics.eye.thin.Eye`;
``lens`` a :class:`eyelab.optics.lens.spectacle.SpectacleLens` or None (the naked eye); ``view`` a
:class:`View` (what is looked at and how the eye focuses); ``quality`` the renderer's own
options (a small frozen dataclass, validated with the spec field's name in every error),
or None for the options the renderer was made with.

Pure numpy: no VTK here.
"""

from __future__ import annotations

import abc
import dataclasses
import time
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from eyelab.core.checks import check_choice, check_in
from eyelab.core.color import CVD_KINDS, cvd_linear, decode_srgb, encode_srgb
from eyelab.core.errors import SpecError
from eyelab.imaging.memory import check_render_memory
from eyelab.optics.cameralens.system import LensSystem
from eyelab.optics.chain.binocular import MAX_GAZE_DEG
from eyelab.optics.eye.thin import EYE_REFERENCE_NM, MAX_ACCOMMODATION_D, Eye
from eyelab.optics.rays.camera import Camera, eye_camera, gaze_camera
from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM

#: Top-level keys of every renderer's report, in this order.
REPORT_KEYS = ("renderer", "view", "quality", "samples", "skipped", "warnings", "timings_s",
               "cache", "details")


@dataclass(frozen=True)
class View:
    """What the eye looks at and how it focuses; the same for every renderer.

    In primary gaze the eye's pupil centre is the origin and it looks along -z (eyelab's
    world frame).

    In a spec these are ``[render]`` keys (``near_m``, ``far_m`` for near, far) and
    ``eye.accommodation_d`` (focus_d); a bad value raises
    :class:`~eyelab.core.errors.SpecError` naming that key. :meth:`replace` gives a
    changed copy.

    Parameters
    ----------
    width, height : int
        Image size, pixels (16-4096).
    fov_y_deg : float
        Vertical field of view, deg (1-150).
    near, far : float
        Clipping depths from the pupil, m (near 0.001-10, far up to 1e5 and > near; scene
        content outside is not drawn).
    focus_d : float or None
        None (each point gets the eye's best accommodation for it, Kakimoto Eq. 13) or a
        fixed accommodation in D (0-25, clamped to the eye's amplitude).
    cvd : str or None
        Colour-vision deficiency of the observer (Machado 2009): None, "protan",
        "deutan", "tritan" or "achromat", applied in linear RGB.
    cvd_severity : float
        Its severity, 0-1.
    gaze_deg : (right, up)
        Degrees (each within +-60): the eye turns about its centre of rotation behind the
        head-fixed lens (:func:`eyelab.optics.rays.camera.gaze_camera`), as ``eyelab
        analyze --fixation rotating`` turns it toward each point.

    Examples
    --------
    >>> import eyelab
    >>> view = eyelab.View(width=64, height=48, fov_y_deg=8.0, gaze_deg=(10, -20))
    >>> view.shape, view.gaze_deg
    ((48, 64), (10.0, -20.0))
    >>> view.replace(cvd="deutan").cvd
    'deutan'
    >>> eyelab.View(width=0)
    Traceback (most recent call last):
    ...
    eyelab.core.errors.SpecError: render.width: must be an integer in [16, 4096], got 0
    """

    width: int = 640
    height: int = 480
    fov_y_deg: float = 60.0
    near: float = 0.05
    far: float = 100.0
    focus_d: float | None = None
    cvd: str | None = None
    cvd_severity: float = 1.0
    gaze_deg: tuple = (0.0, 0.0)

    #: Ranges of the view's values, by spec field (the schema documents them from here).
    LIMITS: ClassVar[dict] = {"render.width": (16, 4096), "render.height": (16, 4096),
                              "render.fov_y_deg": (1, 150), "render.near_m": (1e-3, 10),
                              "render.far_m": (1e-3, 1e5),
                              "eye.accommodation_d": (0, MAX_ACCOMMODATION_D),
                              "render.cvd_severity": (0, 1),
                              "render.gaze_deg": (-MAX_GAZE_DEG, MAX_GAZE_DEG)}

    def __post_init__(self):
        lim = self.LIMITS
        check_in("render.width", self.width, lim, integer=True)
        check_in("render.height", self.height, lim, integer=True)
        check_in("render.fov_y_deg", self.fov_y_deg, lim)
        check_in("render.near_m", self.near, lim)
        check_in("render.far_m", self.far, lim)
        if not self.far > self.near:
            raise SpecError("render.far_m", f"must be > near_m ({self.near}), got {self.far}")
        if self.focus_d is not None:      # the eye's accommodation (spec: eye.accommodation_d)
            check_in("eye.accommodation_d", self.focus_d, lim)
        if self.cvd is not None:
            check_choice("render.cvd", self.cvd, CVD_KINDS)
        check_in("render.cvd_severity", self.cvd_severity, lim)
        g = self.gaze_deg
        if not (isinstance(g, (tuple, list)) and len(g) == 2):
            raise SpecError("render.gaze_deg", f"must be [right, up] in degrees, got {g!r}")
        for i, v in enumerate(g):
            if isinstance(v, bool):
                raise SpecError(f"render.gaze_deg[{i}]", f"must be a number, got {v!r}")
            check_in(f"render.gaze_deg[{i}]", v, lim)
        object.__setattr__(self, "gaze_deg", (float(g[0]), float(g[1])))
        aspect = self.width / self.height
        if not 0.05 <= aspect <= 20:
            raise SpecError("render.width", f"width / height must be in [0.05, 20], got "
                                            f"{self.width} / {self.height}")

    @property
    def shape(self) -> tuple:
        """(height, width) of the image."""
        return self.height, self.width

    def pixel_ndc(self) -> np.ndarray:
        """(n, 2) NDC of the pixel centres, row by row from the top."""
        x = -1.0 + (2 * np.arange(self.width) + 1.0) / self.width
        y = 1.0 - (2 * np.arange(self.height) + 1.0) / self.height
        gx, gy = np.meshgrid(x, y)
        return np.column_stack([gx.ravel(), gy.ravel()])

    def camera(self, rotation_centre: float = 0.0135) -> Camera:
        """The eye camera: centre of projection at the pupil centre, looking along the line
        of sight (along -z in primary gaze; turned about the eye's centre of rotation,
        ``rotation_centre`` m behind the pupil, for a gaze)."""
        if self.gaze_deg == (0.0, 0.0):
            return eye_camera(self.fov_y_deg, self.width / self.height, self.near, self.far)
        return gaze_camera(self.gaze_deg, rotation_centre, self.fov_y_deg,
                           self.width / self.height, self.near, self.far)

    def replace(self, **changes) -> View:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """The view for a report, its lengths named with their unit (the spec's keys)."""
        d = dataclasses.asdict(self)
        d["near_m"], d["far_m"] = d.pop("near"), d.pop("far")
        return d


class RenderResult:
    """A rendered image and how it was made.

    :func:`eyelab.render` and the renderers return one; :meth:`save` writes it, and
    Jupyter shows it as its image. A renderer gives ``linear`` or ``srgb`` (or both); the
    other is derived on first use (exactly: every uint8 code decodes and re-encodes to
    itself), so a frame pays for the conversion only when someone reads it.

    Parameters
    ----------
    report : dict
        The keys :data:`REPORT_KEYS` (same schema for every renderer).
    linear : (h, w, 3) float32
        Linear values (relative; 1 = white), row 0 at the top.
    srgb : (h, w, 3) uint8
        The sRGB encoding of ``linear`` (what a PNG holds).
    layers : dict
        Optional (h, w[, 3]) arrays by name: "lens_mask" (bool: seen through the lens),
        "naked" / "environment" (uint8 intermediate images of the raster renderer).
    progressive : list
        [(samples done, srgb image)] when asked for.

    Examples
    --------
    >>> import os
    >>> import tempfile
    >>> import eyelab
    >>> result = eyelab.render(None, width=64, height=48, samples=2)
    >>> result.shape, result.linear.dtype.name, result.srgb.dtype.name
    ((48, 64, 3), 'float32', 'uint8')
    >>> list(result.report)[:4]
    ['renderer', 'view', 'quality', 'samples']
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     result.save(os.path.join(folder, "view.png"),
    ...                 report=os.path.join(folder, "view.json"))
    ...     sorted(os.listdir(folder))
    ['view.json', 'view.png']
    """

    def __init__(self, report: dict, *, linear=None, srgb=None, layers=None,
                 progressive=None):
        if linear is None and srgb is None:
            raise ValueError("a RenderResult needs linear or srgb")
        self._linear = None if linear is None else np.asarray(linear, np.float32)
        self._srgb = srgb
        self.report = report
        self.layers = dict(layers or {})
        self.progressive = list(progressive or [])

    @property
    def linear(self) -> np.ndarray:
        if self._linear is None:
            self._linear = decode_srgb(self._srgb)
        return self._linear

    @property
    def srgb(self) -> np.ndarray:
        if self._srgb is None:
            self._srgb = encode_srgb(self._linear)
        return self._srgb

    @property
    def image(self) -> np.ndarray:
        """The sRGB image (alias of :attr:`srgb`)."""
        return self.srgb

    @property
    def shape(self) -> tuple:
        return (self._srgb if self._srgb is not None else self._linear).shape

    def __repr__(self) -> str:
        r = self.report
        h, w = self.shape[:2]
        done = r.get("samples", {}).get("done_passes")
        target = r.get("samples", {}).get("target")
        samples = (f", {done} of {target} samples" if done is not None and target
                   else f", {target} samples" if target else "")
        total = r.get("timings_s", {}).get("total")
        took = f", {total:.2f} s" if total is not None else ""
        notes = len(r.get("warnings", []))
        warn = f", {notes} warning{'s' * (notes != 1)}" if notes else ""
        return f"<RenderResult {w}x{h} {r.get('renderer', '?')}{samples}{took}{warn}>"

    def _repr_png_(self) -> bytes:
        """The image as PNG bytes: how Jupyter shows a result."""
        from eyelab.core.fileio import png_bytes

        return png_bytes(self.srgb)

    def save(self, path, *, report=None, linear: bool = False) -> None:
        """Write the image to ``path`` (PNG: 8-bit sRGB, or with ``linear`` 16-bit linear
        light) and, with ``report`` (a path), the render report as JSON — written whole or
        not at all, both renamed into place together."""
        from eyelab.core.fileio import atomic_group, linear_to_png16, png_writer, report_writer

        image = linear_to_png16(self.linear) if linear else self.srgb
        writers = {path: png_writer(image)}
        if report is not None:
            writers[report] = report_writer(self.report)
        atomic_group(writers)


def new_report(renderer: str, view: View, quality) -> dict:
    """An empty report of the common schema (see :data:`REPORT_KEYS`)."""
    return {"renderer": renderer, "view": view.to_dict(),
            "quality": dataclasses.asdict(quality), "samples": {"target": 0, "done": {}},
            "skipped": [], "warnings": [], "timings_s": {},
            "cache": {"hits": [], "misses": []},
            "details": {}}


def observe(view: View, *, linear=None, srgb=None):
    """(linear, srgb) as the view's observer sees them: the colour-vision deficiency applied
    in linear RGB (Machado 2009) when the view has one, else the inputs unchanged (either
    may be None; :class:`RenderResult` derives the missing one)."""
    if view.cvd is None:
        return linear, srgb
    lin = decode_srgb(srgb) if linear is None else np.asarray(linear, np.float32)
    return cvd_linear(lin, view.cvd, view.cvd_severity).astype(np.float32), None


def finish(report: dict, view: View, *, linear=None, srgb=None, layers=None,
           progressive=None, t_start: float | None = None) -> RenderResult:
    """The :class:`RenderResult`: :func:`observe` applied, the report's CVD entry and total
    time filled in; ``progressive`` images [(samples, srgb)] get the same observer."""
    linear, srgb = observe(view, linear=linear, srgb=srgb)
    if view.cvd is not None:
        report["details"]["cvd"] = {"kind": view.cvd, "severity": view.cvd_severity,
                                    "model": "Machado 2009, linear RGB"}
        progressive = [(k, encode_srgb(observe(view, srgb=im)[0]))
                       for k, im in progressive or []]
    if t_start is not None:
        report["timings_s"]["total"] = time.perf_counter() - t_start
    return RenderResult(report, linear=linear, srgb=srgb, layers=layers,
                        progressive=progressive)


class Renderer(abc.ABC):
    """Base class of eyelab's renderers: ``render(scene, eye, lens, view, quality)``.

    Subclasses set :attr:`name` and :attr:`Quality` (their options dataclass) and implement
    :meth:`_render`. A renderer may keep caches and GL contexts between calls (reuse one
    for many frames); :meth:`close` releases them, and so does leaving a ``with`` block.
    """

    name: str = "renderer"
    Quality: type = type(None)
    #: Whether the renderer bends its pupil rays by the eye's higher-order aberrations
    #: itself (then only the diffraction kernel is applied: :mod:`eyelab.imaging.eyepsf`).
    traces_eye_aberrations: bool = False

    def __init__(self, quality=None):
        self.quality = self.Quality() if quality is None else quality
        if not isinstance(self.quality, self.Quality):
            raise TypeError(f"{type(self).__name__} takes a {self.Quality.__name__}, got "
                            f"{type(self.quality).__name__}")

    def render(self, scene, eye, lens=None, view: View | None = None, quality=None, *,
               progressive: bool = False) -> RenderResult:
        """Render what ``eye`` sees of ``scene`` through ``lens`` (None: naked eye); the observer
        may instead be a camera lens (a :class:`~eyelab.optics.cameralens.system.LensSystem`, no
        spectacle lens), dispatched here to :meth:`_render_camera`. ``progressive``: also return the
        images after 1, 2, 4, ... samples (renderers that
        refine in passes; others return the final image only)."""
        view, quality = self._checked(view, quality, scene)
        if isinstance(eye, LensSystem):     # the observer is a camera lens, not an eye
            if lens is not None:
                raise SpecError("lens", "a camera lens system takes no spectacle lens")
            from eyelab.imaging.registry import CAMERA_RENDERERS

            if self.name not in CAMERA_RENDERERS:
                raise SpecError("render.camera", f"a camera lens renders with "
                                f"{' or '.join(map(repr, CAMERA_RENDERERS))}, not {self.name!r}")
            return self._render_camera(scene, eye, view, quality, progressive)
        if not isinstance(eye, Eye):            # a schematic eye: its retinal image
            from eyelab.imaging.registry import REGISTRY, SCHEMATIC_RENDERERS

            if self.name not in SCHEMATIC_RENDERERS:
                why = REGISTRY[self.name].thin_eye_why
                raise SpecError("eye.model", f"the {eye.model} eye's retinal image renders "
                                f"with {' or '.join(map(repr, SCHEMATIC_RENDERERS))}, not "
                                f"{self.name!r}" + (f": {why}" if why else ""))
            return self._render_schematic(scene, eye, lens, view, quality, progressive)
        if getattr(eye, "aberrations", None) is not None:     # eyelab/imaging/eyepsf.py
            from eyelab.imaging.eyepsf import render_aberrated

            return render_aberrated(self, scene, eye, lens, view, quality, progressive)
        return self._render(scene, eye, lens, view, quality, progressive)

    def _render_schematic(self, scene, eye, lens, view: View, quality, progressive: bool
                          ) -> RenderResult:
        """The retinal image of a schematic eye fixating along the view's line of sight
        with one accommodation (the view's ``focus_d``, else the fixation's:
        :func:`~eyelab.imaging.retinal.view_accommodation`); renderers registered as seeing
        schematic eyes draw it with their eye-side machinery, whose blur fields take the
        schematic eye's optics (:mod:`eyelab.blur.schematic`) and whose camera is
        :func:`eye_view_camera`."""
        from eyelab.imaging.retinal import fixation_view

        fixed = fixation_view(scene, eye, lens, view)
        acc = fixed.focus_d
        result = self._render(scene, eye, lens, fixed, quality, progressive)
        result.report["details"]["schematic_eye"] = {
            "model": eye.model, "accommodation_d": acc,
            "fixation": "fixed (the view's line of sight)"}
        return result

    def _render_camera(self, scene, camera, view: View, quality, progressive: bool
                       ) -> RenderResult:
        """What a camera lens system (:class:`~eyelab.optics.cameralens.system.LensSystem`)
        sees; for the renderers registered as seeing cameras."""
        raise NotImplementedError(f"{type(self).__name__} renders eyes only")

    def _checked(self, view, quality, scene=None) -> tuple:
        """(view, quality) with the defaults filled in and their types checked, and the
        render's memory estimate (with ``scene``'s triangles and textures) within the
        limit."""
        view = View() if view is None else view
        quality = self.quality if quality is None else quality
        if not isinstance(view, View):
            raise TypeError(f"view must be a View, got {type(view).__name__}")
        if not isinstance(quality, self.Quality):
            raise TypeError(f"{type(self).__name__} takes a {self.Quality.__name__}, got "
                            f"{type(quality).__name__}")
        # refused before any work when its estimated memory is over the limit
        check_render_memory(self.name, view, quality, scene=scene)
        return view, quality

    @abc.abstractmethod
    def _render(self, scene, eye, lens, view: View, quality, progressive: bool
                ) -> RenderResult:
        """The renderer's work; see :meth:`render`."""

    def close(self) -> None:  # noqa: B027 (nothing to release by default)
        """Release caches and contexts (the renderer can still be used: they are rebuilt)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def eye_view_camera(view: View, eye) -> Camera:
    """The camera an eye sees the view with: the thin eye's from its pupil at the corneal
    vertex (:meth:`View.camera`); a schematic eye's from the centre of its entrance pupil,
    where its lines of sight cross (the same gaze and field)."""
    cam = view.camera(eye.rotation_centre)
    if isinstance(eye, Eye):
        return cam
    z_ep, _ = eye.entrance_pupil(0.0)
    pos = np.asarray(cam.position, float) - z_ep * np.asarray(cam.forward, float)
    return dataclasses.replace(cam, position=tuple(float(v) for v in pos))


def channel_wavelengths(eye, lens, chromatic: bool, report=None) -> tuple:
    """The wavelengths (nm) a render traces: R/G/B's design wavelengths when ``chromatic``
    and either the eye's own chromatic aberration or the lens's dispersion makes the
    channels differ; else the eye's reference wavelength alone (said in ``report``, if
    given)."""
    lens_disperses = lens is not None and lens.material.dispersive
    if chromatic and (eye.chromatic or lens_disperses):
        return RGB_WAVELENGTHS_NM
    why = ("disabled" if not chromatic else
           "neither the eye (eye.chromatic = false) nor the lens material disperses")
    if report is not None:
        report["skipped"].append(f"chromatic: {why}: one wavelength")
    return (EYE_REFERENCE_NM,)
