"""The inspector: its model driven through its controls, its window offscreen, the
``eyelab inspect --screenshot`` command, and a real window under Xvfb."""

import os
import signal
import subprocess
import sys
import time
import tomllib

import numpy as np
import pytest
from skimage.metrics import structural_similarity
from xvfb import needs_xvfb, xvfb_env

from eyelab.jobs.inspector import InspectorModel
from eyelab.jobs.render import render_spec
from eyelab.spec import load_spec, parse_spec

SPEC = """
[eye]
rx = "-2.00 DS"
age = 45
pupil_diameter_mm = 4.0

[lens]
rx = "-2.00 DS"
material = "cr39"

[render]
scene = "chart"
width = 128
height = 96
fov_y_deg = 12.0
near_m = 0.5
far_m = 20.0
samples = 6
"""


@pytest.fixture
def spec_file(tmp_path):
    p = tmp_path / "spec.toml"
    p.write_text(SPEC)
    return p


def _ssim(a, b):
    return structural_similarity(a, b, channel_axis=2, data_range=255)


def _library_render(model):
    """The library's offscreen render of the spec the model would save."""
    spec = parse_spec(tomllib.loads(model.dump()), "<dump>")
    return render_spec(spec).srgb


def _sharpness(img):
    g = img.astype(float).mean(axis=2)
    return float(np.mean(np.abs(np.diff(g, axis=0))) + np.mean(np.abs(np.diff(g, axis=1))))


def test_controls_change_the_view_as_the_library_renders_it(spec_file):
    """Raising the myopia blurs the chart (lens off: more than with the lens), toggling the
    lens and every state's image equals the library's render of the spec it would save."""
    m = InspectorModel(spec_file)
    try:
        m.run_to_target()
        assert _ssim(m.display(), _library_render(m)) >= 0.99
        corrected = _sharpness(m.display())
        m.apply({"lens": False})
        m.run_to_target()
        uncorrected = _sharpness(m.display())
        assert "lens" not in tomllib.loads(m.dump())
        assert _ssim(m.display(), _library_render(m)) >= 0.99
        m.apply({"sphere": -4.0})
        m.run_to_target()
        assert tomllib.loads(m.dump())["eye"]["rx"].startswith("-4.00")
        more = _sharpness(m.display())
        assert corrected > uncorrected > more
        assert _ssim(m.display(), _library_render(m)) >= 0.99
    finally:
        m.close()


def test_blur_at_the_chart_follows_analyze(spec_file):
    """After raising the myopia (lens off, one wavelength) the blur field the view was
    rendered with gives, at the chart's centre, the blur analyze computes there (same
    eye model: pupil fixed at the origin), to the field's interpolation (2 %)."""
    from eyelab.optics.chain.analysis import analyze_points
    from eyelab.optics.rays.paths import ObjectPoints

    m = InspectorModel(spec_file)
    try:
        for sph in (-3.0, -5.0):
            m.apply({"lens": False, "chromatic": False, "sphere": sph})
            m.run_to_target()
            cache = m.renderer.caches["fields"]
            field = cache.get(list(cache.keys())[-1])
            p = np.array([[0.0, 0.0, -6.0]])              # the chart's centre (6 m)
            got = float(field.sample(field.major_arcmin[..., None], p)[0, 0])
            pa = analyze_points(m.spec.eye, None, ObjectPoints.from_positions(p))
            want = float(pa.to_arcmin(pa.blur_axes()[0])[0])
            assert got == pytest.approx(want, rel=0.02), (sph, got, want)
    finally:
        m.close()


def test_samples_change_reruns_passes_only_and_cvd_is_display_only(spec_file):
    m = InspectorModel(spec_file)
    try:
        m.run_to_target()
        m.apply({"samples": 12})
        m.run_to_target()
        misses = m.result.report["cache"]["misses"]
        assert not [k for k in misses if k.startswith(("field", "lens_", "refined",
                                                       "virtual"))], misses
        assert m.result.report["samples"]["done_passes"] == 12
        before = m.display().copy()
        m.request("cvd", "deutan")
        assert m.tick() is True and m.done            # nothing restarted
        assert m.last_change.endswith("display only")
        assert not np.array_equal(before, m.display())
        assert tomllib.loads(m.dump())["render"]["cvd"] == "deutan"
    finally:
        m.close()


