"""Memory estimates checked before any work: the estimate bounds the measured peak (of the
built-in scenes and of mesh files of 10 k to 8 M triangles), a spec over the limit is
refused naming its largest part (a mesh file from its header, before it is loaded), and
the limit can be set."""

from __future__ import annotations

import os

import numpy as np
import pytest

from eyelab.apps.cli import main
from eyelab.bench.memory import MESH_RENDER, measured_peak, plane_ply
from eyelab.imaging.memory import (
    BUILTIN_SCENE,
    GIB,
    check_memory,
    estimate_memory,
    memory_limit,
    source_stats,
)
from eyelab.scene.filestats import SceneStats, file_stats, scene_stats
from eyelab.spec import parse_spec


@pytest.mark.parametrize("render", [
    {"width": 512, "height": 384, "samples": 2, "field_shape": [64, 32, 32]},
    {"width": 256, "height": 192, "samples": 2, "field_shape": [96, 64, 64]},
    {"renderer": "reference", "width": 64, "height": 48, "samples": 16, "workers": 2},
])
def test_the_estimate_bounds_the_measured_peak(render):
    data = {"eye": {"rx": "-3.00 -1.00 x 30"}, "lens": {}, "render": render}
    rs = parse_spec(data).render
    est = estimate_memory(rs.renderer, rs.view, rs.quality, source_stats(rs.scene))["total"]
    peak = measured_peak(data, timeout=300)
    assert peak <= est <= 2.5 * peak, (peak / GIB, est / GIB)


def test_over_the_limit_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "o.png"
    assert main(["render", "-o", str(out), "--width", "2048", "--height", "2048",
                 "--max-memory", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("eyelab: error: render.width:") and "limit is 1.0 GiB" in err
    assert not out.exists()
    spec = tmp_path / "s.toml"
    spec.write_text("[render]\nfield_shape = [512, 512, 512]\n")
    assert main(["render", str(spec), "-o", str(out)]) == 2
    assert capsys.readouterr().err.startswith("eyelab: error: render.field_shape:")
    assert not out.exists()


def test_the_flag_lasts_for_its_command_only(tmp_path, monkeypatch):
    monkeypatch.delenv("EYELAB_MAX_MEMORY_GB", raising=False)
    assert main(["render", "-o", str(tmp_path / "o.png"), "--width", "2048",
                 "--height", "2048", "--max-memory", "1"]) == 2
    assert "EYELAB_MAX_MEMORY_GB" not in os.environ
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "7")
    main(["render", "-o", str(tmp_path / "o.png"), "--width", "2048", "--height", "2048",
          "--max-memory", "1"])
    assert os.environ["EYELAB_MAX_MEMORY_GB"] == "7"


def test_the_limit_from_flag_environment_or_machine(monkeypatch):
    monkeypatch.delenv("EYELAB_MAX_MEMORY_GB", raising=False)
    assert memory_limit(3) == 3 * GIB
    half = memory_limit()
    assert half > 0
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "0.5")
    assert memory_limit() == 0.5 * GIB
    monkeypatch.setenv("EYELAB_MAX_MEMORY_GB", "lots")
    with pytest.raises(ValueError, match="EYELAB_MAX_MEMORY_GB"):
        memory_limit()


@pytest.mark.slow
@pytest.mark.parametrize("triangles", [10_000, 1_000_000, 8_000_000])
def test_the_estimate_bounds_the_measured_peak_of_a_mesh_file(tmp_path, triangles):
    """Peak resident memory of a raster render of a mesh file <= the estimate (counting
    the file's triangles and vertices, read from its header) <= 1.5 x that peak."""
    path = tmp_path / "plane.ply"
    plane_ply(path, triangles)
    data = {"eye": {"rx": "-3.00 -1.00 x 30"}, "lens": {},
            "render": dict(MESH_RENDER, scene=str(path))}
    est = check_memory(parse_spec(data).render, limit=float("inf"))["total"]
    peak = measured_peak(data)
    assert peak <= est <= 1.5 * peak, (peak / GIB, est / GIB)


@pytest.mark.parametrize("table", [False, True])
def test_a_mesh_file_over_the_limit_is_refused_from_its_header(tmp_path, capsys,
                                                              monkeypatch, table):
    """A PLY whose header says 8 M triangles (and whose body is missing: it cannot be
    loaded) is refused from the header alone, naming the spec key that gave the file."""
    import eyelab.scene.scene

    def no_loading(*a, **k):
        raise AssertionError("the mesh file was loaded")

    monkeypatch.setattr(eyelab.scene.scene, "load_meshes", no_loading)
    mesh = tmp_path / "big.ply"
    plane_ply(mesh, 1000, claim=8_000_000)
    spec = tmp_path / "s.toml"
    spec.write_text(f"[render]\nscene = {{path = '{mesh}', position_m = [0, 0, -1]}}\n"
                    if table else f"[render]\nscene = '{mesh}'\n")
    out = tmp_path / "o.png"
    assert main(["render", str(spec), "-o", str(out), "--max-memory", "1.0"]) == 2
    err = capsys.readouterr().err
    key = "render.scene.path" if table else "render.scene"
    assert len(err.splitlines()) == 1 and err.startswith(f"eyelab: error: {key}: "), err
    assert "8,000,000 triangles" in err and "limit is 1.0 GiB" in err
    assert not out.exists()


