"""The whole spec document: :class:`Spec` (what a TOML file describes), parsed from a dict,
loaded from a file (or the built-in default), and written back as TOML."""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from eyelab.core.checks import check_choice
from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import FIXATIONS, VERTEX_SPHERES
from eyelab.optics.chain.binocular import SIDES, Binocular
from eyelab.optics.eye.thin import (
    Eye,
)
from eyelab.optics.lens.spectacle import SpectacleLens
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.spec.frame import parse_frame
from eyelab.spec.parse import ANALYSIS_KEYS, eye_accommodation, parse_points
from eyelab.spec.render import RenderSpec, parse_render
from eyelab.spec.schema import DEFAULT_FIXATION
from eyelab.spec.sides import has_sides, parse_binocular, parse_one_eye
from eyelab.spec.surfacefile import with_spec_folder
from eyelab.spec.tables import check_keys, number


@dataclass(frozen=True)
class Spec:
    """A whole spec: what a TOML spec file describes, validated, as eyelab's objects.

    Made by :func:`load_spec` (a file, or the built-in default) or, from the tables of a
    file as a dict, by :func:`parse_spec`; every function of :mod:`eyelab` that takes a
    spec takes one. It is frozen: ``dataclasses.replace(spec, lens=None)`` is the same spec
    without its lens.

    Parameters
    ----------
    eye : Eye or a schematic eye
        The ``[eye]`` table: the thin eye (:class:`~eyelab.optics.eye.thin.Eye`) or the
        schematic eye ``eye.model`` names; of a two-eye spec, the right eye.
    lens : SpectacleLens or None
        The ``[lens]`` table, None without one; of a two-eye spec, the right eye's.
    points : ObjectPoints
        The ``[[points]]``: the object points ``eyelab.analyze`` and ``eyelab.psf`` look at.
    wavelength_nm : float
        ``analysis.wavelength_nm``: the wavelength (nm) ``eyelab.analyze`` traces at.
    fixation : str
        ``analysis.fixation``: "rotating" (the eye turns about its centre of rotation
        toward each point) or "fixed".
    accommodation : float or None
        ``eye.accommodation_d``: a fixed accommodation (D), or None for "auto" (the best
        effort for each point).
    source : str
        Where it came from: the file's path, ``"<built-in default>"`` or ``"<dict>"``.
    render : RenderSpec
        The ``[render]`` table: the scene, the renderer, the view and the renderer's
        quality options.
    vertex_sphere : str
        ``analysis.vertex_sphere``: where ``eyelab.analyze`` takes the vertex-sphere wave,
        "rotation_centre" or "pupil".
    binocular : Binocular or None
        Two eyes (below).
    warnings : tuple of str
        Notes on the input (below).

    Examples
    --------
    >>> import dataclasses
    >>> import eyelab
    >>> spec = eyelab.load_spec("examples/first.toml")
    >>> spec.lens.rx.format(), spec.render.scene.name, spec.render.view.shape
    ('-2.50 / -0.75 x 090', 'chart', (240, 320))
    >>> naked = dataclasses.replace(spec, lens=None)     # the same spec without its lens
    >>> naked.lens is None, naked.eye == spec.eye
    (True, True)
    """

    eye: Eye
    lens: SpectacleLens | None
    points: ObjectPoints
    wavelength_nm: float = 587.56
    fixation: str = DEFAULT_FIXATION
    accommodation: float | None = None
    source: str = "<built-in>"
    render: RenderSpec = field(default_factory=RenderSpec)
    vertex_sphere: str = "rotation_centre"
    #: Two eyes (:class:`eyelab.optics.chain.binocular.Binocular`) when the spec has [binocular] or
    #: per-eye tables; ``eye`` and ``lens`` are then the right eye's.
    binocular: Binocular | None = None
    #: What the input says that eyelab did not take as given, one line each (e.g. a trace
    #: file whose box records contradict its radii); printed by the commands, kept in the
    #: render reports' ``warnings``.
    warnings: tuple = ()


