"""The blur field (Kakimoto et al. 2007, §4.1): a voxel grid over a camera's view volume in
which each voxel holds the 2x2 matrix (Eq. 9) mapping a unit-disc jitter seed to the NDC
displacement of any vertex inside it.

Grid: ``shape = (nz, ny, nx)``; voxel (k, j, i) covers NDC x in [-1 + 2i/nx, -1 + 2(i+1)/nx],
likewise y, and depth slice k. Arrays are indexed ``[k, j, i]`` (z, y, x), the layout of a
3D texture ``field[z, y, x, 4]``.

Depth axis (``depth_mode``):

* ``"ndc"`` — slices uniform in NDC z (the paper's choice). NDC z is affine in 1/w, so these
  slices are uniform in dioptric distance from the camera's centre of projection, which is
  what blur is linear in (blur diameter = pupil x dioptric defocus). Texture coordinate:
  tc_z = 0.5 z_ndc + 0.5.
* ``"linear"`` — slices uniform in eye-space depth w between near and far; spends the
  slices on the far half, where blur changes least. Texture coordinate:
  tc_z = (w - near) / (far - near), with w = gl_Position.w in the vertex shader.
"""

from __future__ import annotations

import enum
import json
from dataclasses import dataclass, field

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.core.fileio import atomic_path, json_default
from eyelab.optics.rays.camera import Camera

DEPTH_MODES = ("ndc", "linear")


class VoxelStatus(enum.IntEnum):
    OK = 0
    #: no light path from the voxel's wave source through the lens to the pupil
    NOT_VISIBLE = 1
    #: the wave source lies between the eye and the lens, or behind the eye
    BEHIND = 2
    #: outside the scene's bounds: not computed (matrix zero)
    OUTSIDE_SCENE = 3


