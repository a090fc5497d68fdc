"""The inspector's gaze readout (a mixin of :class:`eyelab.jobs.inspector.InspectorModel`):
``eyelab analyze`` at the scene point on the line of sight — the thin eye's accommodation
and blur, a schematic eye's accommodation and the refraction left at the retina by real
rays, and through a lenslet lens the carrier's image with the share of light through
lenslets, as ``analyze`` reports them."""

from __future__ import annotations

import numpy as np

from eyelab.optics.eye.thin import EYE_REFERENCE_NM, Eye


class ReadoutMixin:
    """Needs of its model: ``spec``, ``view``, ``lens``, ``lens_on``, ``two_eyes``,
    ``result`` and ``scene()``; sets ``gaze_point`` and ``gaze_distance_m``."""

    def readout(self) -> str:
        """``analyze`` at the gaze point: the scene point on the line of sight, its
        accommodation and blur (arcmin) for the eye turning about its centre of
        rotation (the as-worn model)."""
        from eyelab.optics.chain.analysis import analyze_points
        from eyelab.optics.rays.paths import ObjectPoints
        from eyelab.optics.rays.trace import FATAL
        from eyelab.scene.raycast import scene_intersector

        if self.two_eyes:
            from eyelab.jobs.twoeyes import fixation_distance, readout

            self.gaze_distance_m = fixation_distance(self.result)
            return readout(self.result)
        from eyelab.jobs.points import line_of_sight_lens

        cam = self.view.camera(self.spec.eye.rotation_centre)
        o = np.asarray(cam.position, float)[None]
        d = np.asarray(cam.basis[2], float)[None]
        lens = line_of_sight_lens(self.lens)    # a lenslet lens: its carrier, as analyze
        if lens is not None:
            res = lens.trace(o, d, EYE_REFERENCE_NM, reverse=True)
            if (res["status"][0] & np.uint8(FATAL)) == 0:
                o, d = res["out_points"], res["out_dirs"]
        hit = scene_intersector(self.scene()).intersect(o + 1e-7 * d, d)
        self.gaze_distance_m = None
        if not hit.hit[0]:
            return "gaze point: nothing on the line of sight"
        p = o[0] + hit.t[0] * d[0]
        self.gaze_point = p                     # m, the world frame (analyze's [[points]])
        self.gaze_distance_m = float(np.linalg.norm(p - np.asarray(cam.position)))
        points = ObjectPoints.from_positions(p[None])
        if not isinstance(self.spec.eye, Eye):
            return self._schematic_readout(p, points)
        pa = analyze_points(self.spec.eye, lens, points, fixation="rotating",
                            accommodation=self.view.focus_d)
        if not pa.ok[0]:
            return "gaze point: no light path through the lens"
        maj, mnr, _ = pa.blur_axes()
        text = (f"gaze point {np.linalg.norm(p):.2f} m: accommodation "
                f"{pa.accommodation[0]:.2f} D, blur {pa.to_arcmin(maj)[0]:.2f}' x "
                f"{pa.to_arcmin(mnr)[0]:.2f}' (semi-axes, d line)")
        if lens is not self.lens:                 # the lenslets' light, as analyze says it
            from eyelab.jobs.points import lenslet_row

            row = lenslet_row(self.lens, points, 0, pa.pupil[0], pa.chief.dir_out[0],
                              self.spec.eye.pupil_diameter / 2, EYE_REFERENCE_NM,
                              entry=pa.chief.entry[0])
            text += _lenslet_text(row)
        return text

    def _schematic_readout(self, p, points) -> str:
        """A schematic eye's readout: ``eyelab analyze`` of the gaze point (the eye turned
        to it; its real chief ray to the retina), the accommodation and the refraction
        left at the retina there (M, J0, J45) — through the lens's carrier."""
        import dataclasses

        from eyelab.jobs.retinal import schematic_report

        spec = dataclasses.replace(self.spec, points=points, fixation="rotating")
        row = schematic_report(spec, no_lens=not self.lens_on)["points"][0]
        if "m_d" not in row:
            return f"gaze point: {row.get('status', 'no light path')}"
        text = (f"gaze point {np.linalg.norm(p):.2f} m: accommodation "
                f"{row['accommodation_d']:.2f} D, refraction left M {row['m_d']:+.2f} D, "
                f"J0 {row['j0_d']:+.2f}, J45 {row['j45_d']:+.2f} (schematic eye, real rays)")
        return text + _lenslet_text(row.get("lenslets"))


def _lenslet_text(row: dict | None) -> str:
    """The readout's part on a lenslet lens's light (``analyze``'s lenslets row)."""
    if row is None:
        return ""
    if not row["count"]:
        return "; the pupil's light misses the lenslets"
    return (f"; {100 * row['fraction']:.1f} % of the light through {row['count']} lenslets "
            f"of {row['add_d']:+.2f} D (the carrier's image above)")
