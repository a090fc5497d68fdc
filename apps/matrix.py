"""The capability matrix (docs/guide/matrix.md): every eye with every lens in every command,
each cell run as a user runs it (the ``eyelab`` command, in-process, at a tiny size) and
its outcome recorded — it works, it refuses in one line (the line is the table's), or it
is broken (any other exit or an exception: a defect). ``python -m eyelab.apps.matrix``
prints the table; ``--write PATH`` rewrites the page; ``tests/test_matrix.py`` runs it
and asserts that no cell is broken and every refusal names a field and its reason.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
from pathlib import Path

#: The eyes (their ``[eye]`` tables; two eyes as per-side tables).
EYES = {
    "thin": {"eye": {"rx": "-2.00", "pupil_diameter_mm": 4}},
    "thin + Zernike": {"eye": {"rx": "-2.00", "pupil_diameter_mm": 4, "aberrations": {
        "coefficients_um": [0, 0, 0, 0, 0, 0, 0, 0.2, 0, 0, 0, 0, 0.1], "pupil_mm": 6.0}}},
    "Navarro": {"eye": {"model": "navarro", "rx": "-2.00", "pupil_diameter_mm": 4}},
    "Navarro, accommodated": {"eye": {"model": "navarro", "rx": "-2.00",
                                      "pupil_diameter_mm": 4, "accommodation_d": 1.5}},
    "two thin": {"eye": {"right": {"rx": "-2.00"}, "left": {"rx": "-1.50"},
                         "pupil_diameter_mm": 4}},
    "two Navarro": {"eye": {"model": "navarro", "right": {"rx": "-2.00"},
                            "left": {"rx": "-1.50"}, "pupil_diameter_mm": 4}},
}
#: The lenses (their ``[lens]`` tables; None: no lens).
LENSES = {
    "none": None,
    "sphere": {"rx": "-2.00"},
    "toric": {"rx": "-2.00 -1.00 x 90"},
    "progressive": {"rx": "-2.00 add +2.00", "design": "progressive"},
    "lenslets": {"rx": "-2.00", "lenslets": {"layout": "honeycomb", "add_d": 3.5,
                                             "diameter_mm": 1.03, "pitch_mm": 1.43,
                                             "clear_zone_mm": 9.4, "zone_mm": 33}},
    "points file": {"front": {"type": "points", "file": "{sample}", "spacing_mm": 2.0},
                    "back": {"type": "plane"}, "center_thickness_mm": 2.0},
    # not a spectacle lens: a camera lens system in place of the eye ([render] keys)
    "camera": {"render": {"renderer": "reference", "camera": "doublet"}},
}
TINY = ["--width", "32", "--height", "24", "--samples", "2"]
#: The commands: name -> the arguments after the spec path (``{out}``: a folder).
COMMANDS = {
    "render (raster)": ["render", *TINY, "-o", "{out}/r.png"],
    "render (reference)": ["render", "--renderer", "reference", *TINY, "-o", "{out}/r.png"],
    "render (image-based)": ["render", "--renderer", "imagebased", *TINY,
                             "-o", "{out}/r.png"],
    "demo": ["demo", *TINY, "-o", "{out}/d.png"],
    "analyze": ["analyze"],
    "maps (as worn)": ["maps", "--kind", "asworn", "--points", "5", "-o", "{out}/m.png"],
    "maps (peripheral)": ["maps", "--kind", "peripheral", "--points", "3",
                          "-o", "{out}/m.png"],
    "psf": ["psf", "--size", "33", "-o", "{out}/p.npy"],
    "surface": ["surface", "--side", "front", "-o", "{out}/f.csv"],
    "inspect": ["inspect", "--screenshot", "{out}/i.png", "--size", "32x24", "--samples",
                "1"],
    "batch": ["batch", "{job}", "-o", "{out}/batch"],
    "API render": "render",
    "API analyze": "analyze",
    "API maps": "maps",
    "API psf": "psf",
    "notebook": "notebook",
}
#: A batch cell's job file: the cell's spec as the base, two cases of a render key (an
#: axis every spec takes), tiny images.
BATCH_JOB = """spec = "spec.toml"
[base]
render = {width = 32, height = 24}
[sweep]
"render.samples" = [1, 2]
"""


def _api_call(name: str, spec: Path, folder: Path) -> None:
    """The Python API's call of a cell (``eyelab.render`` ... ``eyelab.NotebookInspector``)
    at a tiny size; its result used as a user would (saved, read, closed)."""
    import eyelab

    if name == "render":
        eyelab.render(spec, width=32, height=24, samples=2).save(folder / "a.png")
    elif name == "analyze":
        assert eyelab.analyze(spec)["points"]
    elif name == "maps":
        eyelab.maps(spec, n=5)
    elif name == "psf":
        image, _ = eyelab.psf(spec, size=33)
        assert image.shape == (3, 33, 33)
    else:
        inspector = eyelab.NotebookInspector(spec, size=(32, 24), samples=1)
        try:
            assert inspector.image.value[:4] == b"\x89PNG"
        finally:
            inspector.close()


def _toml(value) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def spec_text(eye: dict, lens: dict | None) -> str:
    """A spec file's text for one cell: the eye's tables, the lens's (each side's when the
    eye has two; a points file's path filled in) or a camera's ``[render]`` keys in the
    eye's place, a distant point straight ahead and one 20 deg down at 0.5 m."""
    lines = []

    def table(name, t):
        lines.append(f"[{name}]")
        subs = {k: v for k, v in t.items() if isinstance(v, dict)}
        lines.extend(f"{k} = {_toml(v)}" for k, v in t.items() if not isinstance(v, dict))
        for k, v in subs.items():
            table(f"{name}.{k}", v)

    lens = dict(lens or {})
    render = lens.pop("render", None)
    if render is None or "camera" not in render:      # a camera takes the eye's place
        table("eye", eye["eye"])
    if lens:
        from eyelab.spec.surfacefile import SAMPLE

        table("lens", json.loads(json.dumps(lens).replace('"{sample}"', json.dumps(SAMPLE))))
    if render is not None:
        table("render", render)
    lines.append("[[points]]\nfield_deg = [0, 0]\n[[points]]\nfield_deg = [0, -20]\n"
                 "distance_m = 0.5")
    return "\n".join(lines) + "\n"