@dataclass
class BlurField:
    """A computed blur field.

    Attributes (arrays indexed [k, j, i]):

    matrix : (nz, ny, nx, 2, 2) NDC units per unit seed (Eq. 9)
    a, b : (nz, ny, nx) signed semi-axes of the retinal ellipse, m (Eq. 8; a for k'_1)
    omega : (nz, ny, nx) rad, direction of k'_1 in the eye (x, y) frame
    major_arcmin : (nz, ny, nx) major semi-axis as a visual angle, arcmin
    accommodation : (nz, ny, nx) D used
    status : (nz, ny, nx) uint8 :class:`VoxelStatus`
    sources : (nz, ny, nx, 3) world positions of the wave sources, m
    aberration : None (the map is ``matrix`` alone: a second-order blur), or (nz, ny, nx,
        2, len(HIGHER)) the ray-aberration map's non-linear coefficients, NDC per unit seed
        (:mod:`eyelab.blur.aberration`: the constant, quadratic and cubic terms; the
        linear ones are ``matrix``)
    """

    camera: Camera
    shape: tuple
    depth_mode: str
    matrix: np.ndarray
    a: np.ndarray
    b: np.ndarray
    omega: np.ndarray
    major_arcmin: np.ndarray
    accommodation: np.ndarray
    status: np.ndarray
    sources: np.ndarray
    method: str = "wavefront"
    key: str = ""
    report: dict = field(default_factory=dict)
    aberration: np.ndarray | None = None

    # -------------------------------------------------------------- the map
    @property
    def has_aberration(self) -> bool:
        """Whether the map has terms beyond the matrix (then a pass displaces by
        :meth:`displacement`, not matrix x seed)."""
        return self.aberration is not None

    def active(self) -> np.ndarray:
        """(n,) flat indices of the voxels whose map is not zero (the others displace
        nothing): what the map's per-pass and per-frame work runs over (a scene fills a
        fraction of the view volume's voxels). Computed once."""
        got = self.__dict__.get("_active")
        if got is None:
            nz, ny, nx = self.shape
            on = np.any(self.matrix.reshape(nz * ny * nx, -1) != 0, axis=1)
            if self.aberration is not None:
                on |= np.any(self.aberration.reshape(nz * ny * nx, -1) != 0, axis=1)
            got = np.flatnonzero(on)
            self.__dict__["_active"] = got
        return got

    def on_active(self, fn, *arrays, tail=()) -> np.ndarray:
        """``fn`` of the active voxels' rows of ``arrays`` (each (nz, ny, nx, ...)),
        scattered back into zeros of shape (nz, ny, nx) + ``tail``."""
        nz, ny, nx = self.shape
        idx = self.active()
        rows = [a.reshape((nz * ny * nx,) + a.shape[3:])[idx] for a in arrays]
        out = np.zeros((nz * ny * nx,) + tuple(tail))
        out[idx] = fn(*rows)
        return out.reshape((nz, ny, nx) + tuple(tail))

    def active_rows(self) -> tuple:
        """(active voxels' flat indices (n,), their matrices as rows (2 n, 2), their
        non-linear coefficients as rows (2 n, len(HIGHER))): what :meth:`displacement`
        multiplies, gathered once (0.05 s for 131,072 voxels: a renderer gathers them
        while it sets a frame up, off an interactive window's thread, not in its first
        pass)."""
        got = self.__dict__.get("_active_rows")
        if got is None:
            n = int(np.prod(self.shape))
            idx = self.active()
            got = (idx, self.matrix.reshape(n, 2, 2)[idx].reshape(-1, 2),
                   None if self.aberration is None else
                   self.aberration.reshape(n, 2, -1)[idx].reshape(len(idx) * 2, -1))
            self.__dict__["_active_rows"] = got
        return got

    def displacement(self, seed) -> np.ndarray:
        """(nz, ny, nx, 2) NDC: every voxel's displacement for the pupil point ``seed``
        (2,), unit disc: matrix x seed plus the non-linear terms."""
        from eyelab.blur.aberration import higher_basis

        s = np.asarray(seed, float)
        if self.aberration is None:
            return self.matrix @ s
        h = higher_basis(s[None])[0]
        idx, m, a = self.active_rows()
        out = np.zeros((int(np.prod(self.shape)), 2))
        out[idx] = (m @ s + a @ h).reshape(-1, 2)          # matrix-vector products
        return out.reshape(self.shape + (2,))

    def displacement_rgba(self, seed) -> np.ndarray:
        """(nz, ny, nx, 4) float32 texels of a pass's displacement at ``seed``, laid out
        as :meth:`texture_rgba`'s matrix (dx, 0, dy, 0), so that the shader's matrix x
        (1, 0) is the displacement."""
        d = self.displacement(seed)
        out = np.zeros(d.shape[:3] + (4,), np.float32)
        out[..., 0] = d[..., 0]
        out[..., 2] = d[..., 1]
        return out

    def pass_field(self, seed) -> PassField:
        """The field a pass with this ``seed`` draws by: its displacement as a texture
        (:meth:`displacement_rgba`) under a key of its own, to be used with the seed (1,
        0)."""
        s = tuple(float(v) for v in np.asarray(seed, float))
        return PassField(self.camera, self.shape, self.depth_mode, (self.key, s),
                         lambda: self.displacement_rgba(s))

    def blur_matrix(self) -> np.ndarray:
        """(nz, ny, nx, 2, 2) the matrix whose disc has the map's second moments about
        its mean (:func:`~eyelab.blur.aberration.cov_equivalent_matrix`): ``matrix``
        itself for a second-order field. What the reconstruction filter and the colour
        channels' agreement are sized by."""
        if self.aberration is None:
            return self.matrix
        got = self.__dict__.get("_blur_matrix")
        if got is None:
            from eyelab.blur.aberration import cov_equivalent_matrix, map_covariance

            got = self.on_active(
                lambda m, a: cov_equivalent_matrix(map_covariance(m, a)), self.matrix,
                self.aberration, tail=(2, 2))
            self.__dict__["_blur_matrix"] = got
        return got

    def mean_offset(self) -> np.ndarray:
        """(nz, ny, nx, 2) NDC: the map's mean over the disc (where the blur's light is
        centred, relative to the line of sight): zero for a second-order field."""
        if self.aberration is None:
            return np.zeros(self.matrix.shape[:-1])
        from eyelab.blur.aberration import HIGHER, disc_means

        return self.aberration @ disc_means()[list(HIGHER)]

    # -------------------------------------------------------------- geometry
    @property
    def nz(self):
        return self.shape[0]

    def slice_bounds_depth(self):
        """(nz + 1,) eye-space depths (m) of the slice boundaries, near to far."""
        return slice_bounds(self.camera, self.nz, self.depth_mode)

    def slice_depths(self):
        """(nz,) eye-space depth (m) of each slice's centre (midpoint in the slice's own
        parameter: NDC z or w)."""
        return slice_centres(self.camera, self.nz, self.depth_mode)

    def texcoords(self, points):
        """(n, 3) texture coordinates in [0, 1] of world points, as the shader computes them."""
        ndc = self.camera.world_to_ndc(points)
        if self.depth_mode == "ndc":
            tz = 0.5 * ndc[:, 2] + 0.5
        else:
            w = self.camera.depth(points)
            tz = (w - self.camera.near) / (self.camera.far - self.camera.near)
        return np.stack([0.5 * ndc[:, 0] + 0.5, 0.5 * ndc[:, 1] + 0.5, tz], -1)

    def lookup(self, points, *, interpolate=True):
        """(n, 2, 2) matrices at world points: trilinear between voxel centres (as a
        GL_LINEAR 3D texture with clamp-to-edge) or nearest voxel."""
        nz, ny, nx = self.shape
        return self.sample(self.matrix.reshape(nz, ny, nx, 4), points,
                           interpolate=interpolate).reshape(-1, 2, 2)

    def sample(self, volume, points, *, interpolate=True):
        """Sample any (nz, ny, nx, ...) array at world points like the shader samples the
        texture: (n, ...). Points at or behind the camera plane (clipped by the rasteriser)
        get zeros."""
        points = np.atleast_2d(points)
        with np.errstate(divide="ignore", invalid="ignore"):
            tc = self.texcoords(points)
        behind = (self.camera.depth(points) <= 0) | ~np.all(np.isfinite(tc), axis=1)
        tc = np.where(behind[:, None], 0.5, tc)
        nz, ny, nx = self.shape
        if not interpolate:
            idx = [np.clip((tc[:, a] * n).astype(int), 0, n - 1)
                   for a, n in ((2, nz), (1, ny), (0, nx))]
            out = volume[idx[0], idx[1], idx[2]].copy()
            out[behind] = 0
            return out
        coords = []
        for a, n in ((2, nz), (1, ny), (0, nx)):
            f = np.clip(tc[:, a] * n - 0.5, 0, n - 1)
            if n > 1:
                i0 = np.minimum(np.floor(f).astype(int), n - 2)
                coords.append((i0, f - i0))
            else:
                coords.append((np.zeros(len(f), int), np.zeros(len(f))))
        (z0, tz), (y0, ty), (x0, tx) = coords
        out = np.zeros((len(tc),) + volume.shape[3:])
        extra = (slice(None),) + (None,) * (volume.ndim - 3)
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    wgt = (tz if dz else 1 - tz) * (ty if dy else 1 - ty) * (tx if dx else 1 - tx)
                    zi = np.minimum(z0 + dz, nz - 1)
                    yi = np.minimum(y0 + dy, ny - 1)
                    xi = np.minimum(x0 + dx, nx - 1)
                    out += wgt[extra] * volume[zi, yi, xi]
        out[behind] = 0
        return out

    def texture_rgba(self):
        """(nz, ny, nx, 4) float32 texel data (m00, m01, m10, m11) for the vertex shader."""
        nz, ny, nx = self.shape
        return np.ascontiguousarray(self.matrix.reshape(nz, ny, nx, 4), dtype=np.float32)

    @property
    def all_zero(self) -> bool:
        return not np.any(self.matrix) and (self.aberration is None
                                            or not np.any(self.aberration))

    # ------------------------------------------------------------------- io
    def _meta(self):
        cam = self.camera
        return {"camera": {k: (list(map(float, v)) if isinstance(v, tuple) else float(v))
                           for k, v in cam.__dict__.items()},
                "shape": list(self.shape), "depth_mode": self.depth_mode,
                "method": self.method, "key": self.key, "report": self.report}

    def save(self, path):
        """Save to ``.npz`` (compressed numpy), written atomically; :meth:`load` reads it back
        exactly. (ParaView's ``.vti``: :func:`eyelab.render.fields.save_vti`.)"""
        path = str(path)
        if not path.endswith(".npz"):
            raise SpecError("path", f"blur fields save to .npz here (.vti: "
                                    f"eyelab.render.fields.save_vti), got {path!r}")
        with atomic_path(path, suffix=".npz") as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, meta=np.array(self.meta_json()), **self.arrays())

    def arrays(self) -> dict:
        """The per-voxel arrays by name (what :meth:`save` writes)."""
        out = {k: getattr(self, k) for k in ARRAY_NAMES}
        if self.aberration is not None:
            out["aberration"] = self.aberration
        return out

    def meta_json(self) -> str:
        """Camera, shape, depth mode, method, key and report as JSON text."""
        return json.dumps(self._meta(), default=json_default)

    @classmethod
    def from_parts(cls, meta: dict, arrays: dict) -> BlurField:
        """Rebuild a field from :meth:`meta_json` (parsed) and :meth:`arrays`."""
        c = meta["camera"]
        cam = Camera(tuple(c["position"]), tuple(c["forward"]), tuple(c["up"]),
                     c["fov_y_deg"], c["aspect"], c["near"], c["far"])
        return cls(cam, tuple(meta["shape"]), meta["depth_mode"],
                   *(arrays[k] for k in ARRAY_NAMES), meta["method"], meta["key"],
                   meta["report"], arrays.get("aberration"))

    @classmethod
    def load(cls, path) -> BlurField:
        """Load a field saved by :meth:`save` (``.npz``)."""
        with np.load(str(path)) as z:
            meta = json.loads(str(z["meta"]))
            return cls.from_parts(meta, {k: z[k] for k in ARRAY_NAMES + ("aberration",)
                                         if k in z.files})


