"""As-worn maps against real-ray pencils through the posed lens, and `eyelab maps`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.lens.asworn import as_worn_maps, object_vergence
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.reference.bruteforce import extrapolated_vergence
from eyelab.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("spec_path", [None, "docs/gallery/pal.toml"])
def test_map_values_agree_with_real_ray_pencils(spec_path):
    """At 25 eye rotations of the default (tilted) lens and of the progressive lens, the
    map's mean power error and cylinder equal those of the wave measured by real-ray
    pencils (Richardson-extrapolated bundle fits) on the vertex sphere, less the object's
    vergence and the Rx (with the add the object's vergence calls for), to 1e-3 D."""
    spec = load_spec(None if spec_path is None else ROOT / spec_path)
    eye, lens = spec.eye, spec.lens
    maps = as_worn_maps(eye, lens, half_angle_deg=30.0, n=5)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    r_vs = lens.pose.vertex_distance + eye.rotation_centre
    f = lens.rx.distance().power_matrix()
    checked = 0
    for j, gy in enumerate(maps.eye_rotation_y_deg):
        for i, _ in enumerate(maps.eye_rotation_x_deg):
            k = j * len(maps.eye_rotation_x_deg) + i
            vg = float(object_vergence(gy))
            obj = ObjectPoints(maps.objects.direction[[k]], maps.objects.distance[[k]])
            assert bool(obj.finite[0]) == (vg > 0)
            res = analyze_points(eye, lens, obj, fixation="rotating")
            # the vertex-sphere point: the exit ray meets the sphere (centre of rotation)
            q, n_out = res.chief.exit[0], res.chief.dir_out[0]
            rel = q - cor
            b = rel @ n_out
            s = -b - np.sqrt(b * b - (rel @ rel - r_vs ** 2))
            vs_point = q + s * n_out
            (kxx, kxy, kyy), _ = extrapolated_vergence(
                lens, res.chief.start[0], res.chief.dir_in[0], bool(vg > 0), vs_point, n_out,
                res.eye_x[0])
            o = -1.0 / np.linalg.norm(obj.positions()[0] - vs_point) if vg > 0 else 0.0
            add = lens.rx.add * vg / 2.5
            e = np.array([[kxx - o, kxy], [kxy, kyy - o]]) - f - add * np.eye(2)
            w = np.linalg.eigvalsh(e)
            assert maps.mean_error_d[j, i] == pytest.approx(w.mean(), abs=1e-3)
            assert maps.cylinder_d[j, i] == pytest.approx(w[0] - w[1], abs=1e-3)
            checked += 1
    assert checked >= 20


@pytest.mark.parametrize("rotation", [(0.0, -30.0), (20.0, 15.0), (-25.0, -10.0)])
def test_the_grid_is_over_eye_rotations(rotation):
    """Through a -6 D lens, the map's grid point (a, e) is the eye turned by the Fick angles
    (a, e) about its centre of rotation: the chief ray that path finding (Newton from the
    object, not the map's outward trace) finds to the map's object reaches the centre of
    rotation along the line of sight (cos e sin a, sin e, -cos e cos a) — at (0, -30) 30 deg
    from the primary line of sight — and the object lies beyond the lens's prism there:
    farther out than the line of sight by the prism a focimeter reads on that line."""
    from eyelab.optics.chain.binocular import line_of_sight_prism
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.lens.spectacle import SpectacleLens

    eye, lens = Eye(), SpectacleLens.from_rx(Prescription(-6.0))
    half = 30.0
    maps = as_worn_maps(eye, lens, half_angle_deg=half, n=13)
    i = int(np.argmin(np.abs(maps.eye_rotation_x_deg - rotation[0])))
    j = int(np.argmin(np.abs(maps.eye_rotation_y_deg - rotation[1])))
    assert (maps.eye_rotation_x_deg[i], maps.eye_rotation_y_deg[j]) == pytest.approx(rotation)
    k = j * len(maps.eye_rotation_x_deg) + i
    obj = ObjectPoints(maps.objects.direction[[k]], maps.objects.distance[[k]])
    res = analyze_points(eye, lens, obj, fixation="rotating")
    assert res.ok[0]
    a, e = np.radians(rotation)
    want = np.array([np.cos(e) * np.sin(a), np.sin(e), -np.cos(e) * np.cos(a)])
    los = -res.chief.dir_out[0]                     # from the centre of rotation outward
    np.testing.assert_allclose(los, want, atol=1e-9)
    primary = np.array([0.0, 0.0, -1.0])
    turned = np.degrees(np.arccos(los @ primary))
    assert turned == pytest.approx(np.degrees(np.arccos(want @ primary)), abs=1e-6)
    if rotation == (0.0, -30.0):
        assert turned == pytest.approx(30.0, abs=1e-6)
    # the object seen there: beyond the line of sight by the lens's prism on that line
    prism, _, ok = line_of_sight_prism(eye, lens, ObjectPoints(want[None], np.array([np.inf])))
    assert ok[0] and maps.prism_d[j, i] == pytest.approx(prism[0], rel=1e-6)
    d_in = -res.chief.dir_in[0]                     # toward the object, before the lens
    bend = np.degrees(np.arccos(np.clip(d_in @ los, -1.0, 1.0)))
    assert bend == pytest.approx(np.degrees(np.arctan(prism[0] / 100.0)), abs=1e-6)
    assert np.degrees(np.arccos(d_in @ primary)) > turned     # a minus lens: farther out


def test_marks_are_the_eye_rotations_that_look_through_the_reference_points():
    """A progressive lens's marks: the eye turned by each mark's Fick angles looks through
    that point — its line of sight, traced out through the lens, leaves the front surface
    there (to 1e-6 m)."""
    from eyelab.optics.lens.asworn import fick_lines

    spec = load_spec(ROOT / "docs" / "gallery" / "pal.toml")
    eye, lens = spec.eye, spec.lens
    maps = as_worn_maps(eye, lens, n=3)
    front, _ = lens.placed_surfaces()
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    for name, (x, y) in (("fitting cross", (0.0, 0.0)),
                         ("distance reference", lens.design.distance_point),
                         ("near reference", lens.design.near_point)):
        line = fick_lines(*maps.marks[name])
        out = lens.trace(cor[None], line, reverse=True)["out_points"][0]
        sag = float(front.surface.sag(np.array([x]), np.array([y]))[0])
        want = np.asarray(front.rotation) @ np.array([x, y, sag]) + np.asarray(front.translation)
        np.testing.assert_allclose(out, want, atol=1e-6, err_msg=name)
    assert maps.marks["near reference"][1] < -25.0 < 0.0 < maps.marks["distance reference"][1]


def test_a_lens_made_for_the_eye_has_no_error_straight_ahead():
    spec = load_spec(None)
    import dataclasses

    flat = dataclasses.replace(spec.lens, pose=dataclasses.replace(
        spec.lens.pose, pantoscopic_tilt_deg=0.0))
    maps = as_worn_maps(spec.eye, flat, n=5)
    assert abs(maps.mean_error_d[2, 2]) < 0.01 and abs(maps.cylinder_d[2, 2]) < 0.01
    # oblique astigmatism grows away from the centre
    assert maps.cylinder_d[0, 0] < maps.cylinder_d[2, 2] - 0.01


def test_maps_command_writes_png_and_json(tmp_path, capsys):
    png, js = tmp_path / "m.png", tmp_path / "m.json"
    assert main(["maps", "-o", str(png), "--json", str(js), "--points", "9"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads(js.read_text())
    assert len(data["mean_error_d"]) == 9 and "object_distance_model" in data
    assert len(data["eye_rotation_x_deg"]) == 9 and data["grid"].startswith("eye rotation")
    assert len(data["object_y_deg"]) == 9
    assert "mean power error" in capsys.readouterr().out
    assert main(["maps", "-o", str(png), "--points", "1000"]) == 2
    assert "maps.n" in capsys.readouterr().err


def test_maps_as_pyvista_data_and_isolines():
    from eyelab.render.maps import map_isolines, maps_to_pyvista

    spec = load_spec(ROOT / "docs" / "gallery" / "pal.toml")
    maps = as_worn_maps(spec.eye, spec.lens, n=11)
    img = maps_to_pyvista(maps)
    assert img.dimensions == (11, 11, 1)
    np.testing.assert_allclose(img.point_data["cylinder_d"].reshape(11, 11), maps.cylinder_d)
    # the point at eye rotation (x, y) holds the map's [j, i] value
    i, j = 8, 3
    pid = img.find_closest_point((maps.eye_rotation_x_deg[i], maps.eye_rotation_y_deg[j],
                                  0.0))
    assert img.point_data["mean_error_d"][pid] == pytest.approx(maps.mean_error_d[j, i])
    lines = map_isolines(maps, "cylinder_d", 0.5)
    assert lines.n_points > 0
