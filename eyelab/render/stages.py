"""The stateless parts of a raster frame's stages (Kakimoto et al. 2007, §3): the meshes'
refinement, how many passes a stage needs and with which seeds, the environment image's
width, the lens's meshes and their texture coordinates, the Fresnel transmittance per
pixel, and the progressive checkpoints."""

from __future__ import annotations

import time

import numpy as np

from eyelab.blur.reconstruct import (
    channel_volumes,
    filter_has_work,
    pixel_voxels,
    reconstruct,
    sigma_map,
)
from eyelab.core.sampling import antialias_jitter, pass_samples
from eyelab.render.accumulate import encode_linear
from eyelab.render.actors import field_actor_factory
from eyelab.scene.lensview import (
    lens_back_mesh,
    lens_view_mesh,
    widened_lens,
)
from eyelab.scene.pervertex import lens_texcoords
from eyelab.scene.prefilter import reduction_factor
from eyelab.scene.raycast import scene_intersector
from eyelab.scene.refine import refine_steps

#: Scene textures are mip-mapped (trilinear, in linear light) only below this many passes.
#: With few passes a minified texture would alias (point samples of many texels per pixel);
#: with more, the jittered passes themselves supersample the pixel, and the mip-maps' own
#: blur (a box of the pixel's size, then a tent of the same size) only costs accuracy.
#: Measured (quick quality scenes, RMSE against 256-spp references, 160x120): mip-maps
#: lower the error at S = 1-2 in every case (e.g. 0.055 vs 0.081), are mixed at S = 4-8,
#: and raise it at S = 32 in every case (e.g. 0.044 vs 0.008, the room).
MIPMAP_BELOW_SAMPLES = 8


def start_passes(stages, naked, report):
    """Ready the raster stages ``stages`` (``naked``: the naked view's) for their passes:
    the first channel selected, a per-channel pass's buffer, and the reconstruction
    filter's depth from a view no seed displaced (a displaced pass's edges sit where its
    seed put them: a lopsided blur); the report's ``channel_renders_per_pass``. A
    generator pausing (None) after each undisplaced render (an interactive window's
    tick)."""
    timings = report["timings_s"]
    for st in stages:
        select_channel(st, 0, st["route"])
        if len(st["fields"]) > 1:
            st["rgba"] = np.empty(st["acc"].shape + (4,), np.uint8)
        if filter_has_work(st["recon"]) and "zbuf" not in st:
            t = time.perf_counter()
            st["zbuf"] = st["win"].undisplaced_depth()
            name = "naked_passes" if st is naked else "env_passes"
            timings[name] = timings.get(name, 0.0) + time.perf_counter() - t
            yield None
    channels = [len(s["fields"]) for s in stages]
    if any(c > 1 for c in channels):
        report["details"]["channel_renders_per_pass"] = max(channels)


def select_channel(st, c, route, k: int | None = None) -> None:
    """Make channel ``c``'s field and actors current in the stage's window; for pass
    ``k`` of a field with a ray-aberration map, that pass's displacement texture
    (:meth:`~eyelab.blur.field.BlurField.pass_field`, shown with the seed (1, 0))."""
    win, items = st["win"], st["items"][c]
    field = st["fields"][c]
    if k is not None and field.has_aberration:
        field = field.pass_field(st["seeds"][k])
    win.use_field(field, route)
    keys = [k for k, _ in items]
    if st.get("shown_keys") != keys:
        win.show(items)
        st["shown_keys"] = keys


def stage_route(fields, q, report, label) -> str:
    """The field route of a stage: the quality's, except that fields with a ray-aberration
    map are always drawn through the texture route (each pass uploads that pass's
    displacement, :meth:`~eyelab.blur.field.BlurField.pass_field`; the attribute route's
    per-vertex matrices hold the linear part only)."""
    if q.field_route == "attribute" and any(f.has_aberration for f in fields):
        report["details"].setdefault("field_route", {})[label] = (
            "texture: the ray-aberration map is drawn per pass from a 3D texture")
        return "texture"
    return q.field_route


