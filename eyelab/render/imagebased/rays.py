"""Rays of the eye (with or without a spectacle lens) for the image-based lens model: the
eye's pupil is the image-sided surface, the eye camera's image the film. The thin toric
eye's rays in closed form (:class:`EyeRays`); a schematic eye's traced exactly from its
retina through its surfaces (:class:`SchematicEyeRays`, the reference renderer's rays)."""

from __future__ import annotations

import copy

import numpy as np

from eyelab.core.vecmath import unit
from eyelab.optics.cameralens.film import RaySet
from eyelab.optics.rays.trace import FATAL


def through_lens(lens, o, d, wavelength_nm) -> tuple:
    """(origins (n, 3), directions (n, 3), transmittance (n,), sites (n, 2) or None) of
    eye rays ``o``, ``d`` after the spectacle ``lens`` (None: unchanged, transmittance 1,
    no sites), traced exactly from the eye side; a ray that misses the lens goes on
    straight with all its light. Sites: where each ray crosses the front surface (lens
    frame x, y, m; NaN where it misses), which decides its lenslet."""
    if lens is None:
        return o, d, np.ones(len(o)), None
    r = lens.trace(o, d, wavelength_nm, reverse=True)
    through = (r["status"] & np.uint8(FATAL)) == 0
    site = lens.placed_surfaces()[0].to_local(r["out_points"])[:, :2]
    return (np.where(through[:, None], r["out_points"], o),
            np.where(through[:, None], r["out_dirs"], d),
            np.where(through, r["transmittance"], 1.0),
            np.where(through[:, None], site, np.nan))


class _LensRays:
    """What the eyes' ray makers share: :meth:`with_lens`."""

    def with_lens(self, lens):
        """The same eye and film with another spectacle lens (the image-based renderer's
        lenslet layers: the carrier, each lenslet continued); the caches of the eye's own
        rays are shared."""
        other = copy.copy(self)
        other.lens = lens
        return other


class EyeRays(_LensRays):
    """Rays of the thin toric eye (and a spectacle lens): the film is the eye camera's
    image (a pixel is the chief direction d_s from the pupil centre, tangents t = (tx, ty)
    in the camera's frame); a sample is a pupil point rho (unit disc times the pupil
    radius) in the pupil plane, which is perpendicular to the line of sight. The eye is the
    ideal thin lens of the other renderers' model in tangent form — a ray from the pixel's
    retinal point through rho leaves with the tangents t - G rho, G = P(accommodation) -
    n2 / z_r (+ the eye's chromatic power shift at the wavelength) — then passes the
    spectacle lens exactly (a ray that misses the lens goes on straight). Without a lens
    every ray of a sample passes through its pupil point: one exact perspective per
    sample (Heidrich Fig. 3a). W_i: the retina (a plane z_r behind the pupil) and the
    pupil plane, |x'' - x'|^2 = z_r^2 + |r - rho|^2 with r = -z_r t / n2 the pixel's
    retinal point.

    ``accommodation`` a fixed value (D), or None: each film point's own, for the first
    scene point along its chief ray (``scene`` needed), by the reference renderer's rule
    (:func:`eyelab.scene.focus.pixel_accommodation`, Kakimoto Eq. 13); the rays of a
    sample then change across depth edges, which the quad-tree refines."""

    kind = "eye"

    def __init__(self, eye, lens, view, accommodation: float | None, scene=None):
        self.eye, self.lens, self.view = eye, lens, view
        self.focus_lens = lens          # what the eye focuses through (not a layer's lens)
        self.cam = view.camera(eye.rotation_centre)
        self.acc = None if accommodation is None else \
            float(min(max(accommodation, 0.0), eye.accommodation_max))
        if self.acc is None:
            if scene is None:
                raise ValueError("EyeRays: automatic accommodation needs the scene")
            from eyelab.core.cache import LRUCache
            from eyelab.scene.raycast import EmbreeIntersector

            self.scene, self.inter = scene, EmbreeIntersector(scene)
            # a film point's accommodation does not depend on the lens sample: one chief
            # ray per grid, whatever the sample (planning asks for the same grid per sample)
            self._acc = LRUCache(256, "accommodation")
        self.radius = eye.pupil_diameter / 2
        self.width, self.height = view.width, view.height
        self.near = view.near

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        px = np.asarray(film_px, float)
        tx_half, ty_half = self.cam.tan_half
        t = np.column_stack([(2 * px[:, 0] / self.width - 1) * tx_half,
                             (1 - 2 * px[:, 1] / self.height) * ty_half])
        eye = self.eye
        rho = np.array([sample[0], sample[1]]) * self.radius
        b = self.cam.basis
        if self.acc is None:
            from eyelab.core.cache import array_digest
            from eyelab.scene.focus import pixel_accommodation

            d_s = unit(t[:, :1] * b[0] + t[:, 1:2] * b[1] + b[2])
            acc, _ = self._acc.get_or_create(array_digest(px), lambda: pixel_accommodation(
                d_s, self.scene, self.inter, eye, self.focus_lens, self.view, self.cam)[0])
        else:
            acc = np.full(len(px), self.acc)
        pxx, pxy, pyy = (np.broadcast_to(v, acc.shape) for v in eye.power_matrix(acc))
        # the eye's own chromatic aberration: every meridian's power shifted at this
        # wavelength (the reference renderer's channel slopes)
        e = eye.emmetropic_power - eye.power_shift(wavelength_nm)
        g = np.column_stack([(pxx - e) * rho[0] + pxy * rho[1],
                             pxy * rho[0] + (pyy - e) * rho[1]])
        to = t - g
        d = unit(to[:, :1] * b[0] + to[:, 1:2] * b[1] + b[2])
        o = np.broadcast_to(np.asarray(self.cam.position, float) + rho[0] * b[0]
                            + rho[1] * b[1], d.shape).copy()
        ok = np.ones(len(px), bool)
        o, d, trans, site = through_lens(self.lens, o, d, wavelength_nm)
        zr, n2 = eye.retina_distance, eye.n_vitreous
        r_ret = -zr * t / n2
        dist2 = zr ** 2 + (r_ret[:, 0] - rho[0]) ** 2 + (r_ret[:, 1] - rho[1]) ** 2
        w = zr ** 2 / dist2 ** 2
        return RaySet(px, o, d, ok, w, trans, site)


