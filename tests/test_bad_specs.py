"""The generated bad-spec corpus (``tests/badspecs.py``, > 1000 cases across every field):
each case exits 2 with one line naming the offending field, no traceback, nothing written."""

from __future__ import annotations

import os

import pytest
from badspecs import COMMAND_LINES, HINTS, corpus, to_toml

from eyelab.apps.cli import main

CASES = corpus()


def test_the_corpus_is_large_and_covers_every_table():
    assert len(CASES) >= 500
    fields = {f for _, _, f in CASES}
    for table in ("eye", "lens", "lens.front", "lens.back", "lens.material", "analysis",
                  "points[0]", "render", "spec", "binocular", "eye.right", "eye.left",
                  "lens.right", "lens.left", "render.camera", "render.camera_focus_m",
                  "render.camera_f_number", "render.gaze_deg", "lens.corridor_mm",
                  "lens.inset_mm", "lens.softness_mm", "lens.design", "lens.diameter_mm"):
        assert any(f == table or f.startswith(table + ".") for f in fields), table


def _run(argv, capsys):
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    return rc, err


def test_every_bad_spec_is_one_named_line_and_writes_nothing(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    failures = []
    for i, (name, data, field) in enumerate(CASES):
        spec.write_bytes(data)
        # render (PNG + report) and demo (PNG + JSON), alternately: both must stop first
        argv = (["render", str(spec), "-o", str(tmp_path / "r.png"), "--report",
                 str(tmp_path / "r.json")] if i % 2 else
                ["demo", str(spec), "-o", str(tmp_path / "d.png")])
        rc, err = _run(argv, capsys)
        left = sorted(set(os.listdir(tmp_path)) - {"s.toml"})
        if not (rc == 2 and len(err.splitlines()) == 1
                and err.startswith(f"eyelab: error: {field}") and not left):
            failures.append(f"{name}: rc={rc} written={left} {err[:200]!r}")
    assert not failures, f"{len(failures)} of {len(CASES)}:\n" + "\n".join(failures[:20])


def test_analyze_reads_the_same_corpus(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    out = tmp_path / "a.json"
    for name, data, field in CASES[::7]:
        spec.write_bytes(data)
        rc, err = _run(["analyze", str(spec), "-o", str(out)], capsys)
        assert rc == 2 and err.startswith(f"eyelab: error: {field}"), (name, err)
        assert not out.exists()


@pytest.mark.parametrize("name, spec, field, hint", HINTS, ids=[h[0] for h in HINTS])
def test_a_near_miss_says_what_was_meant(tmp_path, capsys, name, spec, field, hint):
    """A number for a material, a design's other name, an add or a side where the spec
    spells it otherwise, an Rx the eye cannot take: the one line names the field and says
    what to write (or what is allowed)."""
    path = tmp_path / "s.toml"
    path.write_text(to_toml(spec))
    rc, err = _run(["analyze", str(path)], capsys)
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"eyelab: error: {field}") and hint in err, err


def _command(argv, spec, tmp_path, capsys):
    """``eyelab <argv[0]> spec -o <out> <argv[1:]>`` run in ``tmp_path``: (rc, the message
    after "error: ", what it left beside the spec)."""
    cmd, *flags = argv
    out = {"maps": "m.png", "render": "r.png", "analyze": "a.json"}[cmd]
    try:
        rc = main([cmd, str(spec), "-o", out, *flags])
    except SystemExit as e:            # argparse's own errors
        rc = e.code
    err = capsys.readouterr().err.strip()
    left = sorted(set(os.listdir(tmp_path)) - {spec.name})
    return rc, err, left


@pytest.mark.parametrize("name, spec, argv, field, flag", COMMAND_LINES,
                         ids=[c[0] for c in COMMAND_LINES])
def test_bad_command_line_values_are_one_named_line(tmp_path, capsys, monkeypatch, name,
                                                    spec, argv, field, flag):
    """maps' flags, and render's with a camera: exit 2, one line naming the value (the
    field, or the flag with its field), nothing written."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "s.toml"
    path.write_text(to_toml(spec))
    rc, err, left = _command(argv, path, tmp_path, capsys)
    msg = err.partition("error: ")[2]
    assert rc == 2 and len(err.splitlines()) == 1 and not left, (rc, err, left)
    assert msg.startswith((field, f"{flag} ({field})", f"argument {field}")), err


FLAG_NAMED = [c for c in COMMAND_LINES if c[3] != c[4]]


@pytest.mark.parametrize("name, spec, argv, field, flag", FLAG_NAMED,
                         ids=[c[0] for c in FLAG_NAMED])
def test_maps_errors_name_the_flags(tmp_path, capsys, monkeypatch, name, spec, argv, field,
                                    flag):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "s.toml"
    path.write_text(to_toml(spec))
    _, err, _ = _command(argv, path, tmp_path, capsys)
    assert err.startswith(f"eyelab: error: {flag} ({field})"), err


def test_the_maps_job_names_the_flags():
    """What ``eyelab maps`` calls (:func:`eyelab.jobs.maps.cli_maps`) names its flags;
    the Python API keeps its own argument names."""
    import eyelab
    from eyelab.core.errors import SpecError
    from eyelab.jobs.maps import cli_maps
    from eyelab.spec import parse_spec

    s = parse_spec({"lens": {"rx": "-1.00"}})
    for kw, name in ((dict(half_angle_deg=61.0), "--half-angle (maps.half_angle_deg)"),
                     (dict(n=2), "--points (maps.n)")):
        with pytest.raises(SpecError) as e:
            cli_maps(s.eye, s.lens, **kw)
        assert e.value.field == name
    with pytest.raises(SpecError) as e:
        eyelab.maps(s, half_angle_deg=61.0)
    assert e.value.field == "maps.half_angle_deg"


@pytest.mark.parametrize("argv, field", [
    (["--width", "0"], "render.width"),
    (["--width", "99999"], "render.width"),
    (["--width", "16", "--height", "4096"], "render.width"),
    (["--samples", "0"], "render.samples"),
    (["--samples", "100000"], "render.samples"),
    (["--renderer", "reference", "--samples", "0"], "render.samples"),
    (["--gaze", "90", "0"], "render.gaze_deg[0]"),
    (["--gaze", "nan", "0"], "render.gaze_deg[0]"),
    (["--width", "abc"], "--width"),
    (["--renderer", "banana"], "--renderer"),
    (["--no-such-flag"], "unrecognized arguments"),
])
def test_bad_command_lines_are_one_line(tmp_path, capsys, argv, field):
    out = tmp_path / "o.png"
    try:
        rc = main(["render", "-o", str(out), *argv])
    except SystemExit as e:            # argparse's own errors
        rc = e.code
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and field in err, err
    assert not out.exists()


def test_values_at_the_documented_limits_are_accepted(tmp_path, capsys):
    """The corpus refuses just outside the ranges; these just inside are read (age 0 gives
    Hofstetter's 18.5 D, which once overflowed the amplitude's range)."""
    from eyelab.spec import parse_spec

    spec = parse_spec({"eye": {"age": 0, "accommodation_d": 25}, "render": {"far_m": 1e5}})
    assert spec.eye.accommodation_max == pytest.approx(18.5)
    parse_spec({"eye": {"age": 0, "amplitude_model": "max"}})
    parse_spec({"lens": {"rx": "-2.00", "material": {"n_d": 1.5, "v_d": "inf"}}})
    parse_spec({"eye": {"rx": "-2.00", "kind": "axial", "vertex_distance_mm": 14}})


def test_an_unknown_key_suggests_the_nearest_valid_name():
    from eyelab.core.errors import SpecError
    from eyelab.spec import parse_spec

    for data, near in (({"eye": {"agee": 40}}, "'age'"), ({"Lens": {}}, "'lens'"),
                       ({"render": {"sampels": 4}}, "'samples'")):
        with pytest.raises(SpecError, match=f"did you mean {near}"):
            parse_spec(data)
