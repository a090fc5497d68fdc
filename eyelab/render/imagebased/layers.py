"""The image-based lens model through a lenslet lens (:mod:`eyelab.optics.lens.lenslets`):
the film as layers, each a smooth system the quad-tree may interpolate.

Heidrich et al.'s projections (§3.1-3.2) interpolate each lens sample's rays between the
corners of a film grid; a lenslet lens's rays are not smooth — a ray's deflection jumps at
every lenslet's rim — and lenslets a millimetre across fall between the corners. For each
lens sample the film is therefore drawn as

- the carrier's layer: the lens without lenslets (:func:`~eyelab.optics.lens.lenslets.carrier`),
  planned over the whole film, and
- one layer per lenslet its rays meet: the lens with that lenslet's sag continued over the
  carrier (:func:`~eyelab.optics.lens.lenslets.continued`), planned over the film cell its
  rays cross the lenslet from,

each layer's grid keeping where its rays cross the front surface ("sites"). The morph
(:func:`eyelab.render.imagebased.morph.morph_pixels`) interpolates a pixel's site with its
texture coordinates and keeps the pixel in the one layer whose lenslet holds the site (the
carrier's: none): the sample's rays are split at the rims exactly as the lens splits them,
to the grid's interpolation of the site, which is smooth (the front surface is met before
its lenslet turns the ray). The pixel's weights over the samples then add the carrier's and
the lenslets' images in linear light, each sample's share decided per pixel — the veil a
lenslet lens lays over the carrier's sharp image.
"""

from __future__ import annotations

import numpy as np

from eyelab.optics.lens.lenslets import carrier, continued
from eyelab.render.imagebased.plan import Plan, plan_projections

#: The margin a grid quad's sites are widened by (a fraction of the corners' extent)
#: before its lenslets are looked for: the sites are interpolated bilinearly across the
#: quad, their true path bulging a little beyond the corners' box.
SITE_MARGIN = 0.25
#: The counters of the planning, added over the layers.
_COUNTS = ("cells", "vignetted_cells", "newton_steps", "split", "unresolved_cells")


def plan_layers(maker, lens, samples, wavelength_nm, **options) -> Plan:
    """Every projection of a frame through the lenslet ``lens`` (module doc): the
    carrier's plan (layer -1) and, per lens sample, one plan per lenslet its rays meet
    (layer i) over that lenslet's film cell. ``options``: those of
    :func:`~eyelab.render.imagebased.plan.plan_projections`.

    A lenslet's cell is the sample's own: a cell holding the lenslet's rays for every
    sample would be one film grid a lenslet, but its projection strays further from the
    rays (measured: a wide-angle schematic eye through a DIMS-like lens, 4 samples, 3x the
    planning time in quad-tree splits)."""
    surf = lens.front
    base = plan_projections(maker.with_lens(carrier(lens)), samples, wavelength_nm,
                            layer=-1, **options)
    projections = list(base.projections)
    stats = dict(base.stats)
    layers = 0
    for si, s in enumerate(samples):
        own = [pr for pr in base.projections if pr.sample == si]
        for i, cell in lenslet_cells(own, surf, maker.width, maker.height).items():
            sub = plan_projections(maker.with_lens(continued(lens, i)), [s], wavelength_nm,
                                   cell=cell, layer=i, **options)
            for pr in sub.projections:
                pr.sample = si
            projections += sub.projections
            for k in _COUNTS:
                stats[k] += sub.stats[k]
            layers += 1
    errs = [pr.max_angle_deg for pr in projections]
    stats.update(projections=len(projections), lenslet_layers=layers,
                 max_angle_deg=float(max(errs)) if errs else 0.0,
                 max_depth=max((pr.depth for pr in projections), default=0))
    return Plan(projections, np.asarray(samples, float), wavelength_nm, stats)


def lenslet_cells(projections, surf, width: int, height: int) -> dict:
    """{lenslet index: film cell (x0, y0, x1, y1) pixels}: for one lens sample's carrier
    ``projections``, the lenslets of ``surf`` whose circles meet a grid quad's sites (the
    corners' box widened by :data:`SITE_MARGIN`), each with the union of those quads'
    film boxes, clipped to the film."""
    sites, films = [], []
    corners = ((slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)),
               (slice(1, None), slice(None, -1)), (slice(1, None), slice(1, None)))
    for pr in projections:
        ok = pr.grid_ok & np.isfinite(pr.grid_site).all(-1)
        quad_ok = np.all([ok[c] for c in corners], axis=0)
        sites.append(np.stack([pr.grid_site[c] for c in corners], -2)[quad_ok])
        films.append(np.stack([pr.grid_film[c] for c in corners], -2)[quad_ok])
    if not sites:
        return {}
    sites, films = np.concatenate(sites), np.concatenate(films)      # (m, 4, 2)
    lo, hi = sites.min(1), sites.max(1)
    pad = SITE_MARGIN * (hi - lo)
    lo, hi = lo - pad, hi + pad
    q, k = surf.near(0.5 * (lo + hi), 0.5 * np.hypot(*(hi - lo).T) + surf.radius.max())
    # keep the pairs whose circle meets the box: its centre's nearest point of the box
    nearest = np.clip(surf.centres[k], lo[q], hi[q])
    meet = np.linalg.norm(nearest - surf.centres[k], axis=1) < surf.radius[k]
    q, k = q[meet], k[meet]
    if not len(k):
        return {}
    ids, inv = np.unique(k, return_inverse=True)
    f_lo = np.full((len(ids), 2), np.inf)
    f_hi = np.full((len(ids), 2), -np.inf)
    np.minimum.at(f_lo, inv, films[q].min(1))
    np.maximum.at(f_hi, inv, films[q].max(1))
    f_lo = np.maximum(f_lo, 0.0)
    f_hi = np.minimum(f_hi, [float(width), float(height)])
    boxes = zip(ids, f_lo.tolist(), f_hi.tolist(), strict=True)
    return {int(i): (*a, *b) for i, a, b in boxes if b[0] > a[0] and b[1] > a[1]}


def keep_layer(surf, layer: int):
    """The morph's pixel filter of a layer: ``keep(vals) -> (m,) bool`` for interpolated
    attributes ``vals`` (m, 6) whose columns 4-5 are the sites: those in lenslet
    ``layer`` of ``surf`` (-1: in none; a ray that misses the lens, site NaN, is the
    carrier's)."""
    def keep(vals):
        x, y = vals[:, 4].astype(float), vals[:, 5].astype(float)
        missed = ~(np.isfinite(x) & np.isfinite(y))
        which = surf.which(np.where(missed, 1e3, x), np.where(missed, 1e3, y))
        return which == layer
    return keep
