"""Two eyes' images: both eyes rendered with one accommodative response and composed in
linear light — side by side (parallel or crossed free viewing) or as a red/cyan anaglyph
by Dubois's least-squares projection (E. Dubois, ICASSP 2001; the red/cyan matrices of
his 2009 note). The optics of two eyes (vergence, consensual accommodation, induced
prism) are :mod:`eyelab.optics.chain.binocular`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eyelab.core.color import encode_srgb
from eyelab.core.errors import SpecError
from eyelab.optics.chain.binocular import (
    SIDES,
    Binocular,
    analyze_binocular,
    fixation_blur_arcmin,
    prism_rows,
)
from eyelab.optics.eye.thin import EYE_REFERENCE_NM

#: Binocular images: both side by side for parallel or crossed free viewing, a red/cyan
#: anaglyph (red filter over the left eye), or one eye alone.
OUTPUTS = ("side-by-side", "crossed", "anaglyph", "right", "left")


#: Dubois red/cyan anaglyph matrices (linear RGB in -> linear RGB out), left and right.
DUBOIS_LEFT = np.array([[0.437, 0.449, 0.164],
                        [-0.062, -0.062, -0.024],
                        [-0.048, -0.050, -0.017]])


DUBOIS_RIGHT = np.array([[-0.011, -0.032, -0.007],
                         [0.377, 0.761, 0.009],
                         [-0.026, -0.093, 1.234]])


# ---------------------------------------------------------------------- rendering
@dataclass(repr=False)
class BinocularResult:
    """Both eyes' :class:`~eyelab.imaging.contract.RenderResult` and the composed image.

    right, left : RenderResult; report : {"binocular": {...}, "right": ..., "left": ...}.
    Jupyter shows the spec's output (:attr:`output`: side by side unless the spec says
    otherwise); ``srgb(output)`` / ``linear(output)`` give any other.
    """

    right: object
    left: object
    report: dict

    @property
    def output(self) -> str:
        """The spec's ``binocular.output`` (:data:`OUTPUTS`)."""
        return self.report.get("binocular", {}).get("output", "side-by-side")

    def _repr_png_(self) -> bytes:
        """The :attr:`output` image as PNG bytes: how Jupyter shows a two-eye result."""
        from eyelab.core.fileio import png_bytes

        return png_bytes(self.srgb(self.output))

    def __repr__(self) -> str:
        h, w = self.right.srgb.shape[:2]
        return (f"<BinocularResult {self.output}: two eyes, {w}x{h} px each; .right, .left, "
                f".srgb(output), .report>")

    def linear(self, output: str) -> np.ndarray:
        """(h, w', 3) float32 linear image for ``output`` (:data:`OUTPUTS`)."""
        return compose(self.right.linear, self.left.linear, output)

    def srgb(self, output: str) -> np.ndarray:
        """(h, w', 3) uint8 sRGB image for ``output``."""
        if output in SIDES:
            return (self.right if output == "right" else self.left).srgb
        return encode_srgb(self.linear(output))

    def save(self, path, *, report=None, linear: bool = False, output: str | None = None
             ) -> None:
        """Write the ``output`` image (:data:`OUTPUTS`; None: :attr:`output`) to ``path``
        (PNG: 8-bit sRGB, or with ``linear`` 16-bit linear light) and, with ``report`` (a
        path), both eyes' report as JSON — as :meth:`RenderResult.save
        <eyelab.imaging.contract.RenderResult.save>`: whole or not at all."""
        from eyelab.core.fileio import atomic_group, linear_to_png16, png_writer, report_writer

        output = self.output if output is None else output       # checked by compose()
        image = linear_to_png16(self.linear(output)) if linear else self.srgb(output)
        writers = {path: png_writer(image)}
        if report is not None:
            writers[report] = report_writer(self.report)
        atomic_group(writers)


def compose(right: np.ndarray, left: np.ndarray, output: str) -> np.ndarray:
    """Two (h, w, 3) linear images -> the ``output`` image, linear: "side-by-side" (left
    eye's image on the left: parallel viewing), "crossed" (right eye's on the left),
    "anaglyph" (Dubois red/cyan, clipped to [0, 1]), or one eye."""
    if output not in OUTPUTS:
        raise SpecError("binocular.output", f"must be one of {', '.join(map(repr, OUTPUTS))},"
                                            f" got {output!r}")
    right = np.asarray(right, np.float32)
    left = np.asarray(left, np.float32)
    if output == "right":
        return right
    if output == "left":
        return left
    if output == "side-by-side":
        return np.concatenate([left, right], axis=1)
    if output == "crossed":
        return np.concatenate([right, left], axis=1)
    return anaglyph(right, left)


