"""The meridian part of the axisymmetric surface tension as a pair force (Akinci et al. 2013).

``[fluid] csf_meridian = "pair"`` (axisymmetric scenes): the surface force of
:class:`~sphfem.fluid.axisymmetric_surface_tension.AxisymmetricCSF` is split by eq. (1) of
that module into the meridian curvature's part and the hoop curvature's part; the hoop part
stays the CSF's sigma kappa_h grad C, the meridian part becomes the curvature term of Akinci,
Akinci & Teschner (2013, ACM TOG 32(6) 182) in the (r, z) half-plane,

    a_i = -gamma_k sum_j c_j K_ij A_j W_ij (n_i - n_j),     n_i = R sum_j c_j A_j grad_i W_ij,

over fluid rows (colour c = 1), wall rows (c = psi) and their axis mirrors, with the planar
areas A = M / (2 pi r rho) as particle volumes, K_ij = 2 rho0 / (rho_i + rho_j), R the
support.  gamma_k is calibrated to sigma on a flat interface of the square lattice of the
run's spacing with the SPH pressure that holds it
(:func:`~sphfem.fluid.surface_tension_akinci2013.sph_curvature_tension`, as the planar
``surface_tension = "akinci"``).

Why (examples/axisymmetric/taylor_culick.py): the CSF is a field force sigma kappa grad C
whose curvature at the end of a film is of order 1 / dx, so the few rings of the end are
pulled back into the film, wedge its rows apart and the rim forms hollow (a free film 4
rows thick, c0 = 10 V_TC, planar solver and the axisymmetric solver's planar mode alike:
the rim splits into sheets and sprays; 0.59 of Taylor-Culick's speed at 4 rows and slowing,
at 8 rows the retraction stops).  The pair form is a sum of equal and opposite pair terms,
so the net force on any group of rings is the flux through its edge (the line force 2 sigma
of a free
film's end whatever its shape): with it the rim stays compact and retracts at a steady
0.84 / 0.83 V_TC at 4 / 8 rows (the planar solver's Akinci: 0.85 / 0.88 / 0.70 at 4 / 8 /
16; the shortfall, an effective tension ~0.7 sigma on films thinner than a few supports, is
not explained yet).  A spreading lamella is stopped by exactly this pull.

The axis: next to it the planar areas A = M / (2 pi r rho) grow as 1 / r and the axis
mirrors lie 2 r away, so the planar pair sums are distorted there as the CSF's colour
gradient is (:mod:`sphfem.fluid.axisymmetric_surface_tension`, "Curvature at the axis"); with
the pair force alone up to the axis the 10 m/s impact's apex and lamella centre went into
a tension of -0.5 to -1 MPa within 1 t_c (D/dx 64 and 90) and a ring's density below zero.
So within :data:`PAIR_AXIS_BAND` supports of the axis the meridian part blends (smoothstep)
into the CSF's sigma kappa_m grad C.

Not yet for the impact (so off by default): the 10 m/s water droplet at D/dx 64 (fluid
only, frames every 0.25 t_c) runs with it, but its lamella comes apart into spray from
0.5 t_c (rings strewn out to 2.5 D along the wall by 1 t_c, where the CSF's body has
reached 1.5 D): the pair force's tension lives in the surface rings' pressure (-0.3 to
-1.5e5 Pa at the sheet's tip, a few sigma / R), and the one- and two-ring sheet ejected at
the root breaks under it.  The CSF holds those rings at rho >= rho0 instead (``[fluid]``
free-surface treatment), which the pair model cannot have.

Walls: their colour psi = (1 + cos theta) / 2 (90 deg: psi = 1/2, the CSF's wall behaviour:
a film on a wall pulled by sigma), in the normals and in the pairs, as in
:mod:`sphfem.fluid.surface_tension_akinci2013` (Young's relation gives cos theta = 2 psi -
1 for this term).  The walls' normals need their wall neighbours, which the fluid's list
does not hold (wall rows list fluid rows only): that part is summed once (the walls do not
move) over the wall rows and their axis mirrors.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.fluid.passes import grad_factor
from sphfem.kernels import FASTMATH, kernel_f
from sphfem.smallmat import pair_sep

#: the wall's colour for a 90 degree contact angle (module docstring)
WALL_COLOUR_90 = 0.5
#: the pair force is blended in from PAIR_AXIS_BAND[0] R to PAIR_AXIS_BAND[1] R off the axis
#: (smoothstep), the CSF's meridian part taking the rest (module docstring)
PAIR_AXIS_BAND = (2.0, 4.0)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pair_normals(x, A, col, n, offsets, indices, R, fac2, kcode, Lz, out):
    """out[i] += R sum_j col_j A_j grad_i W_ij over the listed neighbours of the real rows
    i < n with col_i > 0 (the other rows untouched)."""
    R2 = R * R
    period = np.array([0.0, Lz])
    for i in prange(n):
        if col[i] <= 0.0:
            continue
        g0 = 0.0
        g1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if col[j] <= 0.0:
                continue
            r0, r1, _ = pair_sep(x, i, j, 2, period, Lz > 0.0)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            t = col[j] * A[j] * grad_factor(math.sqrt(d2), R, fac2, kcode)
            g0 += t * r0
            g1 += t * r1
        out[i, 0] += R * g0
        out[i, 1] += R * g1


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pair_force(x, A, rho, col, fluid, n, offsets, indices, R, ks, kcode, Lz, gamma_k, rho0,
               nrm, acc):
    """acc[i] += -gamma_k sum_j c_j K_ij A_j W_ij (n_i - n_j) for the real fluid rows i < n
    (module docstring; ``ks`` the kernel's normalisation, W = ks kernel_f(d / R))."""
    R2 = R * R
    period = np.array([0.0, Lz])
    for i in prange(n):
        if not fluid[i]:
            continue
        a0 = 0.0
        a1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if col[j] <= 0.0:
                continue
            r0, r1, _ = pair_sep(x, i, j, 2, period, Lz > 0.0)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            K = 2.0 * rho0 / (rho[i] + rho[j]) if fluid[j] else 1.0
            w = -gamma_k * col[j] * K * A[j] * ks * kernel_f(math.sqrt(d2) / R, kcode)
            a0 += w * (nrm[i, 0] - nrm[j, 0])
            a1 += w * (nrm[i, 1] - nrm[j, 1])
        acc[i, 0] += a0
        acc[i, 1] += a1


def static_wall_normals(xw, Aw, R: float, kernel_code: int, Lz: float = 0.0,
                        axis: bool = True) -> np.ndarray:
    """R sum_b A_b grad W_ab over the wall rows ``xw`` (and their axis mirrors (-r, z) when
    ``axis``) for each wall row a: the walls' own part of their normals (colour 1; scaled
    by psi by the caller)."""
    from scipy.spatial import cKDTree

    xw = np.asarray(xw, float)
    m = xw.shape[0]
    out = np.zeros((m, 2))
    if m == 0:
        return out
    src = [xw]
    if axis:
        src.append(xw * np.array([-1.0, 1.0]))
    if Lz > 0.0:
        src = [s + np.array([0.0, k * Lz]) for s in src for k in (-1.0, 0.0, 1.0)]
    xs = np.vstack(src)
    As = np.tile(np.asarray(Aw, float), len(src))
    fac2 = kernels.kernel_sigma(kernel_code, 2, R) / (R * R)
    pairs = cKDTree(xw).query_ball_tree(cKDTree(xs), R)
    for a, js in enumerate(pairs):
        for j in js:
            r = xs[j] - xw[a]
            d = math.hypot(r[0], r[1])
            if d == 0.0 or d >= R:
                continue
            out[a] += R * As[j] * grad_factor(d, R, fac2, kernel_code) * r
    return out


def curvature_constant(sigma: float, rho0: float, R: float, dx: float) -> float:
    """gamma_k [m/s^2] for ``sigma`` [N/m] on the square lattice of spacing ``dx`` with
    support ``R`` (module docstring)."""
    from sphfem.fluid.surface_tension_akinci2013 import sph_curvature_tension

    S_k = sph_curvature_tension(2, round(R / dx, 6), square=True)
    return sigma / (rho0 * R * R * S_k)


def wall_colour(theta_deg: float | None) -> float:
    """psi = (1 + cos theta) / 2 for the contact angle ``theta_deg`` [deg] (None: 90)."""
    if theta_deg is None:
        return WALL_COLOUR_90
    return 0.5 * (1.0 + math.cos(math.radians(theta_deg)))