@with_spec_folder    # relative points files (lens.front.file) are the spec's
def parse_spec(data: dict, source: str = "<dict>", base: Path | None = None) -> Spec:
    check_keys(data, {"eye", "lens", "analysis", "points", "render", "binocular", "frame"},
               "spec")
    eye_t = data.get("eye", {})
    frame = parse_frame(data["frame"], base) if "frame" in data else None
    bino = None
    if "binocular" in data or has_sides(eye_t) or has_sides(data.get("lens")):
        bino = parse_binocular(data, frame)
        eye, lens = bino.right, bino.right_lens
        eye_t = {k: v for k, v in eye_t.items() if k not in SIDES}
    else:
        eye, lens = parse_one_eye(data, frame)
    an = data.get("analysis", {})
    check_keys(an, ANALYSIS_KEYS, "analysis")
    wl = number(an, "wavelength_nm", "analysis", 587.56)
    fix = check_choice("analysis.fixation", an.get("fixation", DEFAULT_FIXATION), FIXATIONS)
    acc = eye_accommodation(eye_t) if isinstance(eye_t, dict) else None
    vsph = check_choice("analysis.vertex_sphere", an.get("vertex_sphere", "rotation_centre"),
                        VERTEX_SPHERES)
    points = parse_points(data.get("points", [{"distance_m": "inf"}]))
    render = parse_render(data.get("render", {}), base)
    if render.camera is not None:
        for table in ("lens", "binocular", "frame"):
            if table in data:
                raise SpecError("render.camera", f"a camera lens sees the scene; [{table}] "
                                                 "has no meaning with it")
        if data.get("eye"):
            raise SpecError("render.camera", "a camera lens sees the scene; [eye] has no "
                                             "meaning with it")
    render = dataclasses.replace(render, view=dataclasses.replace(render.view, focus_d=acc))
    notes = () if frame is None else frame.notes
    return Spec(eye, lens, points, wl, fix, acc, source, render, vsph, bino, notes)


def one_eye(spec: Spec, what: str) -> Spec:
    """``spec``, or a one-line error naming ``[binocular]`` when it has two eyes and
    ``what`` (the inspector, batch, maps) shows one."""
    if spec.binocular is not None:
        raise SpecError("binocular", f"{what} shows one eye; this spec has two ([binocular] "
                                     "or per-eye tables): use eyelab render, demo or analyze")
    return spec


def no_camera(spec: Spec, what: str) -> Spec:
    """``spec``, or a one-line error naming ``render.camera`` when it renders through a
    camera lens: ``what`` (analyze, psf, maps) is an eye's and its spectacle lens's."""
    if spec.render.camera is not None:
        raise SpecError("render.camera", f"{what} is an eye's (and its spectacle lens's); this "
                        "spec has a camera lens, which has no eye: render it with eyelab "
                        "render")
    return spec


def pick_eye(spec: Spec, side: str | None, what: str, *, point: int | None = None,
             no_lens: bool = False, flag: str = "--eye") -> Spec:
    """A one-eye spec for ``what``: ``spec`` itself when it has one eye (``side`` None);
    of a two-eye spec the ``side`` eye ("right" or "left") with its lens and the points as
    its frame holds them, at the accommodation both eyes share at ``point`` (the
    less-blurred eye's, :func:`~eyelab.optics.chain.binocular.analyze_binocular`) unless
    the spec fixes one (through the lenses' carriers, or naked with ``no_lens``). A
    one-line error for a side of a one-eye spec or none of two, naming ``flag``: the
    CLI's ``--eye`` or the Python argument ``eye``."""
    if spec.binocular is None:
        if side is not None:
            raise SpecError(flag, "picks one eye of a two-eye spec ([binocular] or "
                                  "per-eye tables); this spec has one")
        return spec
    if side is None:
        how = (f"{flag} right|left" if flag.startswith("-")
               else f'{flag}="right" or {flag}="left"')
        raise SpecError("binocular", f"{what} shows one eye; this spec has two ([binocular] "
                                     f"or per-eye tables): pick one with {how}")
    check_choice(flag, side, SIDES)
    b = spec.binocular
    acc = spec.accommodation
    if acc is None and point is not None and 0 <= point < len(spec.points):
        from eyelab.optics.chain.binocular import analyze_binocular
        from eyelab.optics.lens.lenslets import carrier

        carriers = dataclasses.replace(b, right_lens=carrier(b.right_lens),
                                       left_lens=carrier(b.left_lens))
        an = analyze_binocular(carriers, spec.points, wavelength_nm=spec.wavelength_nm,
                               fixation=spec.fixation, no_lens=no_lens)
        acc = float(an["accommodation_d"][point])
    return dataclasses.replace(spec, eye=b.eye(side), lens=b.lens(side), binocular=None,
                               points=b.points_for(side, spec.points), accommodation=acc)


