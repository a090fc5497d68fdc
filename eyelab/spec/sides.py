"""The eyes' sides. Two eyes in one spec: ``[eye]`` / ``[lens]`` hold what both sides
share, ``[eye.right]``, ``[lens.left]``, ... one side's own keys, ``[binocular]`` the
pupillary distances, the frame PD, the fixation distance and the output. One eye: its side
is the one its Rx names, if any, and its lens's Rx may not name the other."""

from __future__ import annotations

import math

from eyelab.core.checks import check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.chain.binocular import SIDES
from eyelab.optics.eye.prescription import Prescription
from eyelab.spec.parse import BINOCULAR_KEYS, parse_eye, parse_lens
from eyelab.spec.schema import LIMITS, check
from eyelab.spec.tables import check_keys, check_rules, number, rx_value

#: Keys a side's table ([eye.right], [lens.left], ...) may not hold: one value for both.
SHARED_ONLY = {"eye": ("accommodation_d",), "lens": ()}


def has_sides(t) -> bool:
    return isinstance(t, dict) and any(s in t for s in SIDES)


def _split_sides(t, where) -> tuple:
    """(shared keys, {side: that side's table}) of an [eye] or [lens] table."""
    if t is None:
        return None, {}
    if not isinstance(t, dict):
        raise SpecError(where, f"must be a table, got {t!r}")
    sides = {}
    for side in SIDES:
        st = t.get(side, {})
        if not isinstance(st, dict):
            raise SpecError(f"{where}.{side}", f"must be a table of {where} keys, got {st!r}")
        for key in SHARED_ONLY[where]:
            if key in st:
                raise SpecError(f"{where}.{side}.{key}", f"one value for both eyes: give it "
                                                         f"in [{where}]")
        sides[side] = st
    return {k: v for k, v in t.items() if k not in SIDES}, sides


def _for_side(where, side, own, fn):
    """``fn()``, with an error in a key the side's own table holds renamed to it."""
    try:
        return fn()
    except SpecError as e:
        head, _, rest = e.field.partition(".")
        key = rest.split("[")[0].split(".")[0]
        # a side's own [lens.<side>.front] without its back: the missing surface is the
        # side's too
        pair = key in ("front", "back") and bool({"front", "back"} & set(own))
        if head == where and (key in own or pair):
            raise SpecError(f"{where}.{side}.{rest}", e.message) from None
        raise


def parse_binocular(data: dict, frame=None):
    """A spec with two eyes -> :class:`eyelab.optics.chain.binocular.Binocular`.

    ``[eye]`` and ``[lens]`` hold what both sides share; ``[eye.right]``, ``[eye.left]``,
    ``[lens.right]``, ``[lens.left]`` any key of their table for one side (over the
    shared value); ``[binocular]`` the pupillary distances, the frame PD, the fixation
    distance and the output. Each lens's optical centre goes ``frame_pd_mm`` / 2 from the
    midline (in front of its pupil without it), plus any ``decentration_mm`` written
    (world frame: x to the wearer's right); ``wrap_deg`` is face-form for both lenses (the
    left lens's pose takes its mirror image); a progressive design gets its side's inset.
    With a ``frame`` (:class:`eyelab.spec.frame.FrameSpec`) each lens is cut to its side's
    outline, its fitting point before its pupil (the pupils: [binocular]'s, else the
    trace file's IPD records).
    """
    from eyelab.imaging.stereo import OUTPUTS
    from eyelab.optics.chain.binocular import Binocular
    from eyelab.spec.frame import binocular_pupils, fitted_lens, frame_for

    bt = data.get("binocular", {})
    check_keys(bt, BINOCULAR_KEYS, "binocular")
    check_rules(bt, "binocular")
    mpd = binocular_pupils(frame, bt) or _monocular_pd(bt)
    fpd = number(bt, "frame_pd_mm", "binocular")
    fix = bt.get("fixation_distance_m", "inf")
    if isinstance(fix, str) and fix.strip().lower() in ("inf", "infinity"):
        fix = math.inf
    else:
        fix = check("binocular.fixation_distance_m", fix)
    output = check_choice("binocular.output", bt.get("output", "side-by-side"), OUTPUTS)
    eye_shared, eye_sides = _split_sides(data.get("eye", {}), "eye")
    lens_shared, lens_sides = _split_sides(data.get("lens"), "lens")
    _one_model(eye_shared, eye_sides)
    eyes, lenses = {}, {}
    for side in SIDES:
        letter = side[0].upper()
        et = {**eye_shared, **eye_sides[side]}
        eyes[side] = _for_side("eye", side, eye_sides[side], lambda et=et: parse_eye(et))
        eye_rx = None
        if "rx" in et:
            where = _written("eye", side, eye_sides[side], "rx")
            eye_rx = rx_value(et["rx"], where)
            _check_side(eye_rx, side, where)
        else:                                # from the side's aberrations, if they give one
            eye_rx = eye_rx_of(et)
            where = f"eye.{side}.aberrations.coefficients_um"
        own = lens_sides.get(side, {})
        lt = None if lens_shared is None else _side_lens_table(lens_shared, own, side, fpd,
                                                                mpd)
        if eye_rx is not None:
            check_eye_add(eye_rx, lt, where)
        frame_for(frame, lt)
        if lt is None:
            lenses[side] = None
            continue

        def make(t, rx=eye_rx, s=letter, side=side, own=own):
            return _for_side("lens", side, own, lambda: parse_lens(t, rx, side=s))

        lenses[side] = make(lt) if frame is None else fitted_lens(
            frame, side, (mpd[SIDES.index(side)], _pd_field(bt, frame)), lt, make)
    return Binocular(eyes["right"], eyes["left"], lenses["right"], lenses["left"], mpd,
                     None if fpd is None else fpd * 1e-3, fix, output)


