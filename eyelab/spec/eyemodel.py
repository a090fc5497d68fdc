"""``[eye] model``: the thin toric eye (the default) or a schematic eye of real surfaces
(:mod:`eyelab.optics.eye.schematic`), and the keys each reads.

A schematic eye is made from ``rx`` (spherical: its axial length fitted so that the Rx
corrects its far point at the d line, axial ametropia) or from ``axial_length_mm``; the
published eye without either. It takes the pupil (or luminance), the centre of rotation,
the accommodation (``accommodation_max_d`` or ``age``, within its formulas' 0-10 D) and
``accommodation_d`` as the thin eye does; the thin eye's own parameters are refused by name.
"""

from __future__ import annotations

from eyelab.core.checks import check_bool, check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.eye.models import EYE_MODELS, NAVARRO_MAX_ACCOMMODATION_D, SCHEMATIC_MODELS
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.eye.thin import hofstetter_amplitude, watson_yellott_pupil
from eyelab.spec.schema import check
from eyelab.spec.tables import check_rules, number, rx_value

#: The keys only the schematic eyes read.
SCHEMATIC_KEYS = ("axial_length_mm",)
#: The thin eye's own parameters, which a schematic eye does not read (its powers come
#: from its surfaces, its aberrations from tracing them, its dispersion from its media).
THIN_ONLY_KEYS = ("kind", "power_min_d", "astigmatism_d", "astigmatism_axis_deg",
                  "retina_distance_mm", "n_vitreous", "chromatic", "aberrations")


def eye_options(t: dict) -> dict:
    """The eye keywords of ``[eye]`` that do not depend on how the powers are given:
    amplitude (or age), pupil (or luminance), vitreous, centre of rotation, chromatic
    aberration (a schematic eye refuses the thin eye's own before it takes the rest)."""
    kw = {}
    if "age" in t:
        kw["accommodation_max"] = hofstetter_amplitude(
            check("eye.age", t["age"]), t.get("amplitude_model", "mean"))
    elif "accommodation_max_d" in t:
        kw["accommodation_max"] = number(t, "accommodation_max_d", "eye")
    if "pupil_diameter_mm" in t:
        kw["pupil_diameter"] = number(t, "pupil_diameter_mm", "eye") * 1e-3
    elif "luminance_cd_m2" in t:
        kw["pupil_diameter"] = watson_yellott_pupil(t["luminance_cd_m2"],
                                                    t.get("age", 30.0)) * 1e-3
    if "n_vitreous" in t:
        kw["n_vitreous"] = number(t, "n_vitreous", "eye")
    if "rotation_centre_mm" in t:
        kw["rotation_centre"] = number(t, "rotation_centre_mm", "eye") * 1e-3
    if "chromatic" in t:
        kw["chromatic"] = check_bool("eye.chromatic", t["chromatic"])
    return kw


def eye_model(t: dict) -> str:
    """``eye.model`` of an ``[eye]`` table (default "thin"); a schematic eye's key without
    a schematic model is refused by name."""
    model = check_choice("eye.model", t.get("model", "thin"), EYE_MODELS)
    if model == "thin":
        for key in SCHEMATIC_KEYS:
            if key in t:
                raise SpecError(f"eye.{key}", f"only read by a schematic eye (eye.model = "
                                f"{', '.join(map(repr, SCHEMATIC_MODELS))})")
    return model


def parse_schematic(t: dict, model: str, vertex_mm: float) -> SchematicEye:
    """The schematic eye of ``[eye]`` ``t`` (``vertex_mm``: where ``rx`` is worn)."""
    for key in THIN_ONLY_KEYS:
        if key in t:
            raise SpecError(f"eye.{key}", f"not read by the {model} eye (eye.model = "
                            f"{model!r}): its powers, aberrations and dispersion come from "
                            f"its surfaces and media")
    check_rules(t, "eye")
    options = eye_options(t)
    kw = {k: options[k] for k in ("pupil_diameter", "rotation_centre", "accommodation_max")
          if k in options}
    amp = kw.get("accommodation_max")
    if amp is not None and amp > NAVARRO_MAX_ACCOMMODATION_D:
        key = "eye.age" if "age" in t else "eye.accommodation_max_d"
        raise SpecError(key, f"gives {amp:g} D of accommodation; the {model} eye's formulas "
                             f"hold for 0-{NAVARRO_MAX_ACCOMMODATION_D:g} D")
    if "rx" in t and "axial_length_mm" in t:
        raise SpecError("eye.axial_length_mm", "give either eye.rx or eye.axial_length_mm, "
                                               "not both (the rx fits the axial length)")
    if "axial_length_mm" in t:
        kw["axial_length"] = number(t, "axial_length_mm", "eye") * 1e-3
    if "rx" in t:
        rx = rx_value(t["rx"], "eye.rx")
        return SchematicEye.from_rx(rx, vertex_distance=vertex_mm * 1e-3, model=model, **kw)
    return SchematicEye(model=model, **kw)