def test_coalesced_requests_and_refused_values(spec_file):
    m = InspectorModel(spec_file)
    try:
        m.run_to_target()
        for v in np.linspace(-2.0, -3.5, 25):          # a dragged slider: one restart
            m.request("sphere", v)
        m.tick()
        assert m.last_change == "sphere"
        assert m.eye_rx().sphere == -3.5
        m.run_to_target()
        rx = m.eye_rx()
        assert m.apply({"pupil_mm": 42.0}) is not None
        assert "eye.pupil_diameter_mm" in m.message
        assert m.eye_rx() == rx and m.value("pupil_mm") == pytest.approx(4.0)
    finally:
        m.close()


def test_gaze_and_save_reproduce_the_view(spec_file, tmp_path):
    """The gaze control reaches the view (the saved spec has it) and the saved pair (PNG,
    TOML) renders back to the same image."""
    m = InspectorModel(spec_file)
    try:
        m.apply({"gaze": (0.0, -4.0)})
        m.run_to_target()
        png, toml = m.save(tmp_path / "shot.png")
        data = tomllib.loads(toml.read_text())
        assert data["render"]["gaze_deg"] == [0.0, -4.0]
        import matplotlib.image as mpimg

        saved = (mpimg.imread(png)[..., :3] * 255).round().astype(np.uint8)
        again = render_spec(load_spec(toml)).srgb
        assert _ssim(saved, again) >= 0.99
        m.apply({"gaze": (0.0, 0.0)})
        m.run_to_target()
        assert _ssim(saved, m.display()) < 0.99          # the view did move
    finally:
        m.close()


def test_window_offscreen_shows_the_model_image(spec_file):
    """The window's simulated view (read back from its framebuffer) is the model's image;
    arrow keys turn the gaze."""
    from eyelab.render.inspector import InspectorWindow

    win = InspectorWindow(InspectorModel(spec_file), off_screen=True)
    try:
        win.run_to_target()
        shown = win.grab_view()
        assert shown.shape == win.model.display().shape
        assert _ssim(shown, win.model.display()) >= 0.99
        win._turn(2.0, 0.0)
        win.run_to_target()
        assert win.model.value("gaze") == (2.0, 0.0)
        assert _ssim(win.grab_view(), _library_render(win.model)) >= 0.99
    finally:
        win.close()


def test_cli_screenshot_and_errors(spec_file, tmp_path, capsys):
    from eyelab.apps.cli import main

    out = tmp_path / "v.png"
    assert main(["inspect", str(spec_file), "--screenshot", str(out), "--samples", "2"]) == 0
    assert out.is_file() and out.with_suffix(".toml").is_file()
    assert main(["inspect", str(spec_file), "--screenshot", str(tmp_path / "w.png"),
                 "--size", "9x9"]) == 2
    assert "--size" in capsys.readouterr().err
    assert not (tmp_path / "w.png").exists()


def test_bench_inspect_small():
    from eyelab.bench.inspector import run_inspect_bench

    res = run_inspect_bench(160, 120, 2, examples=False)
    kinds = {r["kind"] for r in res["rows"]}
    assert {"eye, no lens in view", "eye, through the lens", "samples"} <= kinds
    for r in res["rows"]:
        assert 0 < r["first_frame_s"] <= r["to_target_s"]
    assert [r for r in res["rows"] if r["kind"] == "samples"][0]["recomputed"] == \
        "passes only"


