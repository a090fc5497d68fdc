"""As-worn maps against real-ray pencils through the posed lens, and `eyelab maps`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.optics.analysis import analyze_points
from eyelab.optics.asworn import as_worn_maps, object_vergence
from eyelab.optics.paths import ObjectPoints
from eyelab.reference.bruteforce import extrapolated_vergence
from eyelab.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("spec_path", [None, "docs/gallery/pal.toml"])
def test_map_values_agree_with_real_ray_pencils(spec_path):
    """At 25 gazes of the default (tilted) lens and of the progressive lens, the map's mean
    power error and cylinder equal those of the wave measured by real-ray pencils
    (Richardson-extrapolated bundle fits) on the vertex sphere, less the object's vergence
    and the Rx (with the add the object's vergence calls for), to 1e-3 D."""
    spec = load_spec(None if spec_path is None else ROOT / spec_path)
    eye, lens = spec.eye, spec.lens
    maps = as_worn_maps(eye, lens, half_angle_deg=30.0, n=5)
    cor = np.array([0.0, 0.0, eye.rotation_centre])
    r_vs = lens.pose.vertex_distance + eye.rotation_centre
    f = lens.rx.distance().power_matrix()
    checked = 0
    for j, gy in enumerate(maps.gaze_y_deg):
        for i, gx in enumerate(maps.gaze_x_deg):
            d = np.array([np.tan(np.radians(gx)), np.tan(np.radians(gy)), -1.0])
            d /= np.linalg.norm(d)
            vg = float(object_vergence(gy))
            if vg > 0:
                pos = cor + d * (1.0 / vg + eye.rotation_centre)
                obj = ObjectPoints.from_positions(pos[None])
            else:
                obj = ObjectPoints(d[None], np.array([np.inf]))
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
    # the point at gaze (x, y) holds the map's [j, i] value
    i, j = 8, 3
    pid = img.find_closest_point((maps.gaze_x_deg[i], maps.gaze_y_deg[j], 0.0))
    assert img.point_data["mean_error_d"][pid] == pytest.approx(maps.mean_error_d[j, i])
    lines = map_isolines(maps, "cylinder_d", 0.5)
    assert lines.n_points > 0