def _pd_field(bt: dict, frame) -> str:
    """The field the pupils of a two-eye spec came from."""
    for key in ("monocular_pd_mm", "pd_mm"):
        if key in bt:
            return f"binocular.{key}"
    return "frame.file" if frame.from_file and frame.file_pd_mm("right") is not None \
        else "binocular.pd_mm"


def _written(table: str, side: str, own: dict, key: str) -> str:
    """The field a binocular value came from: the side's table where it holds the key,
    else the shared one."""
    return f"{table}.{side}.{key}" if key in own else f"{table}.{key}"


def _check_side(rx: Prescription, side: str, where: str, why: str = "") -> None:
    """An Rx that names an eye (R/L/OD/OS) must be the side it is given for."""
    if rx.eye in ("R", "L") and rx.eye != side[0].upper():
        eye = "right" if rx.eye == "R" else "left"
        raise SpecError(where, f"{rx.format()!r} is for the {eye} eye, given for the {side}"
                               f"{why}")


def eye_rx_of(t: dict):
    """The Rx of an ``[eye]`` table: ``eye.rx`` as written, else the one its aberrations'
    second order gives (:mod:`eyelab.spec.aberrationparse`); None where it has neither —
    what a ``[lens]`` without ``rx`` is made for."""
    from eyelab.spec.aberrationparse import eye_aberrations
    from eyelab.spec.schema import EYE_VERTEX_MM
    from eyelab.spec.tables import number

    if "rx" in t:
        return rx_value(t["rx"], "eye.rx")
    if isinstance(t.get("aberrations"), dict):
        derived, _ = eye_aberrations(t, number(t, "vertex_distance_mm", "eye", EYE_VERTEX_MM))
        return derived.get("rx")
    return None


def _one_model(shared: dict, sides: dict) -> None:
    """Two eyes are of one model (both thin, or both the same schematic eye): a pair of
    models is refused, named by the side's own ``model`` key where one has it."""
    models = [{**shared, **sides[s]}.get("model", "thin") for s in SIDES]
    if models[0] == models[1]:
        return
    own = [s for s in SIDES if "model" in sides[s]]
    side = own[-1] if own else SIDES[1]
    raise SpecError(_written("eye", side, sides[side], "model"), "two eyes are of one model "
                    f"(here {models[0]!r} and {models[1]!r}): the accommodation they share "
                    "and the images they are compared by are one eye model's")