@needs_xvfb
def test_real_window_under_xvfb(tmp_path):
    """``eyelab inspect SPEC --screenshot`` with a display (Xvfb): a real window for an
    uncorrected and a corrected myope; the images are not blank, differ as the renders
    do, and equal the offscreen renders of the same specs."""
    shots = {}
    with xvfb_env() as env:
        for name, lens in (("uncorrected", ""), ("corrected", '[lens]\nrx = "-2.00 DS"\n')):
            spec = tmp_path / f"{name}.toml"
            spec.write_text(SPEC.replace('[lens]\nrx = "-2.00 DS"\nmaterial = "cr39"\n',
                                         lens))
            png = tmp_path / f"{name}.png"
            r = subprocess.run([sys.executable, "-P", "-m", "eyelab.apps.cli", "inspect",
                                str(spec), "--screenshot", str(png)], env=env,
                               capture_output=True, text=True, timeout=300)
            assert r.returncode == 0, r.stderr[-2000:]
            import matplotlib.image as mpimg

            shots[name] = (mpimg.imread(png)[..., :3] * 255).round().astype(np.uint8)
            assert shots[name].std() > 10                        # not blank
            ref = render_spec(load_spec(spec)).srgb
            assert _ssim(shots[name], ref) >= 0.99
    assert _sharpness(shots["corrected"]) > 1.2 * _sharpness(shots["uncorrected"])