def passes_for(fields, q, report, label) -> tuple:
    """(passes, seeds (S, 2), jitter (S, 2) px) of a stage. A zero field needs no blur
    samples: without antialiasing one pass is the exact image (the rest are skipped);
    with it, the S passes still run, as jittered copies only (a skip may remove work,
    never quality)."""
    seeds, jit = pass_samples(q.samples)
    if not q.antialias:
        jit = np.zeros_like(jit)
    if all(f.all_zero for f in fields) and q.skip_unneeded:
        if not q.antialias and q.samples > 1:
            report["skipped"].append(f"{label}: blur field all zero: 1 pass instead of "
                                     f"{q.samples}")
            return 1, np.zeros((1, 2)), np.zeros((1, 2))
        if q.samples > 1:
            report["skipped"].append(f"{label}: blur field all zero: the {q.samples} "
                                     f"passes only antialias (jitter, no displacement)")
            return q.samples, np.zeros_like(seeds), antialias_jitter(q.samples)
    return q.samples, seeds, jit


def env_width(cam, vcam, view, q, lens=None) -> int:
    """The environment image's width (px): ``q.env_oversample`` of its pixels per eye pixel
    in every direction where the lens needs them most
    (:func:`~eyelab.optics.rays.camera.lens_view_density`: its magnification and distortion),
    in 16-4096. Without ``lens`` (or where no ray passes it), the virtual camera's field
    over the eye's, times the oversampling."""
    from eyelab.optics.rays.camera import lens_view_density

    density = None if lens is None else lens_view_density(lens, cam, vcam, view.width)
    if density is None or density <= 0:
        density = cam.tan_half[0] / (vcam.tan_half[0] * view.width)
    return int(min(4096, max(16, round(q.env_oversample / density))))


def lens_geometry(scene, lens, vcam, cam, view, q, wls) -> dict:
    """Lens outline mesh, view grid mesh and their texture coordinates (§3)."""
    inter = scene_intersector(scene)
    lv, lf = lens_back_mesh(lens, q.lens_rings, q.lens_segments)
    gv, gf = lens_view_mesh(lens, cam, view.width, view.height, q.lens_grid_px)
    tc = lens_texcoords(lens, lv, vcam, inter, wavelengths=wls, pupil=cam.position)
    # the grid's coordinates through the lens extended beyond its rim (the outline mask
    # clips it), so that rim cells are filled
    tcg = lens_texcoords(widened_lens(lens), gv, vcam, inter, wavelengths=wls,
                         pupil=cam.position)
    return {"lens_v": lv, "lens_f": lf, "grid_v": gv, "grid_f": gf, "tc": tc, "tc_grid": tcg,
            "transmittance": grid_transmittance(tcg.transmittance)}


def lenslet_geometry(scene, lens, geo, vcam, cam, eye, view, q, wls):
    """The lens grid's per-pupil-sample offsets through ``lens``'s lenslets
    (:func:`~eyelab.scene.lensletrays.lenslet_offsets`; ``geo``: :func:`lens_geometry`'s
    of the carrier), the eye focusing the carrier's image at each vertex
    (:func:`~eyelab.scene.focus.pixel_accommodation`)."""
    from eyelab.scene.focus import pixel_accommodation
    from eyelab.scene.lensletrays import lenslet_offsets

    inter = scene_intersector(scene)
    pupil = np.asarray(cam.position, float)
    d = geo["grid_v"] - pupil
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    acc, _ = pixel_accommodation(d, scene, inter, eye, lens, view, cam)
    return lenslet_offsets(lens, geo["grid_v"], cam, vcam, inter, eye, acc,
                           samples=q.lenslet_samples, wavelengths=wls)


def grid_transmittance(t_grid) -> np.ndarray | None:
    """The lens grid's Fresnel transmittance (channels, n) (of its vertices' rays), None when
    the lens transmits everything (an index-1 lens). The lens view interpolates it across
    the grid's triangles (within a cell of ``lens_grid_px``, where it varies by far less
    than an 8-bit code)."""
    t = np.asarray(t_grid, float)
    return None if np.all(t >= 1.0) else t


def image_due(last: bool, image_s: float | None, passes_s: float) -> bool:
    """Whether a progressive viewer's checkpoint gets an image: the first (``image_s``, the
    last image's build time, None) and the ``last`` always; the others when the passes
    since the last image took at least as long as that image took to build, so that the
    images shown cost at most the passes' own time."""
    return last or image_s is None or passes_s >= image_s


def progressive_checkpoints(samples):
    cps, k = [], 1
    while k < samples:
        cps.append(k)
        k *= 2
    return cps + [samples]


