"""The inspector's two eyes: a two-eye spec (``[binocular]``, or per-eye tables) inspected
as ``eyelab render`` renders it — each eye posed for the cyclopean gaze with one
accommodative response (:func:`eyelab.imaging.stereo.pose_binocular`), both eyes' frames
run in step and composed in linear light as the spec's ``binocular.output`` (or a red/cyan
anaglyph, toggled). The eye controls edit one eye or both (linked); the state is kept as
a spec whose ``[eye.right]`` and ``[eye.left]`` tables hold each eye's keys in full, so
what one eye's slider writes never moves the other."""

from __future__ import annotations

import copy

from eyelab.imaging.stereo import SIDES, BinocularResult, binocular_report, compose
from eyelab.jobs.controls import EXPLICIT_EYE, STEP, edit_spec_data, snap
from eyelab.optics.eye.prescription import Prescription
from eyelab.spec.sides import SHARED_ONLY

#: The eyes the controls edit, cycled by the window's ``e`` key.
EDIT_CYCLE = ("both", "right", "left")
#: Keys a two-eye spec's ``[eye]`` keeps for both eyes (one value only).
SHARED_EYE_KEYS = SHARED_ONLY["eye"]


def sided_data(data: dict) -> dict:
    """A copy of the two-eye spec table ``data`` whose ``[eye.right]`` / ``[eye.left]``
    hold every eye key of their side (the shared ``[eye]`` keys folded in, only the keys
    both eyes must share left in ``[eye]``), and whose lens on each side keeps that eye's
    Rx as its prescription when the spec designs it from the eye's (as the one-eye
    inspector does), so that moving an eye's sliders leaves the lenses as they are."""
    data = copy.deepcopy(data)
    eye = data.get("eye", {})
    shared = {k: v for k, v in eye.items() if k not in SIDES}
    out = {k: v for k, v in shared.items() if k in SHARED_EYE_KEYS}
    for side in SIDES:
        out[side] = {**{k: v for k, v in shared.items() if k not in SHARED_EYE_KEYS},
                     **eye.get(side, {})}
    data["eye"] = out
    lens = data.get("lens")
    if isinstance(lens, dict):
        for side in SIDES:
            own = lens.get(side, {})
            if not any(k in t for t in (lens, own) for k in ("rx", "front")) \
                    and "rx" in out[side]:
                lens.setdefault(side, {})["rx"] = out[side]["rx"]
    return data


def edited_sides(edit: str) -> tuple:
    """The sides the controls edit for the ``edit`` mode (:data:`EDIT_CYCLE`)."""
    return SIDES if edit == "both" else (edit,)


def binocular_frame(pose, right, left) -> BinocularResult:
    """Both eyes' RenderResults of one step as a BinocularResult with the two-eye report."""
    return BinocularResult(right, left, {"binocular": binocular_report(pose),
                                         "right": right.report, "left": left.report})


def display_linear(result, output: str):
    """(h, w', 3) linear image of a BinocularResult as ``output`` shows it."""
    return compose(result.right.linear, result.left.linear, output)


def readout(result) -> str:
    """The two-eye readout: pupillary and frame PDs, the accommodation and the prism at
    the fixated point (the report's ``binocular`` part)."""
    b = result.report["binocular"]
    r, l_ = b["monocular_pd_mm"]
    fpd = "" if b["frame_pd_mm"] is None else f", frame PD {b['frame_pd_mm']:.1f} mm"
    fix = b["fixation_distance_m"]
    fix_s = "infinity" if fix == "inf" else f"{fix:g} m"
    blur = "  ".join(f"{s[0].upper()} {b['eyes'][s]['blur_at_fixation_arcmin'][0]:.2f}'"
                     for s in SIDES)
    prism = b["prism_at_fixation"]
    prism_s = ("no prism (no lenses, or a line of sight misses one)" if prism is None else
               f"prism {prism['binocular']['horizontal']}, {prism['binocular']['vertical']}")
    return (f"PD {r:.1f} + {l_:.1f} mm{fpd}; fixation {fix_s}: accommodation "
            f"{b['accommodation_d']:.2f} D, blur {blur}; {prism_s}")


def fixation_distance(result) -> float:
    """Distance (m) from the eyes' midpoint to the fixated point (inf at infinity)."""
    import math

    p = result.report["binocular"]["fixation_point_m"]
    return math.inf if p is None else math.sqrt(sum(float(v) ** 2 for v in p))


