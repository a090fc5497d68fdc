"""What each renderer can be asked for: its quality options, one small frozen dataclass per
renderer, validated with the spec field's name (``render.<key>``) in every error.

Pure data (no VTK), so that specs can be validated, documented and round-tripped without
loading any renderer. :data:`eyelab.imaging.registry.REGISTRY` maps each renderer name to
its options class.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from eyelab.core.checks import check_bool, check_choice, check_in, check_rgb
from eyelab.core.errors import SpecError

#: Passes of the raster renderer are 8-bit read-backs summed in uint16: exact up to 256.
MAX_PASSES = 256
#: The raster renderer's default S: with the reconstruction filter (on by default) 8 passes
#: give no ghosting at any blur size — the filter carries up to RECON_MAX_FRACTION of the
#: blur's variance, and 8 samples of a disc are then spaced by at most 2 filter sigmas
#: (docs/bench/quality_*.json: every case at SSIM >= 0.97 against the converged reference
#: at S = 8, filter on).
DEFAULT_SAMPLES = 8
#: Blur-field routes of the raster renderer: "texture" (3D texture sampled in the vertex
#: shader, docs/VTK_NOTES.md Q2, route A) or "attribute" (per-vertex look-up on the CPU,
#: route D).
FIELD_ROUTES = ("texture", "attribute")
#: Depth slicing of the raster renderer's blur fields: uniform in NDC z (dioptres) or metres.
DEPTH_MODES = ("ndc", "linear")
#: Eye models of the reference renderer: Kakimoto's thin toric eye, or Fons et al.'s
#: reduced-eye sampling.
MODELS = ("thin", "fons")
#: Per-pixel accommodation rules of the reference renderer (see ReferenceQuality).
ACCOMMODATION_RULES = ("eq13", "rms")


@dataclass(frozen=True)
class RasterQuality:
    """Options of the raster renderer (spec table ``[render]``, renderer = "raster").

    samples : S passes (1-256); field_shape : blur-field grid (nz, ny, nx), each 1-512;
    depth_mode : "ndc" (slices uniform in NDC z = in dioptres, the paper's) or "linear"
    (uniform in metres); refine : adaptive tessellation where the field is not linear
    along edges; reconstruct : per-pixel, blur-shaped Gaussian reconstruction filter
    against the ghosting of large blurs, variance-compensated so that the blur keeps its
    second moments (``eyelab.blur.reconstruct``); antialias : a sub-pixel
    jitter per pass; skip_unneeded : skip passes a frame does not need (False only to
    measure what skipping saves); chromatic : each colour channel with its own light
    paths and blur (R, G, B at the C, e, F lines) where the lens disperses or the eye has
    its own chromatic aberration (``Eye.chromatic``): per-channel blur fields and one
    render per channel and pass (false: one wavelength, one render per pass);
    field_route : "texture" (3D texture sampled in the vertex shader) or "attribute"
    (per-vertex look-up on the CPU); lens_rings / lens_segments : the lens outline mesh;
    lens_grid_px : pixel spacing of the lens mesh that carries the texture coordinates;
    env_oversample : environment-image pixels per eye pixel, in every direction, where the
    lens magnifies most (the lens view is resampled from it; the image's width follows the
    lens's magnification and distortion, :func:`eyelab.optics.rays.camera.lens_view_density`:
    a plus lens gets a denser one). 1.5 is the best measured: against 256-spp references
    at 320 x 240 through -3 D and +3 D lenses, SSIM 0.9926-0.9946 at 1.0, 0.9955-0.9967 at
    1.25, 0.9970-0.9979 at 1.5, 0.9963-0.9976 at 2; lenslet_samples : pupil samples of the
    view through a lenslet lens (:mod:`eyelab.scene.lensletrays`: one lens-view draw each
    where the sample meets lenslets); rim_color / invalid_color : sRGB of the lens rim and
    of pixels whose rays fail in the lens.
    """

    #: Ranges of the options, by spec field (the schema documents them from here).
    LIMITS: ClassVar[dict] = {"render.samples": (1, MAX_PASSES), "render.field_shape": (1, 512),
                              "render.lens_rings": (2, 256), "render.lens_segments": (8, 1024),
                              "render.lens_grid_px": (1, 64), "render.env_oversample": (0.5, 4),
                              "render.lenslet_samples": (1, MAX_PASSES)}

    samples: int = DEFAULT_SAMPLES
    field_shape: tuple = (128, 32, 32)
    depth_mode: str = "ndc"
    refine: bool = True
    reconstruct: bool = True
    antialias: bool = True
    skip_unneeded: bool = True
    chromatic: bool = True
    field_route: str = "texture"
    lens_rings: int = 24
    lens_segments: int = 96
    lens_grid_px: int = 8
    env_oversample: float = 1.5
    lenslet_samples: int = 32
    rim_color: tuple = (30, 30, 30)
    invalid_color: tuple = (128, 128, 128)

    def __post_init__(self):
        check_in("render.samples", self.samples, self.LIMITS, integer=True)
        fs = self.field_shape
        if not (isinstance(fs, (tuple, list)) and len(fs) == 3):
            raise SpecError("render.field_shape", f"must be [nz, ny, nx], got {fs!r}")
        for i, n in enumerate(fs):
            check_in(f"render.field_shape[{i}]", n, self.LIMITS, integer=True)
        object.__setattr__(self, "field_shape", tuple(int(n) for n in fs))
        check_choice("render.depth_mode", self.depth_mode, DEPTH_MODES)
        for name in ("refine", "reconstruct", "antialias", "skip_unneeded", "chromatic"):
            check_bool(f"render.{name}", getattr(self, name))
        check_choice("render.field_route", self.field_route, FIELD_ROUTES)
        check_in("render.lens_rings", self.lens_rings, self.LIMITS, integer=True)
        check_in("render.lens_segments", self.lens_segments, self.LIMITS, integer=True)
        check_in("render.lens_grid_px", self.lens_grid_px, self.LIMITS, integer=True)
        check_in("render.env_oversample", self.env_oversample, self.LIMITS)
        check_in("render.lenslet_samples", self.lenslet_samples, self.LIMITS, integer=True)
        for name in ("rim_color", "invalid_color"):
            object.__setattr__(self, name, check_rgb(f"render.{name}", getattr(self, name)))


@dataclass(frozen=True)
class ReferenceQuality:
    """Options of the reference renderer (spec table ``[render]``, renderer = "reference").

    samples : rays per pixel and colour channel (1-65536; the "fons" model traces its own n
    x m + 1 pupil points instead); model : "thin" (Kakimoto's thin toric eye) or "fons"
    (Fons et al. 2023's reduced-eye sampling); fons_n / fons_m : radii and diameters of the
    Fons pupil pattern; seed : random seed of the per-pixel rotations and jitter
    (deterministic for a seed); chromatic : R/G/B traced at their own wavelengths where the
    lens disperses or the eye has its own chromatic aberration; workers : threads (None:
    every core); progress : a progress bar on stderr; accommodation : how each pixel's
    accommodation is found when the view does not fix it — "eq13" (Kakimoto's Eq. 13 on the
    wave carried by the lens's ray matrices, as the blur field does) or "rms" (independent
    of that machinery: real rays from the scene point through the lens to pupil points, and
    the accommodation that minimises their retinal spot's RMS in the thin eye; slower).
    """

    #: Ranges of the options, by spec field (the schema documents them from here).
    LIMITS: ClassVar[dict] = {"render.samples": (1, 65536), "render.fons_n": (1, 64),
                              "render.fons_m": (1, 64), "render.seed": (0, 2**63 - 1),
                              "render.workers": (1, 256)}

    samples: int = 64
    model: str = "thin"
    fons_n: int = 4
    fons_m: int = 8
    seed: int = 0
    chromatic: bool = True
    workers: int | None = None
    progress: bool = False
    accommodation: str = "eq13"

    def __post_init__(self):
        check_in("render.samples", self.samples, self.LIMITS, integer=True)
        check_choice("render.model", self.model, MODELS)
        check_choice("render.accommodation", self.accommodation, ACCOMMODATION_RULES)
        check_in("render.fons_n", self.fons_n, self.LIMITS, integer=True)
        check_in("render.fons_m", self.fons_m, self.LIMITS, integer=True)
        check_in("render.seed", self.seed, self.LIMITS, integer=True)
        check_bool("render.chromatic", self.chromatic)
        if self.workers is not None:
            check_in("render.workers", self.workers, self.LIMITS, integer=True)
        check_bool("render.progress", self.progress)


#: Radiometry of the image-based renderer (see ImageBasedQuality).
RADIOMETRY = ("auto", "irradiance", "radiance")
#: Centre-of-projection fits of the image-based renderer.
COP_FITS = ("angle", "lsq")


@dataclass(frozen=True)
class ImageBasedQuality:
    """Options of the image-based renderer (Heidrich et al. 1997; spec table ``[render]``,
    renderer = "imagebased").

    samples : lens (pupil) sample points p_i, each one set of perspective renders (1-256;
    the pass sample set of the raster renderer: mean 0, the disc's covariance; through a
    lenslet lens equal-area seeds with the same moments);
    grid : film grid quads per side of each quad-tree cell (2-64; the paper's 10);
    angle_threshold_deg : a cell is split while the largest angle between a traced ray
    and its projection's ray exceeds it (the paper's 0.05°; 0.001-10);
    max_depth : deepest quad-tree level (0-8); cop : "angle" (the COP maximising sum
    cos^2, §3.3) or "lsq" (closest to the rays in the least-squares sense, for
    comparison); oversample : slice pixels per film pixel (0.5-4); max_slice : largest
    slice side, pixels (64-4096); radiometry : "irradiance" (Eq. 3 over the film,
    normalised so that a uniform white scene gives 1 at the film centre without losses:
    a camera's natural vignetting shows), "radiance" (Eq. 3 divided by sum_i W_i at each
    film point: what an eye sees, as the other renderers show it) or "auto" (irradiance
    for a camera lens, radiance for an eye); chromatic : R/G/B planned and rendered at
    their own wavelengths where the optics disperse (three plans).
    """

    #: Ranges of the options, by spec field (the schema documents them from here).
    LIMITS: ClassVar[dict] = {"render.samples": (1, MAX_PASSES), "render.grid": (2, 64),
                              "render.angle_threshold_deg": (0.001, 10),
                              "render.max_depth": (0, 8), "render.oversample": (0.5, 4),
                              "render.max_slice": (64, 4096)}

    samples: int = 10
    grid: int = 10
    angle_threshold_deg: float = 0.05
    max_depth: int = 3
    cop: str = "angle"
    oversample: float = 2.0
    max_slice: int = 2048
    radiometry: str = "auto"
    chromatic: bool = True

    def __post_init__(self):
        check_in("render.samples", self.samples, self.LIMITS, integer=True)
        check_in("render.grid", self.grid, self.LIMITS, integer=True)
        check_in("render.angle_threshold_deg", self.angle_threshold_deg, self.LIMITS)
        check_in("render.max_depth", self.max_depth, self.LIMITS, integer=True)
        check_choice("render.cop", self.cop, COP_FITS)
        check_in("render.oversample", self.oversample, self.LIMITS)
        check_in("render.max_slice", self.max_slice, self.LIMITS, integer=True)
        check_choice("render.radiometry", self.radiometry, RADIOMETRY)
        check_bool("render.chromatic", self.chromatic)
