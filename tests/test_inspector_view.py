"""What a person sees of the inspector window: every piece of text legible and inside its
viewport at the default size and at 960 x 710 and 1280 x 800 (the text actors' and slider
texts' boxes read back from VTK); two eyes shown as ``eyelab render --binocular`` renders
them; a mesh file placed from the command line and warned about as render warns."""

import numpy as np
import pytest
import trimesh
from skimage.metrics import structural_similarity

from eyelab.jobs.inspector import InspectorModel
from eyelab.render.textlayout import MIN_GLYPH_PX, text_boxes

ONE = """
[eye]
rx = "-2.00 / -0.75 x 20"
age = 45
pupil_diameter_mm = 4.0

[lens]
rx = "-2.00 / -0.75 x 20"
material = "cr39"

[render]
scene = "chart"
width = 128
height = 96
fov_y_deg = 12.0
samples = 1
"""

TWO = """
[eye]
rx = "-2.00 DS"
age = 45
pupil_diameter_mm = 4.0

[eye.left]
rx = "-3.00 DS"

[lens]
material = "cr39"

[binocular]
pd_mm = 64
frame_pd_mm = 60

[render]
scene = "chart"
width = 96
height = 72
fov_y_deg = 12.0
samples = 2
"""


def _file(tmp_path, text, name="spec.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _problems(win) -> list:
    """Texts smaller than the minimum or reaching outside their viewport (1 px slack)."""
    bad = []
    for b in text_boxes(win.plotter.ren_win):
        x0, x1, y0, y1 = b["box"]
        v = b["viewport"]
        if b["line_px"] < MIN_GLYPH_PX:
            bad.append(("small", b["line_px"], b["text"]))
        if x0 < v[0] - 1 or x1 > v[1] + 1 or y0 < v[2] - 1 or y1 > v[3] + 1:
            bad.append(("outside", b["box"], v, b["text"]))
    return bad


@pytest.mark.parametrize("window", [None, (960, 710), (1280, 800)])
def test_every_text_is_legible_and_inside_its_viewport(tmp_path, window):
    from eyelab.render.inspector import InspectorWindow

    win = InspectorWindow(InspectorModel(_file(tmp_path, ONE)), off_screen=True,
                          window_size=window)
    try:
        win.run_to_target()
        win.plotter.render()
        boxes = text_boxes(win.plotter.ren_win)
        texts = " ".join(b["text"] for b in boxes)
        # the pieces the issue found unreadable or clipped are among those checked
        for piece in ("eye sphere (D)", "-2.00", "changed:", "blur field", "as worn"):
            assert piece in texts
        assert _problems(win) == []
        win._toggle_help()                       # the help, with the whole status
        win.plotter.render()
        assert any("h: this help" in b["text"] for b in text_boxes(win.plotter.ren_win))
        assert _problems(win) == []
    finally:
        win.close()


def test_two_eyes_show_what_render_binocular_renders(tmp_path):
    """The two-eye window's view (read back from its framebuffer) is the library's
    two-eye render of the spec the window saves; the eye sliders edit one eye or both;
    the anaglyph toggle changes the view's composition only."""
    import tomllib

    from eyelab.jobs.render import render_binocular_spec
    from eyelab.render.inspector import InspectorWindow
    from eyelab.spec import parse_spec

    win = InspectorWindow(InspectorModel(_file(tmp_path, TWO)), off_screen=True)
    m = win.model
    try:
        win.run_to_target()
        shown = win.grab_view()
        assert shown.shape == (72, 192, 3)               # side by side
        spec = parse_spec(tomllib.loads(m.dump()), "<dump>")
        ref = render_binocular_spec(spec).srgb("side-by-side")
        assert structural_similarity(shown, ref, channel_axis=2, data_range=255) >= 0.99
        assert "PD 32.0 + 32.0 mm, frame PD 60.0 mm" in win._readout
        assert "prism" in win._readout and "base" in win._readout
        # linked: both eyes move; then the left eye alone
        m.request("sphere", -1.0)
        m.run_to_target()
        assert (m.eye_rx("right").sphere, m.eye_rx("left").sphere) == (-1.0, -1.0)
        win._cycle_edit()
        win._cycle_edit()
        assert m.edit == "left"
        m.request("sphere", -4.0)
        win.run_to_target()
        assert (m.eye_rx("right").sphere, m.eye_rx("left").sphere) == (-1.0, -4.0)
        spec = parse_spec(tomllib.loads(m.dump()), "<dump>")
        assert spec.binocular.left.power_min != spec.binocular.right.power_min
        res = render_binocular_spec(spec)
        assert structural_similarity(win.grab_view(), res.srgb("side-by-side"),
                                     channel_axis=2, data_range=255) >= 0.99
        win._toggle_anaglyph()
        win.plotter.render()
        assert m.output == "anaglyph"
        assert structural_similarity(win.grab_view(), res.srgb("anaglyph"), channel_axis=2,
                                     data_range=255) >= 0.99
    finally:
        win.close()


def test_inspect_cli_two_eyes_equals_render_binocular(tmp_path):
    """``eyelab inspect --screenshot`` of a two-eye spec against ``eyelab render`` of it."""
    from PIL import Image

    from eyelab.apps.cli import main

    spec = _file(tmp_path, TWO)
    assert main(["inspect", str(spec), "--screenshot", str(tmp_path / "i.png")]) == 0
    assert main(["render", str(spec), "-o", str(tmp_path / "r.png"), "--quiet"]) == 0
    a = np.asarray(Image.open(tmp_path / "i.png").convert("RGB"))
    b = np.asarray(Image.open(tmp_path / "r.png").convert("RGB"))
    assert a.shape == b.shape == (72, 192, 3)
    assert structural_similarity(a, b, channel_axis=2, data_range=255) >= 0.99


def test_mesh_placement_flags_and_the_render_warning(tmp_path, capsys):
    from eyelab.apps.cli import main

    stl = tmp_path / "box.stl"
    trimesh.creation.box(extents=(0.5, 0.5, 0.5)).export(stl)
    spec = _file(tmp_path, ONE)
    # at the origin the eye is inside the box: the same warning as eyelab render
    shot = tmp_path / "a.png"
    assert main(["inspect", str(spec), "--mesh", str(stl), "--screenshot", str(shot)]) == 0
    err = capsys.readouterr().err
    assert "eyelab: warning: the eye is inside mesh" in err
    # placed a metre ahead: no warning, and the box fills the middle of the view
    shot = tmp_path / "b.png"
    assert main(["inspect", str(spec), "--mesh", str(stl), "--mesh-position", "0", "0", "-1",
                 "--screenshot", str(shot)]) == 0
    out = capsys.readouterr()
    assert "warning" not in out.err and shot.is_file()
    assert 'position_m = [ 0.0, 0.0, -1.0,]' in shot.with_suffix(".toml").read_text() or \
        "-1.0" in shot.with_suffix(".toml").read_text()
    # bad placement: one line naming the flag, exit 2, nothing written
    bad = tmp_path / "c.png"
    assert main(["inspect", str(spec), "--mesh", str(stl), "--mesh-scale", "-2",
                 "--screenshot", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "--mesh-scale" in err and len(err.strip().splitlines()) == 1
    assert not bad.exists()
    assert main(["inspect", str(spec), "--mesh-scale", "2", "--screenshot", str(bad)]) == 2
    assert "only with --mesh" in capsys.readouterr().err
    assert main(["inspect", str(spec), "--window", "100x100", "--screenshot", str(bad)]) == 2
    assert "--window" in capsys.readouterr().err