@dataclass(frozen=True)
class PassField:
    """One pass's displacement of a field with a ray-aberration map, as the window's
    ``use_field`` takes a field: camera, shape, depth mode, a key, and the texels
    ((nz, ny, nx, 4) float32 (dx, 0, dy, 0), made when first uploaded)."""

    camera: Camera
    shape: tuple
    depth_mode: str
    key: tuple
    make: object

    def texture_rgba(self) -> np.ndarray:
        return self.make()


#: The per-voxel arrays of a :class:`BlurField`, in constructor order.
ARRAY_NAMES = ("matrix", "a", "b", "omega", "major_arcmin", "accommodation", "status",
               "sources")


def slice_bounds(camera: Camera, nz: int, mode: str):
    if mode == "ndc":
        return camera.ndc_z_to_depth(np.linspace(-1.0, 1.0, nz + 1))
    if mode == "linear":
        return np.linspace(camera.near, camera.far, nz + 1)
    raise SpecError("depth_mode", f"must be one of {DEPTH_MODES}, got {mode!r}")


def slice_centres(camera: Camera, nz: int, mode: str):
    if mode == "ndc":
        return camera.ndc_z_to_depth(-1.0 + (2 * np.arange(nz) + 1.0) / nz)
    if mode == "linear":
        return camera.near + (np.arange(nz) + 0.5) * (camera.far - camera.near) / nz
    raise SpecError("depth_mode", f"must be one of {DEPTH_MODES}, got {mode!r}")