def run_cell(eye: dict, lens: dict | None, argv: list, folder: Path) -> tuple:
    """(outcome, line): "works", "refuses" (exit 2 and one line on stderr: that line) or
    "broken" (another exit, more lines, or an exception: its text)."""
    from eyelab.apps.cli import main

    spec = folder / "spec.toml"
    spec.write_text(spec_text(eye, lens))
    if isinstance(argv, str):
        return _run_api(argv, spec, folder)
    if "{job}" in argv:                     # batch reads a job file naming the spec
        (folder / "job.toml").write_text(BATCH_JOB)
        argv = [a.replace("{job}", str(folder / "job.toml")) for a in argv]
    else:
        argv = [argv[0], str(spec), *argv[1:]]
    args = [a.replace("{out}", str(folder)) for a in argv]
    err = io.StringIO()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            rc = main(args)
    except BaseException as e:              # noqa: BLE001 - a cell that raises is broken
        return "broken", f"{type(e).__name__}: {e}"[:200]
    lines = [x for x in err.getvalue().splitlines() if x.startswith("eyelab: error:")]
    if rc == 0:
        return "works", ""
    if rc == 2 and len(lines) == 1:          # (the cell's own folder is not the message's)
        return "refuses", lines[0].removeprefix("eyelab: error: ").replace(str(folder), "…")
    return "broken", f"exit {rc}: {err.getvalue().strip()[-200:]}"


def _run_api(name: str, spec: Path, folder: Path) -> tuple:
    """As :func:`run_cell` for a Python API cell: it works, refuses (a
    :class:`~eyelab.core.errors.SpecError`, whose one line is the CLI's) or is broken."""
    from eyelab.core.errors import SpecError

    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(
                io.StringIO()):
            _api_call(name, spec, folder)
    except SpecError as e:
        lines = str(e).splitlines()
        if len(lines) == 1:
            return "refuses", lines[0].replace(str(folder), "…")
        return "broken", f"SpecError of {len(lines)} lines: {str(e)[:200]}"
    except BaseException as e:              # noqa: BLE001 - a cell that raises is broken
        return "broken", f"{type(e).__name__}: {e}"[:200]
    return "works", ""


def matrix(eyes=None, lenses=None, commands=None, progress=None) -> dict:
    """{(eye, lens, command): (outcome, line)} over the named subsets (default: all)."""
    out = {}
    for en in eyes or EYES:
        for ln in lenses or LENSES:
            for cn in commands or COMMANDS:
                with tempfile.TemporaryDirectory() as tmp:
                    out[en, ln, cn] = run_cell(EYES[en], LENSES[ln], COMMANDS[cn], Path(tmp))
                if progress is not None:
                    progress(f"{en} | {ln} | {cn}: {out[en, ln, cn][0]}")
    return out


HEADER = """# What every command does with every eye and lens

Generated by running each cell as a user would (`python -m eyelab.apps.matrix --write
docs/guide/matrix.md`): the `eyelab` command at a tiny size (batch: a job of two cases
on the cell's spec), the Python API's `eyelab.render`, `analyze`, `maps`, `psf` and the
notebook's `eyelab.NotebookInspector`, with a spec per cell holding a point straight
ahead and one 20° down at 0.5 m. `tests/test_matrix.py` runs it and asserts that no cell
is broken and each refusal is one line naming a field. ✓ works; a number refuses, for
the reason under the table.
"""


def table(results: dict) -> str:
    """The page: per eye a table of lenses x commands, the refusals' lines numbered."""
    reasons: dict[str, int] = {}
    parts = [HEADER]
    eyes = list(dict.fromkeys(k[0] for k in results))
    lenses = list(dict.fromkeys(k[1] for k in results))
    commands = list(dict.fromkeys(k[2] for k in results))
    for en in eyes:
        parts.append(f"\n## {en}\n\n| lens | " + " | ".join(commands) + " |\n|---|"
                     + "---|" * len(commands))
        for ln in lenses:
            cells = []
            for cn in commands:
                outcome, line = results[en, ln, cn]
                if outcome == "works":
                    cells.append("✓")
                elif outcome == "refuses":
                    cells.append(str(reasons.setdefault(line, len(reasons) + 1)))
                else:
                    cells.append("**broken**")
            parts.append(f"| {ln} | " + " | ".join(cells) + " |")
    parts.append("\n## Refusals\n")
    parts.extend(f"{n}. {line.replace('|', '/')}" for line, n in reasons.items())
    return "\n".join(parts) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m eyelab.apps.matrix", description=__doc__)
    p.add_argument("--write", help="rewrite this page (docs/guide/matrix.md)")
    args = p.parse_args(argv)
    import sys

    text = table(matrix(progress=lambda s: print(s, file=sys.stderr)))
    if args.write:
        from eyelab.core.fileio import atomic_path

        with atomic_path(args.write, suffix=".md") as tmp:
            Path(tmp).write_text(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