def parse_one_eye(data: dict, frame=None) -> tuple:
    """(eye, lens or None) of a spec with one eye. The eye has a side only where its Rx
    names one (R/OD, L/OS): a lens Rx naming the other side is refused, and a progressive
    lens is made for the eye's side (else its own Rx's, else the right). With a ``frame``
    (:class:`eyelab.spec.frame.FrameSpec`) the lens is cut to that side's outline (the
    right's where the eye has no side), its fitting point before the pupil."""
    from eyelab.spec.frame import fitted_lens, frame_for, one_eye_pd
    eye_t = data.get("eye", {})
    eye = parse_eye(eye_t)
    eye_rx = eye_rx_of(eye_t)                # as written, or from the aberrations
    lens_t = data.get("lens")
    check_eye_add(eye_rx, lens_t, "eye.rx")
    frame_for(frame, lens_t)
    if lens_t is None:
        return eye, None
    side = eye_rx.eye if eye_rx is not None and eye_rx.eye in ("R", "L") else None
    if side is not None and isinstance(lens_t, dict) and "rx" in lens_t:
        _check_side(rx_value(lens_t["rx"], "lens.rx"), "right" if side == "R" else "left",
                    "lens.rx", f" eye (eye.rx = {eye_rx.format()!r}): a lens Rx names the "
                    "eye's side or none")
    if frame is None or not isinstance(lens_t, dict):
        return eye, parse_lens(lens_t, eye_rx, side=side)
    which = "left" if (side or _rx_side(lens_t)) == "L" else "right"
    return eye, fitted_lens(frame, which, one_eye_pd(frame, which), lens_t,
                            lambda t: parse_lens(t, eye_rx, side=side))


def _rx_side(lens_t: dict):
    """The side a lens table's own Rx names ("R", "L") or None."""
    if "rx" not in lens_t:
        return None
    return rx_value(lens_t["rx"], "lens.rx").eye


def check_eye_add(rx: Prescription | None, lens_t, where: str) -> None:
    """An add in the eye's Rx is used only by a lens made from that Rx (a ``[lens]``
    without its own rx or surfaces): the eye itself has no add (its near focus is its
    accommodation), so anywhere else the add is refused, never ignored."""
    if rx is None or rx.add == 0:
        return
    if isinstance(lens_t, dict) and not {"rx", "front", "back"} & set(lens_t):
        return
    if lens_t is not None and not isinstance(lens_t, dict):
        return                                    # [lens] itself is refused
    why = ("there is no [lens] to take it" if lens_t is None else
           "the lens is made for its own rx: write the add there" if "rx" in lens_t else
           "the lens is given surface by surface")
    raise SpecError(where, f"{rx.format()!r} has an add, which the eye does not use ({why});"
                           " an add belongs to a lens made for this Rx (a [lens] without "
                           "rx, with lens.design), the eye's near focus to eye.age or "
                           "eye.accommodation_max_d")


def _monocular_pd(bt: dict) -> tuple:
    """(right, left) pupil centre to midline (m) of ``[binocular]``."""
    if "monocular_pd_mm" not in bt:
        pd = number(bt, "pd_mm", "binocular", 64.0) * 1e-3
        return pd / 2, pd / 2
    m = bt["monocular_pd_mm"]
    if not (isinstance(m, list) and len(m) == 2):
        raise SpecError("binocular.monocular_pd_mm", f"must be [right, left] in mm, got {m!r}")
    return tuple(check(f"binocular.monocular_pd_mm[{i}]", v) * 1e-3 for i, v in enumerate(m))


def _side_lens_table(lens_shared: dict, own: dict, side: str, fpd, mpd) -> dict:
    """One side's [lens] table: the shared keys under its own, its Rx checked for the
    side, its decentration from the frame PD, the left lens's wrap mirrored."""
    lt = {**lens_shared, **own}
    if "rx" in lt:
        where = _written("lens", side, own, "rx")
        _check_side(rx_value(lt["rx"], where), side, where)
    dec = lt.get("decentration_mm", [0.0, 0.0])
    where = _written("lens", side, own, "decentration_mm")
    if not (isinstance(dec, list) and len(dec) == 2):
        raise SpecError(where, f"must be [x, y] in mm, got {dec!r}")
    dec = [check(f"{where}[{i}]", v) for i, v in enumerate(dec)]
    if fpd is not None:
        sign = 1.0 if side == "right" else -1.0
        dec[0] += sign * (fpd / 2 - mpd[0 if side == "right" else 1] * 1e3)
        if abs(dec[0]) > LIMITS["lens.decentration_mm"][1]:
            raise SpecError("binocular.frame_pd_mm", f"puts the {side} lens's optical "
                            f"centre {dec[0]:+.1f} mm from its pupil; at most "
                            f"{LIMITS['lens.decentration_mm'][1]:g} mm")
    lt["decentration_mm"] = dec
    if "wrap_deg" in lt and side == "left":
        lt["wrap_deg"] = -check(_written("lens", side, own, "wrap_deg"), lt["wrap_deg"])
    return lt