#: Rings of not-visible voxels next to visible ones whose matrices are extended from their
#: visible neighbours. One ring is what a trilinear look-up in a visible voxel reads; the
#: second covers look-ups between the lens's rim and the first ring's centres.
RIM_RINGS = 2


def extend_into_invisible(matrix, status, rings: int = RIM_RINGS) -> int:
    """Give NOT_VISIBLE voxels next to visible (OK) ones, ring by ring in each depth slice,
    the mean matrix of their already-filled 8-neighbours; returns how many were filled.

    A not-visible voxel (no light path through the lens) has no matrix of its own, and
    zero there would be mixed into every trilinear look-up at the lens's rim, shrinking
    the blur by up to half in a one-voxel band (the scene-margin defect's twin); the
    field is smooth there, so its visible neighbours' mean is the right continuation.
    The status stays NOT_VISIBLE. ``matrix`` (nz, ny, nx, 2, 2) is changed in place."""
    filled = status == VoxelStatus.OK
    todo = status == VoxelStatus.NOT_VISIBLE
    total = 0
    nz, ny, nx = status.shape
    for _ in range(rings):
        acc = np.zeros(matrix.shape)
        cnt = np.zeros(status.shape)
        src = np.where(filled[..., None, None], matrix, 0.0)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dy == dx == 0:
                    continue
                ys = slice(max(dy, 0), ny + min(dy, 0))
                yd = slice(max(-dy, 0), ny + min(-dy, 0))
                xs = slice(max(dx, 0), nx + min(dx, 0))
                xd = slice(max(-dx, 0), nx + min(-dx, 0))
                acc[:, yd, xd] += src[:, ys, xs]
                cnt[:, yd, xd] += filled[:, ys, xs]
        new = todo & ~filled & (cnt > 0)
        if not new.any():
            break
        matrix[new] = acc[new] / cnt[new][:, None, None]
        filled = filled | new
        total += int(new.sum())
    return total