class SchematicEyeRays(_LensRays):
    """Rays of a schematic eye at fixation (and a spectacle lens), traced as the reference
    renderer traces them (:mod:`eyelab.reference.retinal`): a film point is a line of
    sight (the eye camera's pixel direction entering the eye), its retinal point where that
    chief ray lands at the eye's reference wavelength
    (:func:`~eyelab.optics.chain.retinal_rays.retina_points`); a sample is a point of the
    iris (unit disc times the stop's radius, in the eye's x, y), and the ray from the
    retinal point through it is found by Newton's method and traced exactly through the
    crystalline lens, the cornea and the spectacle lens (a ray missing the lens goes on
    straight), each colour at its own wavelength. Every ray that leaves the eye weighs 1:
    the image is the mean radiance over the pupil, as the reference's (the retinal
    illuminance's obliquity fall-off is not applied there either).

    ``accommodation``: the eye's one accommodation at fixation (D, the model's;
    :func:`~eyelab.imaging.retinal.view_accommodation`)."""

    kind = "eye"

    def __init__(self, eye, lens, view, accommodation: float):
        from eyelab.optics.chain.retinal_rays import camera_frame
        from eyelab.optics.eye.thin import EYE_REFERENCE_NM

        self.eye, self.lens, self.view = eye, lens, view
        self.cam = view.camera(eye.rotation_centre)
        self.rot, self.vertex = camera_frame(self.cam)
        self.acc = float(accommodation)
        self.radius = eye.stop_radius(self.acc, EYE_REFERENCE_NM)
        self.width, self.height = view.width, view.height
        self.near = view.near
        from eyelab.core.cache import LRUCache

        # the planner asks for the same grids for every sample: their landing (one per
        # grid) and stop Jacobians (per grid and wavelength) are traced once
        self._landing = LRUCache(64, "retinal landing")
        self._jacobians = LRUCache(64, "stop Jacobians")

    def _retina(self, px, wavelength_nm):
        """(retinal points (n, 3), unit chief directions in the vitreous (n, 3), on the
        retina (n,), the stop Jacobians at ``wavelength_nm``) of film points ``px`` (n, 2),
        kept for the last grids asked for."""
        from eyelab.core.cache import array_digest
        from eyelab.optics.chain.retinal_rays import retina_points, stop_jacobians
        from eyelab.optics.eye.thin import EYE_REFERENCE_NM

        def land():
            x = 2 * px[:, 0] / self.width - 1
            y = 1 - 2 * px[:, 1] / self.height
            dirs = -self.cam.ray_directions(x, y)
            r, v, st = retina_points(self.eye, self.rot, self.vertex, dirs, self.acc,
                                     EYE_REFERENCE_NM)
            return r, v / np.linalg.norm(v, axis=1, keepdims=True), (st & np.uint8(FATAL)) == 0

        key = array_digest(px)
        (retina, v0, landed), _ = self._landing.get_or_create(key, land)
        jac, _ = self._jacobians.get_or_create(f"{key}-{wavelength_nm}", lambda: stop_jacobians(
            self.eye, self.rot, self.vertex, retina, v0, self.acc, wavelength_nm))
        return retina, v0, landed, jac

    def rays(self, film_px, sample, wavelength_nm) -> RaySet:
        from eyelab.optics.chain.retinal_rays import rays_from_retina

        px = np.asarray(film_px, float).reshape(-1, 2)
        n = len(px)
        retina, v0, landed, jac = self._retina(px, wavelength_nm)
        targets = np.broadcast_to(np.asarray(sample, float)[:2] * self.radius, (n, 2))
        o, d, ok = rays_from_retina(self.eye, self.rot, self.vertex, retina, v0,
                                    np.ascontiguousarray(targets), (np.arange(n), jac),
                                    self.acc, wavelength_nm)
        ok = ok & landed
        o, d, trans, site = through_lens(self.lens, o, d, wavelength_nm)
        return RaySet(px, o, d, ok, ok.astype(float), trans, site)