def lens_details(geo: dict, texcoord_sets: int, vcam) -> dict:
    """The report's ``details.lens`` of a stage's lens geometry (:func:`lens_geometry`)."""
    tc, tcg = geo["tc"], geo["tc_grid"]
    return {"vertices": int(len(geo["grid_v"])), "outline_vertices": int(len(geo["lens_v"])),
            "texcoord_sets": texcoord_sets,
            "vertices_missing_lens": int((~tc.lens_ok).any(0).sum()),
            "rays_missing_scene": int((~tcg.scene_hit).sum()),
            "virtual_camera": {"position_m": list(map(float, vcam.position)),
                               "fov_y_deg": vcam.fov_y_deg, "aspect": vcam.aspect}}


def field_details(f, hit: bool) -> dict:
    """The report's ``details.fields[label]`` of a blur field (cached or computed)."""
    info = {"cache": "hit" if hit else "miss", "all_zero": f.all_zero,
            "voxels_total": f.report["voxels_total"],
            "voxels_computed": f.report["voxels_computed"],
            "skipped_why": f.report["skipped_why"]}
    if not hit:
        info["time_s"] = f.report["timings"]["total_s"]
    return info


def refining(cache, scene, fields, view, q, report, offload=False):
    """The scene's meshes refined for every field of both stages (``fields``), as a
    generator: None after each mesh refined anew and between its measurements and
    subdivisions (:func:`~eyelab.scene.refine.refine_steps`: with ``offload`` the
    measurements on a worker thread, pymeshlab on this one), the meshes as its return
    value; refined meshes kept in ``cache`` (the renderer's "refined")."""
    if not q.refine:
        report["skipped"].append("refinement: disabled")
        return list(scene.meshes)
    meshes = []
    for m in scene.meshes:
        key = (m.content_key, tuple(f.key for f in fields), view.width)
        found = cache.get(key)
        hit = found is not None
        if not hit:             # measured (on a worker with offload) and cut in steps
            found = yield from refine_steps(m, fields, px_scale=view.width / 2,
                                            offload=offload)
            cache.put(key, found)
            yield None
        report["cache"]["hits" if hit else "misses"].append(f"refined_{m.name}")
        meshes.append(found[0])
        report["details"]["refinement"].append(found[1])
    return meshes


def scene_items(meshes, fields, route: str, passes: int, cam, height: int, prefilter, *,
                mipmaps: bool = True) -> list:
    """Per field (channel), the [(key, factory)] of the meshes' actors. More passes than
    :data:`MIPMAP_BELOW_SAMPLES`: the passes supersample, and textures are prefiltered to
    about two texels per pixel (:mod:`eyelab.scene.prefilter`; ``prefilter(mesh,
    factor)`` returns the prefiltered mesh). Fewer: mip-mapped, the chain built from the
    texture reduced by the largest power of two 2^k within that factor — the levels a view
    samples, those from k on (its nearest part is minified at least 2^(k+1) times), the
    finer ones never built: a chain 4^k times cheaper (the first frame at S = 4 of the
    built-in view waited 1.2 s for full chains). Against references (256 rays a pixel for
    a 128 x 96 chart, 64 for the room at 320 x 240) these chains of power-of-two textures
    (:func:`~eyelab.scene.prefilter.drawn_texture`) measured closer than the full
    texture's: RMSE 2.44 vs 2.78 sRGB levels (chart, S = 6), 8.9 vs 10.3 (chart, one
    pass), 5.88 vs 6.10 (room, S = 4), 6.14 vs 6.36 (room, one pass) — GL's chain of a
    size that halves to odd numbers drifts off a box. Unless ``mipmaps`` (a preview),
    no chain is built: the texture reduced by that power of two is drawn as it is, the
    same for every gaze and size within an octave (a gaze change's preview waited 0.07-0.1
    s for the room's textures prefiltered by the new gaze's factors). On the
    texture route an actor does not depend on the field (the shader samples it), so the
    channels share their actors."""
    mip = mipmaps and passes < MIPMAP_BELOW_SAMPLES
    shown = []
    for m in meshes:
        f = reduction_factor(m, cam, height)
        if mip or not mipmaps:      # the chain's sampled levels only (or a preview's
            f = 1 << (f.bit_length() - 1)     # texture): the texture reduced 2^k
        shown.append(m if m.texture is None else prefilter(m, f))
    return [[((m.content_key, None if route == "texture" else field.key, route, mip),
              field_actor_factory(m, field, route, mipmap=mip)) for m in shown]
            for field in fields]


def warm_textures(win, fields, route: str, items):
    """A generator pausing after each render of :meth:`OffscreenWindow.warm
    <eyelab.render.window.OffscreenWindow.warm>`: a stage's new actors (the first
    channel's ``items``) built and their textures uploaded a few a render, with the first
    field current."""
    win.use_field(fields[0], route)
    yield from win.warm(items[0])