def test_a_mesh_file_and_a_click_in_the_view(tmp_path, spec_file):
    """``--mesh`` puts a mesh file in the scene (the saved spec names it); a left click in
    the simulated view turns the gaze toward the clicked pixel (right of centre: right)."""
    import trimesh

    from eyelab.render.inspector import InspectorWindow

    mesh = tmp_path / "box.ply"
    box = trimesh.creation.box(extents=(0.5, 0.5, 0.5))
    box.apply_translation((0.0, 0.0, -3.0))
    box.export(mesh)
    win = InspectorWindow(InspectorModel(spec_file, scene=mesh, samples=1), off_screen=True)
    try:
        win.run_to_target()
        assert tomllib.loads(win.model.dump())["render"]["scene"] == str(mesh.resolve())
        assert win.model.display().std() > 5                      # the box is seen
        vx, vy = win._view_renderer.GetOrigin()
        vw, vh = win._view_renderer.GetSize()
        win.plotter.iren.get_event_position = lambda: (vx + 3 * vw // 4, vy + vh // 2)
        win._on_click(None, "LeftButtonPressEvent")
        win.run_to_target()
        right, up = win.model.value("gaze")
        fov = win.model.view.fov_y_deg
        assert 0 < right < fov and abs(up) < 0.5
    finally:
        win.close()


# ------------------------------------------------------------------ the as-worn map view
FRAME = """
[frame]
shape = "oval"
box_mm = [40, 30]
dbl_mm = 18
monocular_pd_mm = 29
fitting_height_mm = 15
"""
NAKED = SPEC.replace('[lens]\nrx = "-2.00 DS"\nmaterial = "cr39"\n', "")


def test_as_worn_maps_and_the_gaze_marker(spec_file):
    """The model's maps are eyelab.optics.lens.asworn's over +-40 deg; the marker sits at the
    gaze's Fick angles with the maps' values there (the grid's own value on a grid point,
    the engine's at that eye rotation elsewhere, to the interpolation); they are computed
    after a change's first frame, once per lens (not per gaze), and kept."""
    from eyelab.jobs.gazemaps import MAP_HALF_ANGLE_DEG, MAP_POINTS
    from eyelab.optics.lens.asworn import as_worn_maps

    m = InspectorModel(spec_file, samples=1)
    try:
        m.run_to_target()
        m.wait_maps()
        maps = m.maps()
        assert m.maps_state() == "ready" and m.gaze_maps.computed == 1
        assert maps.mean_error_d.shape == (MAP_POINTS, MAP_POINTS)
        assert maps.eye_rotation_x_deg[-1] == MAP_HALF_ANGLE_DEG
        ref = as_worn_maps(m.spec.eye, m.lens, half_angle_deg=MAP_HALF_ANGLE_DEG,
                           n=MAP_POINTS, wavelength_nm=m.spec.wavelength_nm)
        np.testing.assert_allclose(maps.cylinder_d, ref.cylinder_d, atol=1e-12)
        m.apply({"gaze": (12.0, 4.0)})                   # a grid point (4 deg steps)
        m.run_to_target()
        mk = m.gaze_marker()
        assert mk["eye_rotation_deg"] == (12.0, 4.0)
        i, j = np.searchsorted(maps.eye_rotation_x_deg, 12.0), \
            np.searchsorted(maps.eye_rotation_y_deg, 4.0)
        assert mk["mean_error_d"] == pytest.approx(maps.mean_error_d[j, i], abs=1e-12)
        assert mk["cylinder_d"] == pytest.approx(maps.cylinder_d[j, i], abs=1e-12)
        m.apply({"gaze": (10.0, -6.0)})                  # between grid points
        m.run_to_target()
        mk = m.gaze_marker()
        at = as_worn_maps(m.spec.eye, m.lens, half_angle_deg=10.0, n=11,
                          wavelength_nm=m.spec.wavelength_nm)      # (10, -6): [2, 10]
        assert mk["eye_rotation_deg"] == (10.0, -6.0)
        assert mk["mean_error_d"] == pytest.approx(at.mean_error_d[2, 10], abs=0.005)
        assert mk["cylinder_d"] == pytest.approx(at.cylinder_d[2, 10], abs=0.005)
        assert abs(at.cylinder_d[2, 10]) > 0.005                   # not a trivial 0
        m.wait_maps()
        assert m.gaze_maps.computed == 1 and m.maps() is maps     # the gaze reuses them
        # a new lens: its first frame comes before its maps are even started
        m.apply({"lens_rx": "-3.00 DS"})
        while not m.tick():             # its coarse field on the worker, then the preview
            pass
        assert m.result.report["samples"]["done_passes"] == 0
        assert m.maps() is None and not m.gaze_maps.busy and m.gaze_marker() is None
        m.run_to_target()
        m.wait_maps()
        assert m.gaze_maps.computed == 2 and m.maps() is not maps
        m.apply({"lens": False})
        assert not m.maps_wanted and m.maps_state() == "none"
        m.apply({"lens": True})
        assert m.maps() is not None and m.gaze_maps.computed == 2   # kept
    finally:
        m.close()


def _marker_px(shot, ren):
    """(x, y) centroid (px; y down) of the marker's pure-green pixels in renderer ren's
    viewport of the window screenshot ``shot``, or None."""
    (vx, vy), (vw, vh) = ren.GetOrigin(), ren.GetSize()
    H = shot.shape[0]
    g = np.zeros(shot.shape[:2], bool)
    sub = shot[H - vy - vh:H - vy, vx:vx + vw]
    g[H - vy - vh:H - vy, vx:vx + vw] = (sub[..., 0] == 0) & (sub[..., 1] == 255) & \
        (sub[..., 2] == 0)
    ys, xs = np.nonzero(g)
    return None if len(xs) < 10 else (xs.mean(), ys.mean())


def test_window_map_panel_follows_the_gaze(tmp_path):
    """With a lens cut to a frame the window shows the maps (the frame's outline as their
    edge) and the marker; the marker moves right / up with the gaze without the maps being
    recomputed or redrawn; ``m`` hides the panel (the side views take its room)."""
    from eyelab.render.inspector import InspectorWindow

    spec = tmp_path / "framed.toml"
    spec.write_text(SPEC + FRAME)
    win = InspectorWindow(InspectorModel(spec, size=(96, 320), samples=1), off_screen=True)
    try:
        win.run_to_target()
        panel = win._maps
        ren = panel.renderers["mean_error_d"]
        x0 = ren.GetOrigin()[0]
        assert panel.shown and panel.draws == 1
        assert "map_edge_mean_error_d" in panel.renderers["mean_error_d"].actors
        assert np.isnan(win.model.maps().mean_error_d[0, 0])     # outside the frame

        def shot():
            win.plotter.render()
            return win.plotter.screenshot(return_img=True)[..., :3]

        first = shot()
        assert first[:, x0:].std() > 20                          # a map, not a blank
        p0 = _marker_px(first, ren)
        H = first.shape[0]
        assert p0 is not None
        want = panel.marker_display()
        assert abs(p0[0] - want[0]) < 1.5 and abs(p0[1] - (H - want[1])) < 1.5
        moves = panel.marker_moves
        win._request("gaze", (6.0, 0.0))           # the chart stays in view
        win.run_to_target()
        p1 = _marker_px(shot(), ren)
        win._request("gaze", (6.0, 6.0))
        win.run_to_target()
        p2 = _marker_px(shot(), ren)
        assert p1[0] - p0[0] > 5 and abs(p1[1] - p0[1]) < 1.5     # right
        assert p1[1] - p2[1] > 5 and abs(p2[0] - p1[0]) < 1.5     # up (rows grow down)
        want = panel.marker_display()
        assert abs(p2[0] - want[0]) < 1.5 and abs(p2[1] - (H - want[1])) < 1.5
        assert panel.draws == 1 and panel.marker_moves == moves + 2
        assert win.model.gaze_maps.computed == 1
        x, y = panel.display_point(-4.0, 2.0, "cylinder_d")     # a click on a map: look there
        win.plotter.iren.get_event_position = lambda: (int(round(x)), int(round(y)))
        win._on_click(None, "LeftButtonPressEvent")
        win.run_to_target()
        assert win.model.value("gaze") == pytest.approx((-4.0, 2.0), abs=0.5)
        win._toggle_maps()
        win.run_to_target()
        assert not panel.shown and _marker_px(shot(), ren) is None
        side = win.plotter.renderers[win.plotter.renderers.loc_to_index((0, 1))]
        assert side.GetViewport()[2] == 1.0
    finally:
        win.close()


def test_window_without_a_lens_has_no_map_panel(tmp_path):
    """A naked eye: no maps computed, no panel drawn (no marker in its cells, which the
    side views cover)."""
    from eyelab.render.inspector import InspectorWindow

    spec = tmp_path / "naked.toml"
    spec.write_text(NAKED)
    win = InspectorWindow(InspectorModel(spec, size=(192, 256), samples=1), off_screen=True)
    try:
        win.run_to_target()
        win.plotter.render()
        assert "lens" not in win.model.data
        assert not win._maps.shown and win.model.maps() is None
        shot = win.plotter.screenshot(return_img=True)[..., :3]
        for ren in win._maps.renderers.values():
            assert _marker_px(shot, ren) is None
        assert win.model.gaze_maps.computed == 0
    finally:
        win.close()


@needs_xvfb
@pytest.mark.parametrize("signum,code,word", [(signal.SIGINT, 130, "interrupted"),
                                              (signal.SIGTERM, 143, "terminated")])
def test_the_live_window_ends_on_ctrl_c_and_sigterm_like_every_command(tmp_path, signum,
                                                                       code, word):
    """A real window in its event loop: Ctrl-C or SIGTERM ends it with the one line and
    the status every command gives (not VTK's own exit 1, not a traceback)."""
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    with xvfb_env() as env:
        proc = subprocess.Popen([sys.executable, "-P", "-m", "eyelab.apps.cli", "inspect",
                                 str(spec), "--size", "160x120", "--samples", "2"], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(15)                  # the window open, its frames done: the event loop
        assert proc.poll() is None, proc.communicate()[1][-2000:]
        proc.send_signal(signum)
        try:
            out, err = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise AssertionError(f"the window did not end on {signum.name}") from None
    assert proc.returncode == code, err[-2000:]
    assert err.strip().splitlines()[-1] == f"eyelab: {word}", err[-2000:]
    assert "Traceback" not in err and "Caught a Ctrl-C" not in out + err


PROBE_THEN_REOPEN = """
import ctypes, ctypes.util, sys
from eyelab.render import display_error
assert display_error() is None
x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
x11.XOpenDisplay.restype = ctypes.c_void_p
x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
for i in range(200):
    handle = x11.XOpenDisplay(sys.argv[1].encode())
    if not handle:
        sys.exit(f"open {i} failed")
    x11.XCloseDisplay(handle)
"""


@needs_xvfb
def test_the_display_probe_leaves_a_bare_x_server_steady():
    """The probe that names an unreachable display keeps its connection: a bare Xvfb
    resets when its last client leaves, and the window opened next would fail ("bad X
    server connection", then an event loop that returns at once with status 0). With the
    probe's connection closed, one of the 200 opens that follow fails on every try."""
    with xvfb_env() as env:
        run = subprocess.run([sys.executable, "-P", "-c", PROBE_THEN_REOPEN, env["DISPLAY"]],
                             env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]


SHOW_WITHOUT_DISPLAY = """
import sys
from eyelab.core.errors import SpecError
from eyelab.jobs.inspector import InspectorModel
from eyelab.render.inspector import InspectorWindow
win = InspectorWindow(InspectorModel(sys.argv[1], size=(64, 48), samples=1), off_screen=False)
try:
    win.show()
except SpecError as e:
    print(e)
finally:
    win.close()
"""


def test_a_window_vtk_could_not_open_is_one_line_not_status_0(tmp_path):
    """A display that answered the probe but refuses VTK's connection (here: none at
    all, the probe bypassed): VTK falls back to an offscreen window whose event loop
    returns at once. ``show`` says so in the inspector's one line instead."""
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    env = {k: v for k, v in os.environ.items()
           if k not in ("VTK_DEFAULT_OPENGL_WINDOW", "WAYLAND_DISPLAY")}
    env["DISPLAY"] = ":77"
    run = subprocess.run([sys.executable, "-P", "-c", SHOW_WITHOUT_DISPLAY, str(spec)],
                         env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    line = run.stdout.strip()
    assert line.startswith("inspect: cannot open a window on display :77 (VTK made a vtk"), line
    assert line.endswith("; use --screenshot FILE or --offscreen, or run under xvfb-run"), line


class _Window:
    """A stand-in for an initialised VTK render window: its class and its X display."""

    def __init__(self, cls, display):
        self.cls, self.display = cls, display

    def IsA(self, name):
        return name == self.cls

    def GetGenericDisplayId(self):
        return self.display

    def GetClassName(self):
        return self.cls


def test_a_window_without_its_display_is_named(monkeypatch):
    """An X window with its display is fine; one VTK made offscreen instead says which
    display it missed, or that there was none (Wayland alone: VTK's windows need X)."""
    from eyelab.render import window_error

    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("DISPLAY", ":3")
    assert window_error(_Window("vtkXOpenGLRenderWindow", "_0x1_p_void")) is None
    assert window_error(_Window("vtkXOpenGLRenderWindow", None)) == (
        "cannot open a window on display :3 (VTK made a vtkXOpenGLRenderWindow)")
    monkeypatch.delenv("DISPLAY")
    assert window_error(_Window("vtkEGLRenderWindow", "_0x1_p_void")) == (
        "cannot open a window without an X display (DISPLAY is not set) "
        "(VTK made a vtkEGLRenderWindow)")


def test_what_a_change_recomputed_is_said_in_words():
    from eyelab.jobs.inspector import recomputed_words

    names = ["field_through_lens_486.13nm", "field_through_lens_546.07nm", "lens_texcoords",
             "compensated_fields", "reconstruction_sigma", "refined_floor",
             "refined_chart_row_+0.1", "prefiltered_chart_board", "something_new"]
    assert recomputed_words(names) == (
        "blur field through the lens (2 fields), rays through the lens, reconstruction "
        "filter, mesh refinement (2 meshes), texture prefiltering, something new")
    assert recomputed_words([]) == "passes only"


def test_the_blur_field_panel_says_which_depth_it_shows():
    from eyelab.render.sideviews import field_title

    assert field_title(None, 4.09, 6.0, 546.07) == "blur field at 4.09 m (gaze 6.00 m; 546 nm)"
    assert field_title("right", 6.05, 6.0, 546.07) == (
        "blur field at 6.05 m (right eye, gaze point; 546 nm)")
    assert field_title(None, 90.0, None, 587.56) == (
        "blur field at 90.00 m (farthest slice; 588 nm)")