def test_the_estimate_counts_the_scene():
    """The scene part grows with triangles, vertices and texels; a built scene counts its
    own; unknown, a built-in scene's at most; every built-in scene fits that."""
    from eyelab.scene.library import SCENES

    rs = parse_spec({}).render
    small = estimate_memory("raster", rs.view, rs.quality, SceneStats(1000, 500))
    big = estimate_memory("raster", rs.view, rs.quality, SceneStats(8_000_000, 4_000_000))
    tex = estimate_memory("raster", rs.view, rs.quality, SceneStats(1000, 500, 16_000_000))
    assert small["scene"] < tex["scene"] < big["scene"]
    assert big["total"] - small["total"] == big["scene"] - small["scene"]
    for name, make in SCENES.items():
        st = scene_stats(make())
        assert st.triangles <= BUILTIN_SCENE.triangles, name
        assert st.vertices <= BUILTIN_SCENE.vertices, name
        assert st.texels <= BUILTIN_SCENE.texels, name
        assert source_stats(name) == st
    assert estimate_memory("raster", rs.view, rs.quality)["scene"] == \
        estimate_memory("raster", rs.view, rs.quality, BUILTIN_SCENE)["scene"]


def test_file_stats_match_what_is_loaded(tmp_path):
    """Counts read from headers or lines (PLY, STL binary and ASCII, OBJ with a texture,
    GLB) are what the loader makes (an STL's vertices: half its triangles, a closed mesh's
    count); a face-coloured PLY loads flat (three vertices per face)."""
    import trimesh
    from PIL import Image

    from eyelab.scene.scene import Scene, load_meshes

    ball = trimesh.creation.icosphere(3)
    for name, kw in (("b.ply", {}), ("b.stl", {}), ("a.stl", {"file_type": "stl_ascii"}),
                     ("b.glb", {}), ("a.ply", {"encoding": "ascii"})):
        ball.export(tmp_path / name, **kw)
        st = file_stats(tmp_path / name)
        parts = load_meshes(tmp_path / name)
        assert st.triangles == sum(p.n_triangles for p in parts) == 1280, name
        assert st.vertices == (640 if name.endswith(".stl") else 642), name
    flat = trimesh.Trimesh(ball.vertices, ball.faces, process=False)
    flat.visual.face_colors = np.tile([200, 30, 30, 255], (1280, 1))
    flat.export(tmp_path / "f.ply")
    assert file_stats(tmp_path / "f.ply").vertices == 3 * 1280 == \
        len(load_meshes(tmp_path / "f.ply")[0].vertices)
    Image.new("RGB", (64, 32)).save(tmp_path / "t.png")
    (tmp_path / "t.mtl").write_text("newmtl m\nmap_Kd t.png\n")
    (tmp_path / "t.obj").write_text("mtllib t.mtl\nusemtl m\nv 0 0 -1\nv 1 0 -1\n"
                                    "v 0 1 -1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n")
    st = file_stats(tmp_path / "t.obj")
    assert (st.triangles, st.vertices, st.texels) == (1, 3, 64 * 32)
    assert scene_stats(Scene(load_meshes(tmp_path / "t.obj"))) == SceneStats(
        1, 3, 64 * 32, "of the built scene")
    assert file_stats(tmp_path / "t.png") is None


def test_refinement_leaves_big_meshes_and_bounds_its_temporaries(monkeypatch):
    """A mesh over half the refinement cap is left as it is (no pymeshlab copy of it),
    saying why; the per-face error is the same in blocks as in one piece."""
    import eyelab.scene.refine as refine
    from eyelab.blur.wavefront import compute_blur_field
    from eyelab.optics.eye.prescription import Prescription
    from eyelab.optics.eye.thin import Eye
    from eyelab.optics.rays.camera import eye_camera
    from eyelab.scene.library import room_scene

    eye = Eye.from_rx(Prescription(-2.0), accommodation_max=0.5)
    f = compute_blur_field(eye, None, eye_camera(near=0.05, far=100.0), shape=(64, 32, 32))
    floor = room_scene().meshes[0]
    err = refine._interpolation_error(floor.vertices, floor.faces, [f], 320.0)
    monkeypatch.setattr(refine, "FACE_BLOCK", 7)
    assert np.array_equal(refine._interpolation_error(floor.vertices, floor.faces, [f],
                                                      320.0), err)
    assert err.max() > 0.5
    monkeypatch.setattr(refine, "MAX_VERTICES", 2 * len(floor.vertices) - 2)
    out, info = refine.refine_for_fields(floor, [f])
    assert out is floor and not info["refined"] and info["capped_at_max_vertices"]