def stage_mean(st: dict, cached, report) -> np.ndarray:
    """A stage's average (linear light, re-encoded) as GL-ordered RGBA (h, w, 4) uint8,
    reconstructed in linear light when asked (:mod:`eyelab.blur.reconstruct`).
    ``cached(key, factory)``: the renderer's small cache (the sigma maps)."""
    acc = st["acc"]
    if st["recon"] is None or "zbuf" not in st:
        return acc.mean_rgba()
    t = time.perf_counter()
    # the sigma the fields were compensated for; before the last pass (a progressive
    # preview) the sigma of the passes so far, wider: previews err on the blurry side
    rc = st["recon"]

    def sigma():                          # one map per filter (shared, or per channel)
        vols = (rc["sigma"] if acc.count == st["passes"]
                else channel_volumes(rc["svds"], acc.count, rc["reaches"]))
        if "voxels" not in st:            # the depth buffer's look-up, once per frame
            st["voxels"] = pixel_voxels(st["zbuf"], st["cam"], st["fields"][0])
        return [sigma_map(st["zbuf"], st["cam"], st["fields"][0], vol, st["voxels"])
                for vol in vols]

    sigs = cached(("sigma",) + st["key"] + (acc.shape, acc.count), sigma)
    rgba = acc.mean_rgba()
    h = acc.shape[0]
    channels = [slice(0, 3)] if len(sigs) == 1 else [slice(c, c + 1) for c in range(3)]
    boxes = [s["region"][1] for s in sigs if s["region"] is not None]
    rows = (min(b[0] for b in boxes), max(b[1] for b in boxes)) if boxes else None
    whole = acc.mean_linear(rows=rows) if boxes else None     # once for every channel
    for ch, sig in zip(channels, sigs, strict=True):
        if sig["region"] is None:      # filtered: only the box the filters change
            continue
        (y0, y1, x0, x1), (py0, py1, px0, px1) = sig["region"]
        lin = whole[py0 - rows[0]:py1 - rows[0], px0:px1, ch]
        out = reconstruct(lin, sig)            # sig's maps cover just that box
        rgba[h - y1:h - y0, x0:x1, ch] = encode_linear(   # encoded once, GL order
            out[y0 - py0:y1 - py0, x0 - px0:x1 - px0][::-1])
    tm = report["timings_s"]
    tm["reconstruct"] = tm.get("reconstruct", 0.0) + time.perf_counter() - t
    return rgba


def lens_coords(cached, scene, lens, vcam, cam, view, q, report, eye) -> tuple:
    """(lens geometry, its key, a lenslet lens's offsets or None, the wavelengths' count):
    the rays through the lens that give the environment's texture coordinates (GL-free:
    a viewer computes them on a worker thread), through ``cached`` (a renderer's
    ``_cached(cache, key, factory, report, label)``)."""
    from eyelab.core.cache import content_key
    from eyelab.optics.eye.thin import EYE_REFERENCE_NM
    from eyelab.optics.lens.lenslets import carrier
    from eyelab.optics.rays.materials import RGB_WAVELENGTHS_NM

    lenslets, lens = (lens, carrier(lens)) if lens.has_lenslets else (None, lens)
    disperses = q.chromatic and lens.material.dispersive
    wls = RGB_WAVELENGTHS_NM if disperses else (EYE_REFERENCE_NM,)
    if not disperses:
        report["skipped"].append("lens dispersion: " + (
            "disabled" if not q.chromatic else "the lens material does not disperse")
            + ": one texture-coordinate set")
    tkey = content_key(scene=scene.content_key, lens=lens, camera=vcam, wls=wls,
                       rings=q.lens_rings, segments=q.lens_segments, grid=q.lens_grid_px,
                       eye=cam, size=(view.width, view.height))
    geo, _ = cached("texcoords", tkey, lambda: lens_geometry(
        scene, lens, vcam, cam, view, q, wls), report, "lens_texcoords")
    offsets = None
    if lenslets is not None:
        okey = content_key(texcoords=tkey, lens=lenslets, eye=eye, view=view,
                           samples=q.lenslet_samples)
        offsets, _ = cached("texcoords", okey, lambda: lenslet_geometry(
            scene, lenslets, geo, vcam, cam, eye, view, q, wls), report, "lenslet_offsets")
    return geo, tkey, offsets, len(wls)
