"""Wavefront tracing along rays (Kakimoto et al. 2007, §4.3-4.4; Kneisly 1964; Stavroudis 1972).

A wavefront is carried along each ray as struct-of-arrays:

* ``N`` (n, 3): unit propagation direction (the wavefront normal);
* ``t1`` (n, 3): a unit tangent; ``t2 = N x t1`` completes a right-handed frame;
* ``k11, k12, k22`` (n,): the curvature matrix K in the basis (t1, t2), 1/m.

Curvature sign (paper, §4.3): negative when the centre of curvature lies opposite to
the direction of travel (a diverging wave from a point at distance L has K = -I/L).
In air the vergence in dioptres equals the curvature in 1/m.

Keeping K in an arbitrary orthonormal tangent basis, rather than principal form, makes
every operation a few multiplications and has no special case at k1 == k2 (umbilic):
principal curvatures and directions (Eq. 5) are extracted only on output.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eyelab.core.constants import TOL
from eyelab.core.vecmath import any_tangent, cross, dot
from eyelab.optics.rays.surfaces import sym2_eig
from eyelab.optics.rays.trace import Hit, Status, refract


@dataclass
class RefractionFrame:
    """The geometry of refraction shared by the wavefront and ray-matrix forms of Eq. 4.

    new_dir (n, 3): refracted direction N'; u (n, 3): common tangent of wave and surface
    (perpendicular to the plane of incidence; ``fallback_u`` at normal incidence); cos_i,
    cos_t, gamma = cos_t - mu cos_i (n,); ks = (ks_u, ks_v, ks_uv): the surface's curvatures
    along u and v_s = N_s x u, w.r.t. the normal oriented along the light; status (n,).
    """

    new_dir: np.ndarray
    u: np.ndarray
    cos_i: np.ndarray
    cos_t: np.ndarray
    gamma: np.ndarray
    ks: tuple
    status: np.ndarray


def refraction_frame(N, hit: Hit, mu, fallback_u) -> RefractionFrame:
    new_dir, ns, cos_i, cos_t, st = refract(N, hit.normals, mu)
    sgn = np.where(dot(ns, hit.normals) < 0, -1.0, 1.0)
    u = cross(N, ns)
    un = np.linalg.norm(u, axis=1)
    normal_inc = un < 1e-12
    u = np.where(normal_inc[:, None], fallback_u, u / np.where(normal_inc, 1.0, un)[:, None])
    vs = cross(ns, u)
    ks = (sgn * hit.curvature(u, u), sgn * hit.curvature(vs, vs), sgn * hit.curvature(u, vs))
    return RefractionFrame(new_dir, u, cos_i, cos_t, cos_t - mu * cos_i, ks, st)


@dataclass
class Wavefront:
    """Wavefronts along n rays. See the module docstring for conventions."""

    N: np.ndarray
    t1: np.ndarray
    k11: np.ndarray
    k12: np.ndarray
    k22: np.ndarray
    status: np.ndarray

    @classmethod
    def spherical(cls, directions, distance):
        """Wave from a point source at ``distance`` (m, may be inf) behind, travelling along
        ``directions``: K = -I / distance (Table 1, 'wavefront creation' then Eq. 1)."""
        directions = np.asarray(directions, float)
        dist = np.broadcast_to(np.asarray(distance, float), directions.shape[:1])
        with np.errstate(divide="ignore"):
            k = np.where(np.isinf(dist), 0.0, -1.0 / dist)
        z = np.zeros_like(k)
        return cls(directions.copy(), any_tangent(directions), k.copy(), z, k.copy(),
                   np.zeros(len(k), np.uint8))

    def principal(self):
        """Principal curvatures and directions (Eq. 5).

        Returns k1 >= k2 (n,), e1, e2 (n, 3) unit with e2 = N x e1.
        """
        k1, k2, c, s = sym2_eig(self.k11, self.k12, self.k22)
        t2 = cross(self.N, self.t1)
        e1 = c[:, None] * self.t1 + s[:, None] * t2
        return k1, k2, e1, cross(self.N, e1)

    def in_basis(self, u):
        """Curvature components (k_uu, k_uv, k_vv) in the basis (u, v = N x u) — Euler's
        formulas, Eq. 3, for an arbitrary tangent unit vector u (n, 3)."""
        t2 = cross(self.N, self.t1)
        c = dot(u, self.t1)
        s = dot(u, t2)
        kuu = c * c * self.k11 + 2 * c * s * self.k12 + s * s * self.k22
        kvv = s * s * self.k11 - 2 * c * s * self.k12 + c * c * self.k22
        kuv = c * s * (self.k22 - self.k11) + (c * c - s * s) * self.k12
        return kuu, kuv, kvv

    def copy(self) -> Wavefront:
        """An independent copy (every array copied)."""
        return Wavefront(self.N.copy(), self.t1.copy(), self.k11.copy(), self.k12.copy(),
                         self.k22.copy(), self.status.copy())

    def transfer(self, distance):
        """Propagate by ``distance`` (n,) or scalar, metres, in a homogeneous medium.

        Eq. 1 (k' = k / (1 - d k) per principal meridian) in matrix form,
        K' = K (I - d K)^-1, closed form for symmetric 2x2 K:
        k11' = (k11 - d det K)/D, k12' = k12/D, k22' = (k22 - d det K)/D,
        D = det(I - d K) = (1 - d k1)(1 - d k2).
        Where |D| < TOL.focal_eps the wave passes (within ~eps/|d k|) through a focal line:
        D is clamped to +-eps (curvatures finite, ~|k|/eps) and the ray is flagged FOCAL.
        """
        d = np.asarray(distance, float)
        det_k = self.k11 * self.k22 - self.k12 * self.k12
        big_d = 1.0 - d * (self.k11 + self.k22) + d * d * det_k   # = (1 - d k1)(1 - d k2)
        focal = np.abs(big_d) < TOL.focal_eps
        if focal.any():
            big_d = np.where(focal, np.copysign(TOL.focal_eps, big_d), big_d)
            self.status = self.status | np.where(focal, np.uint8(Status.FOCAL), np.uint8(0))
        inv = 1.0 / big_d
        dd = d * det_k
        self.k11 = (self.k11 - dd) * inv
        self.k22 = (self.k22 - dd) * inv
        self.k12 = self.k12 * inv
        return self

    def refract(self, hit: Hit, mu):
        """Refract at a surface hit, ``mu = n_before / n_after`` (Eq. 3-5).

        Uses the generalised Coddington equations (Kneisly 1964) as written in Eq. 4,
        with u the common tangent (perpendicular to the plane of incidence), v = N x u on the
        wave, v_s = N_s x u on the surface and v' = N' x u after refraction:

            k'_u  = mu k_u + gamma ks_u
            k'_v  = mu k_v cos^2(phi)/cos^2(phi') + gamma ks_v / cos^2(phi')
            k'_uv = mu k_uv cos(phi)/cos(phi') + gamma ks_uv / cos(phi')

        Eq. 4 in the paper prints ks_u in the second line; the tangential surface curvature
        ks_v is correct (Kneisly 1964; checked against brute-force ray bundles in the tests).
        Surface curvatures are taken w.r.t. the normal oriented along the light.
        """
        fr = refraction_frame(self.N, hit, mu, self.t1)
        u, cos_i, cos_t, gamma = fr.u, fr.cos_i, fr.cos_t, fr.gamma
        new_dir, st = fr.new_dir, fr.status
        ksu, ksv, ksuv = fr.ks
        ku, kuv, kv = self.in_basis(u)
        r = cos_i / cos_t
        inv = 1.0 / cos_t
        self.k11 = mu * ku + gamma * ksu
        self.k22 = mu * kv * r * r + gamma * ksv * inv * inv
        self.k12 = mu * kuv * r + gamma * ksuv * inv
        self.N = new_dir
        # re-orthogonalise the basis against the new normal (u is exactly tangent to both)
        self.t1 = u
        self.status = self.status | st | hit.status
        return self

    def toric_lens(self, up, powers, mu, n_after):
        """Thin toric lens perpendicular to N (the eye, §4.4.1, Eq. 7).

        Parameters
        ----------
        up : (3,) world 'up' used to define the eye-lens x axis: x = unit(up x N), y = N x x,
            so x is horizontal and y points upward (paper, Fig. 7).
        powers : tuple (pxx, pxy, pyy) of (n,) arrays, the lens power matrix (D) in (x, y).
        mu : n_before / n_after.
        n_after : index behind the lens.

        Returns the new wavefront (curvatures in the (x, y) basis) — Eq. 7:
        K' = mu K + P / n_after.
        """
        x = cross(np.broadcast_to(up, self.N.shape), self.N)
        xn = np.linalg.norm(x, axis=1)
        deg = xn < 1e-9
        x = np.where(deg[:, None], any_tangent(self.N), x / np.where(deg, 1.0, xn)[:, None])
        kxx, kxy, kyy = self.in_basis(x)
        pxx, pxy, pyy = powers
        return Wavefront(self.N.copy(), x, mu * kxx + pxx / n_after, mu * kxy + pxy / n_after,
                         mu * kyy + pyy / n_after, self.status.copy())