def thin_eye(spec: Spec, what: str) -> Spec:
    """``spec``, or a one-line error naming ``eye.model`` when its eye is a schematic eye
    and ``what`` takes the thin eye only."""
    if not isinstance(spec.eye, Eye):
        raise SpecError("eye.model", f"{what} takes the thin eye (eye.model = \"thin\"); "
                        f"the {spec.eye.model} eye works with eyelab analyze and eyelab "
                        "maps --kind peripheral")
    return spec


def load_spec(path: str | Path | None = None) -> Spec:
    """Load a TOML spec; ``None`` loads the built-in default scene.

    ``path``: a spec file (str or Path); the files it names (a lens's points files, a
    mesh as ``[render] scene``) are found relative to its folder. Returns a :class:`Spec`.
    A file that cannot be read, is not TOML, or holds a bad key or value raises
    :class:`~eyelab.core.errors.SpecError`: one line naming the field and what is allowed.

    Examples
    --------
    >>> import eyelab
    >>> spec = eyelab.load_spec("examples/first.toml")
    >>> spec.source, spec.lens.material.name
    ('examples/first.toml', 'polycarbonate')
    >>> spec.lens.rx, spec.eye.pupil_diameter
    (Prescription(sphere=-2.5, cylinder=-0.75, axis=90, add=0, eye=None), 0.004)
    >>> eyelab.load_spec().source
    '<built-in default>'
    """
    data, source, base = read_spec_data(path)
    return parse_spec(data, source, base)


def read_spec_data(path: str | Path | None = None) -> tuple:
    """(table, source, base folder) of a TOML spec file, unvalidated (:func:`parse_spec`
    checks it); ``None``: the built-in default."""
    if path is None:
        text = resources.files("eyelab").joinpath("data/default.toml").read_text()
        source = "<built-in default>"
        base = None
    else:
        p = Path(path)
        shown = str(p) if len(str(p)) <= 80 else f"{str(p)[:40]}... ({len(str(p))} characters)"
        try:
            if not p.is_file():
                raise SpecError("spec", f"file not found (or not a file): {shown!r}")
            raw = p.read_bytes()
        except OSError as e:
            raise SpecError("spec", f"cannot read {shown!r}: {e.strerror}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise SpecError("spec", f"{shown} is not a UTF-8 text file (byte {e.start}): a "
                                    "spec is TOML text; a mesh goes in [render] scene") from None
        source = str(p)
        base = p.parent
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SpecError("spec", f"{source} is not valid TOML: {e}") from None
    except RecursionError:
        raise SpecError("spec", f"{source}: nesting too deep") from None
    return data, source, base


def toml_value(v) -> str:
    """One value as TOML: booleans, integers, floats written exactly (``repr``; ``inf``,
    ``nan``), strings, arrays and inline tables."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return "nan" if math.isnan(v) else repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise SpecError("spec", f"cannot write {v!r} as TOML")


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _toml_table(name: str, t: dict, lines: list) -> None:
    """``[name]`` with its scalars, then its nested tables and arrays of tables."""
    scalars = {k: v for k, v in t.items() if not isinstance(v, dict) and not _is_table_array(v)}
    lines.append(f"[{name}]")
    lines.extend(f"{k} = {toml_value(v)}" for k, v in scalars.items())
    lines.append("")
    for k, v in t.items():
        if isinstance(v, dict):
            _toml_table(f"{name}.{k}", v, lines)
        elif k not in scalars:
            _toml_items(f"{name}.{k}", v, lines)


def _toml_items(name: str, items: list, lines: list) -> None:
    """An array of tables ``[[name]]``."""
    for item in items:
        lines.append(f"[[{name}]]")
        lines.extend(f"{k} = {toml_value(v)}" for k, v in item.items())
        lines.append("")


def dump_spec(data: dict) -> str:
    """A spec table as TOML text that :func:`tomllib.loads` reads back equal: tables of
    scalars, strings, lists of scalars, nested tables ([lens.front]) and arrays of tables
    ([[points]]); floats written exactly (``repr``), infinities as ``inf``.

    >>> import tomllib
    >>> d = {"eye": {"rx": "-2.00 DS", "age": 40}, "points": [{"distance_m": "inf"}]}
    >>> tomllib.loads(dump_spec(d)) == d
    True
    """
    lines = []
    for name, t in data.items():
        if isinstance(t, dict):
            _toml_table(name, t, lines)
        elif isinstance(t, list):
            _toml_items(name, t, lines)
        else:
            raise SpecError(f"spec.{name}", "top-level entries must be tables")
    return "\n".join(lines)