class TwoEyesMixin:
    """The inspector model's eyes: which one the controls show and edit, how an edit is
    written (one eye's table, or both eyes' — linked — by the same change), each eye's
    renderer, and its rotation on the as-worn maps. Needs of its model: ``spec``,
    ``data``, ``renderer``, ``pose`` (the last frame's :class:`BinocularPose`, or None),
    ``value()``, ``apply()``, ``message``, ``last_change``, ``_maps_key`` and
    ``_left_renderer`` (None until a left eye's renderer is made)."""

    @property
    def two_eyes(self) -> bool:
        return self.spec.binocular is not None

    def reset_eyes(self) -> None:
        """The controls on both eyes and the view as the spec's output (after a load or a
        reset)."""
        self.edit = "both" if self.two_eyes else None
        self.output = None if not self.two_eyes else self.spec.binocular.output

    @property
    def side(self) -> str | None:
        """The eye the controls show (two eyes: the edited one, the right when both)."""
        return None if not self.two_eyes else ("right" if self.edit == "both" else self.edit)

    @property
    def eye(self):
        """The eye the controls show (:attr:`side`'s of two)."""
        return self.spec.eye if not self.two_eyes else self.spec.binocular.eye(self.side)

    def _eye_table(self, side=None, data=None) -> dict:
        eye = (self.data if data is None else data).get("eye", {})
        return eye if not self.two_eyes else eye.get(side or self.side, {})

    def explicit_powers(self, side=None) -> bool:
        """Whether the eye is given by its powers (``power_min_d``, ...) rather than an Rx."""
        return any(k in self._eye_table(side) for k in EXPLICIT_EYE)

    def eye_rx(self, side=None, data=None) -> Prescription:
        """The eye's refraction as an Rx (plano when the spec gives explicit powers:
        :meth:`explicit_powers`); of ``side`` (default the shown eye) for two eyes."""
        rx = self._eye_table(side, data).get("rx")
        field = "eye.rx" if not self.two_eyes else f"eye.{side or self.side}.rx"
        return Prescription() if rx is None else Prescription.parse(rx, field=field)

    def eye_text(self) -> str:
        """The eyes' Rx for the status line (and which eye the controls edit)."""
        def rx(side):
            return "explicit powers" if self.explicit_powers(side) else \
                self.eye_rx(side).format()
        if not self.two_eyes:
            return "eye " + rx(None)
        return f"eyes R {rx('right')}, L {rx('left')} (editing {self.edit})"

    def cycle_edit(self) -> str | None:
        """Two eyes: the controls edit the next of both / right / left; returns it. The
        maps follow the shown eye's lens."""
        if self.two_eyes:
            self.edit = EDIT_CYCLE[(EDIT_CYCLE.index(self.edit) + 1) % len(EDIT_CYCLE)]
            self.last_change = f"editing: {self.edit} eye{'s' if self.edit == 'both' else ''}"
            self._maps_key = None
        return self.edit

    def toggle_anaglyph(self) -> str | None:
        """Two eyes: the view as a red/cyan anaglyph, or back to the spec's output (the
        saved spec says which: :meth:`dump`)."""
        if self.two_eyes:
            spec_out = self.spec.binocular.output
            self.output = (spec_out if self.output == "anaglyph" and spec_out != "anaglyph"
                           else "side-by-side" if self.output == "anaglyph" else "anaglyph")
            self.last_change = f"output {self.output}: display only"
        return self.output

    def edit_eyes(self, data: dict, name: str, v) -> None:
        """Write control ``name``'s value ``v`` into spec table ``data``: one eye's, or
        each edited eye's. Linked (both eyes), the Rx controls move both eyes by the change
        of the shown (right) eye — sphere and cylinder by the same dioptres, the axis
        mirrored (the left eye's by minus the right's change) — so an anisometropia or a
        mirror-symmetric astigmatism is kept (an eye given by its powers keeps them: edited
        alone, its sliders replace them by an Rx); the pupil and the age are one value."""
        if not self.two_eyes:
            edit_spec_data(data, name, v)
            return
        if self.edit != "both" or name not in ("sphere", "cylinder", "axis"):
            edit_spec_data(data, name, v, edited_sides(self.edit))
            return
        change = snap(v, STEP[name]) - getattr(self.eye_rx("right", data), name)
        for side, sign in (("right", 1.0), ("left", -1.0 if name == "axis" else 1.0)):
            if self.explicit_powers(side):
                continue                # its powers are kept: edit it alone to replace them
            new = getattr(self.eye_rx(side, data), name) + sign * change
            if name == "axis":
                new = (new - 1.0) % 180.0 + 1.0                    # 1-180
            edit_spec_data(data, name, new, (side,))

    def copy_eye_rx_to_lens(self) -> str | None:
        """The lens (each edited eye's) made for the eye's current refraction (a full
        correction). Lenses given by their surfaces, and eyes given by their powers rather
        than an Rx, are left as they are and named in the message."""
        lens = self.data.get("lens")
        if lens is None:
            self.message = "no lens to design"
            return self.message
        sides = (None,) if not self.two_eyes else edited_sides(self.edit)
        rxs, left_out = {}, []
        for side in sides:
            own = lens if side is None else {**lens, **lens.get(side, {})}
            who = "the lens" if side is None else f"the {side} lens"
            if "front" in own or "back" in own:
                left_out.append(f"{who} is given by its surfaces")
            elif self.explicit_powers(side):
                left_out.append(f"{who}'s eye is given by its powers, not an Rx")
            else:
                rxs[side] = self._eye_table(side).get("rx", "plano")
        if rxs and (error := self.apply({"lens_rx": rxs[None] if None in rxs else rxs})):
            return error
        if left_out:
            self.message = "not designed: " + "; ".join(left_out)
            return self.message
        return None

    def renderers(self) -> list:
        """The raster renderer of each eye: one eye's, or the right's and the left's (two
        interleaved progressive renders may not share one renderer's GL windows)."""
        if not self.two_eyes:
            return [self.renderer]
        if self._left_renderer is None:
            from eyelab.render.raster import RasterRenderer

            self._left_renderer = RasterRenderer()
        return [self.renderer, self._left_renderer]

    def shown_renderer(self):
        """The renderer of the eye the controls show."""
        return self.renderers()[1 if self.side == "left" else 0]

    def eye_gaze(self) -> tuple:
        """(right, up) deg: the shown eye's rotation — the gaze for one eye; for two, the
        eye's own rotation toward the fixated point (the last frame's pose)."""
        if not self.two_eyes or self.pose is None:
            return tuple(self.value("gaze"))
        return tuple(float(v) for v in self.pose.gazes[self.side])

    def gaze_for_eye_rotation(self, rotation) -> tuple:
        """The (cyclopean) gaze that turns the shown eye to ``rotation`` (right, up; deg),
        to first order: the gaze moved by the rotation's change."""
        return tuple(float(r) + g - e for r, g, e in
                     zip(rotation, self.value("gaze"), self.eye_gaze(), strict=True))