def anaglyph(right: np.ndarray, left: np.ndarray) -> np.ndarray:
    """Dubois red/cyan anaglyph (linear RGB (h, w, 3) each -> (h, w, 3) in [0, 1]); the
    red filter goes over the left eye."""
    out = np.asarray(left, float) @ DUBOIS_LEFT.T + np.asarray(right, float) @ DUBOIS_RIGHT.T
    return np.clip(out, 0.0, 1.0).astype(np.float32)


@dataclass
class BinocularPose:
    """Both eyes posed for one cyclopean view: the wearer (lenses removed for ``no_lens``),
    the fixated point, each eye's gaze and the one accommodative response, and each eye's
    render inputs (``inputs[side]``: its scene in the eye's frame, eye, lens, view)."""

    wearer: Binocular
    fixation: object
    gazes: dict
    analysis: dict
    accommodation_d: float
    inputs: dict
    no_lens: bool
    fixed_focus: bool


def pose_binocular(scene, bino: Binocular, view, *, no_lens: bool = False) -> BinocularPose:
    """Each eye turned toward the fixated point (``view.gaze_deg`` is the cyclopean gaze),
    both with one accommodative response (``view.focus_d``, or the less-blurred-eye rule
    for the fixated point when it is None, at the eye's reference wavelength), each eye's
    response at most its amplitude."""
    b = bino.without_lenses() if no_lens else bino
    fix = b.fixation(view.gaze_deg)
    gazes = {s: b.gaze(s, view.gaze_deg) for s in SIDES}
    an = analyze_binocular(b, fix, wavelength_nm=EYE_REFERENCE_NM, fixation="rotating",
                           accommodation=view.focus_d)
    acc = float(an["accommodation_d"][0])
    inputs = {}
    for side in SIDES:
        eye = b.eye(side)
        v = view.replace(gaze_deg=gazes[side], focus_d=min(acc, eye.accommodation_max))
        inputs[side] = (b.scene_for(side, scene), eye, b.lens(side), v)
    return BinocularPose(b, fix, gazes, an, acc, inputs, no_lens, view.focus_d is not None)


def binocular_report(pose: BinocularPose) -> dict:
    """The two-eye part of a report: the per-eye gaze, accommodation, figures at the
    fixated point and the binocular prism there."""
    b, an, fix = pose.wearer, pose.analysis, pose.fixation
    per_eye = {}
    for side in SIDES:
        lens, r = b.lens(side), an[side]
        per_eye[side] = {
            "pupil_mm": [float(x) for x in b.pupil(side) * 1e3],
            "gaze_deg": list(pose.gazes[side]),
            "accommodation_d": float(r.accommodation[0]),
            "blur_at_fixation_arcmin": fixation_blur_arcmin(b.eye(side), r, 0),
            "rx": None if lens is None or lens.rx is None else lens.rx.format()}
    return {
        "output": b.output, "monocular_pd_mm": [v * 1e3 for v in b.monocular_pd],
        "frame_pd_mm": None if b.frame_pd is None or pose.no_lens else b.frame_pd * 1e3,
        "fixation_distance_m": b.fixation_distance if math.isfinite(b.fixation_distance)
        else "inf",
        "fixation_point_m": [float(x) for x in fix.positions()[0]] if fix.finite[0] else None,
        "accommodation_d": pose.accommodation_d,
        "accommodation_rule": "fixed (eye.accommodation_d)" if pose.fixed_focus
        else f"less-blurred eye: the {an['driving_eye'][0]} eye's response",
        "eyes": per_eye,
        "prism_at_fixation": prism_rows(b, an, 0)}


def render_binocular(renderer, scene, bino: Binocular, view, quality=None, *,
                     no_lens: bool = False, progressive: bool = False) -> BinocularResult:
    """Render what each eye sees of the head-frame ``scene`` with ``renderer`` (any
    :class:`~eyelab.imaging.contract.Renderer`), the eyes posed by
    :func:`pose_binocular`. The report lists the per-eye gaze, accommodation, figures at
    the fixated point and the binocular prism there (:func:`binocular_report`)."""
    pose = pose_binocular(scene, bino, view, no_lens=no_lens)
    results = {side: renderer.render(*pose.inputs[side], quality, progressive=progressive)
               for side in SIDES}
    report = {"binocular": binocular_report(pose),
              "right": results["right"].report, "left": results["left"].report}
    return BinocularResult(results["right"], results["left"], report)
