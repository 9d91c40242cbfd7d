"""Akinci et al. (2013) surface tension and wall adhesion (``surface_tension = "akinci"``).

Cohesion + curvature of Akinci, Akinci & Teschner (2013, ACM TOG 32(6) 182) between fluid
particles, and their adhesion to wall particles:

    a_i = sum_j K_ij [ gamma m_j C(d) r/d  -  gamma_k V_j W_ij (n_i - n_j) ]        (fluid j)
        + sum_b [ gamma_a rho0 V_b C(d) r/d  -  psi gamma_k V_b W_ib (n_i - n_b) ]   (wall b)

    K_ij = 2 rho0 / (rho_i + rho_j),
    n_i = R (sum_fluid V_j grad_i W_ij + psi sum_wall V_b grad_i W_ib),
    C(d) = (32/pi) R^-dim { (1-q)^3 q^3            if 1/2 < q <= 1
                            2 (1-q)^3 q^3 - 1/64   if 0 < q <= 1/2 }.

Notation as in :mod:`sphfem.fluid.passes` (``r = x_j - x_i``, ``d = |r|``, ``q = d / R``;
n_i points into the liquid, as SPlisHSPlasH's gradW(x_i - x_j) gives; the signs are the
paper's).

Calibration.  The paper's curvature force gamma m_i (n_i - n_j) is not dimensionally
consistent with its cohesion gamma m_i m_j C (their ratio depends on the unit system), so
the two get separate constants.  The paper sums the normal differences over the neighbours
with equal weight; here each pair is weighted by V_j W_ij (the SPH mean of the neighbours'
normals): with equal weights the tension of the term depends on the particle arrangement
(flat-interface sums, R = 3 dx: 3.21 on the hexagonal and 2.36 on the square lattice, and a
2D droplet period of 1.07 or 0.89 T_Rayleigh depending on which one calibrates it), with
the kernel weight it does not (0.0392 vs 0.0393).  Both constants are fixed by the
mechanical tension of a flat interface, sigma = int (P_N - P_T) dz with the pair virial
(Kirkwood-Buff), evaluated as lattice sums at the run's R / dx on a hexagonal (2D) / cubic
(3D) lattice (:func:`lattice_sums`; the continuum half-space integral AKINCI_C is their
limit, 6 % (2D) / 14 % (3D) below the cohesion's sum at R = 3 dx).  The curvature forces
are normal to a flat interface; they count through the pressure that balances them (the
surface layer is stretched: positive tension), and that pressure is the SPH one: its
symmetric gradient over the truncated support of the surface layers is not isotropic, and
the tension it holds is 38 % above the continuum pressure's (:func:`sph_curvature_tension`,
R = 3 dx, 2D; 43 % in 3D), which calibrates gamma_k.  ``akinci_curvature`` = phi is the
share of sigma carried by the curvature term: gamma for (1 - phi) sigma, gamma_k [m/s^2]
for phi sigma (:func:`akinci_constants`).

Why the former version blew up (2D droplet: speed guard at step 2): gamma_k was gamma
m_bar / R^dim, i.e. the curvature term carried ~70 sigma of tension (20 times the cohesion's
pull on the outer layer, outward), and c0 was chosen for the Laplace pressure sigma / R_drop
while the cohesion's bulk virial pressure (:func:`internal_pressure`) is ~7 sigma / R.

Why phi defaults to 1 (no cohesion): the cohesion is a pair potential; a particle lattice
held by it is an elastic solid with a shear modulus of the order of its internal pressure
~sigma / R, far above the capillary stress sigma / R_drop.  Measured on the 2D droplet of
``sphfem validate droplet-oscillation`` (R_drop = 10 dx, started from rest in the model's
equilibrium; square-lattice constants, c0 from the cohesion's pressure): the l = 2 period is
0.39-0.45 of Rayleigh's with phi = 0-0.25 and the drop keeps a plastic deformation; with
phi = 0.9 it is 0.94 at R_drop = 10 dx but 0.83 at 20 dx (the cohesion's share of the
stiffness grows with R_drop / R).  The curvature term depends
on the particles only through the colour gradient, which vanishes in the bulk, so it adds
no bulk stiffness.

Density diffusion (delta-SPH) must be off (``[fluid] delta = 0``; :func:`_calibrate` warns
under ``pressure = "wcsph"``, the projection methods do not use it):
the curvature forces on a flat surface are held by a pressure step between the outer
layers, a profile at the particle scale that the diffusive term of the continuity equation
(Antuono et al. 2010; its renormalised gradient falls back at the free surface) relaxes
within ~1e-3 period (dx^2 / (delta h c0)); the surface layers then move to rebuild it and
the surface roughens.  Measured on the 2D droplet (``sphfem validate droplet-oscillation``,
R_drop = 20 dx, 2 periods after 0.3 at rest; rms ripple of the outermost particles,
``surface_ripple``): delta = 0.1 grows the ripple from 0.006 dx to 0.10-0.15 dx within ~1.2
periods (3x c0: 0.18 dx; alpha = 0.1: 0.12 dx); delta = 0 keeps it <= 0.015 dx at R_drop =
10 / 20 / 30 dx, not growing.  The diffusion also relaxed the tension: with delta = 0.1 the
period was 0.973 / 1.013 / 1.048 T_Rayleigh at 10 / 20 / 30 dx under the continuum-pressure
calibration, which with delta = 0 gives 0.890 / 0.875 / 0.866 (a tension of 1.26-1.33 sigma;
interior pressure 1.50 sigma / R_drop at 10 and 20 dx).  With the SPH-pressure calibration
and delta = 0: 1.056 / 1.036 / 1.024 T_Rayleigh (2 periods), ripple <= 0.011 / 0.014 /
0.023 dx, the last third no rougher than the first (tests/test_surface_tension_akinci_ripple.py);
3D droplet (R_drop = 8 dx, 1.6 periods, delta = 0): 1.019 T_Rayleigh (0.883 before).

Wetting (Akinci's adhesion replaced by a construction with a Young relation for both terms):
the wall carries the colour psi = (1 + cos theta) / 2, theta = ``akinci_contact_angle``
(degrees; unset: psi = 0, theta = 180): in the normals, n_i = R (sum_fluid V_j grad_i W_ij
+ psi sum_wall V_b grad_i W_ib), and as the adhesion pair potential gamma_a = psi gamma
with the cohesion kernel (wall particles at the rest density).  For the pair potential the
work of adhesion is psi times the work of cohesion 2 sigma_c; the curvature term is a
discrete Korteweg force (-gamma_k sum (n_i - n_j) ~ grad lap C), whose interface tensions
scale with the square of the colour jump: sigma_LV = sigma, sigma_SL = (1 - psi)^2 sigma,
sigma_SV = psi^2 sigma.  Either way Young's law gives cos theta = 2 psi - 1.  For the
curvature term the wall particles take part with weight psi and normals of the same colour
field (their fluid neighbours plus psi times their wall neighbours, the latter computed once
while the walls do not move): a flat wall acting on a fluid particle through its normal
alone would push it only along the wall normal, and the contact line would not move.  The
wall's repulsion is the wall model's pressure (Adami et al. 2012); the wall pairs of this
pass are not added to the walls' ``f_fluid``.  Measured (sessile drop,
:mod:`sphfem.validation.sessile_drop`, R0/dx = 10, 6 capillary times from a half disc,
angle from the drop's outer layer): the contact line stays near its start, no-slip or not --
60 / 120 deg prescribed gave a mean of 90.2 / 94.1 deg over the second half on the no-slip
Adami wall and 88.0 / 89.8 deg with ``wall_slip = "free-slip"`` (so the pinning is not the
wall's viscous stress: the adhesion and the wall pairs of the curvature term do not make a
net force along the wall that moves the line).  Turning the normals near walls to Young's
direction instead (the CSF's contact angle, :mod:`sphfem.fluid.contact_angle_breinlinger2013`,
walls as liquid in the normals, no wall pairs) gave 84 / 97 deg: the curvature term
-gamma_k sum V_j W_ij (n_i - n_j) is not sigma kappa n, and its response to the turned
normals at the contact line is weak and for theta > 90 deg of the wrong sign along the wall.
The contact angle of the CSF (``csf_contact_angle``) is the working one.  With delta = 0
and the SPH-pressure calibration (session 9; R0/dx = 10, mean over capillary times 3-6):
72.7 / 97.7 deg (free slip), 72.5 / 103.2 deg (no slip) for 60 / 120 deg: the line moves,
about half-way.

Time step: the capillary limit of :meth:`FluidSolver.dt_limits` with the sigma the
constants represent; weakly compressible runs need rho0 c0^2 >> the largest pressure,
:func:`akinci_c0_pressure` (Laplace plus the larger of the cohesion's internal pressure and
the curvature forces' normal stress, both ~sigma / R).
"""

from __future__ import annotations

import logging
import math
from functools import lru_cache

import numpy as np
from numba import njit, prange

from sphfem.fluid.surface import color_gradient, color_gradient_row
from sphfem.fluid.surface_tension import SurfaceTensionMethod, register
from sphfem.kernels import FASTMATH, kernel_f
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param
from sphfem.smallmat import pair_sep

logger = logging.getLogger(__name__)

#: default share of sigma carried by the curvature term (``akinci_curvature``; see the
#: module doc: the cohesion makes the particle lattice elastic)
CURVATURE_DEFAULT = 1.0


def _akinci_c(q):
    q = np.asarray(q, float)
    a = (1.0 - q) ** 3 * q**3
    return 32.0 / math.pi * np.where(q > 0.5, a, 2.0 * a - 1.0 / 64.0)


def _akinci_integral(power: int) -> float:
    q = np.linspace(0.0, 1.0, 20001)
    f = _akinci_c(q) * q**power
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


#: continuum half-space tension of the cohesion: sigma = gamma rho0^2 R^2 AKINCI_C[dim]
AKINCI_C = {2: _akinci_integral(3) / 3.0, 3: math.pi / 8.0 * _akinci_integral(4)}
#: bulk virial pressure p = -AKINCI_P[dim] gamma rho0^2 R of the cohesion
#: (p = -(rho0^2 / (2 dim)) int gamma C(r) r dV)
AKINCI_P = {2: 0.5 * math.pi * _akinci_integral(2), 3: 2.0 * math.pi / 3.0 * _akinci_integral(3)}


def _wendland_dwdq(q, dim):
    """dW/dq * R^dim of the Wendland C2 kernel (the fluid's default kernel)."""
    c = 7.0 / math.pi if dim == 2 else 21.0 / (2.0 * math.pi)
    return c * (-20.0 * q * (1.0 - q) ** 3)


def lattice_tensions(dim: int, R_over_dx: float) -> tuple[float, float]:
    """The calibration sums: S_c of :func:`lattice_sums` (cohesion) and the curvature
    term's tension under the SPH pressure, :func:`sph_curvature_tension`."""
    return lattice_sums(dim, R_over_dx)[0], sph_curvature_tension(dim, R_over_dx)


def _slab(dim: int, R: float, square: bool = False):
    """A slab of particles at unit number density, ``layers`` rows along the last axis,
    periodic sideways (period >= 2 R + one spacing): 2D hexagonal (rows along x), 3D simple
    cubic.  Returns (positions, row index, lateral periods)."""
    if dim == 2 and not square:
        a = math.sqrt(2.0 / math.sqrt(3.0))  # unit density: a^2 sqrt(3)/2 = 1
        dy = a * math.sqrt(3.0) / 2.0
        ncol = int(math.ceil((2 * R + a) / a))
        rows = int(math.ceil(4 * R / dy))
        xs = [((c + 0.5 * (r % 2)) * a, r * dy) for r in range(rows) for c in range(ncol)]
        row = np.repeat(np.arange(rows), ncol)
        return np.array(xs), row, np.array([ncol * a])
    ncol = int(math.ceil(2 * R + 1))
    rows = int(math.ceil(4 * R))
    g = np.meshgrid(*([np.arange(ncol)] * (dim - 1)), np.arange(rows), indexing="ij")
    x = np.stack([v.ravel() for v in g], 1).astype(float)
    return x, x[:, -1].astype(int), np.full(dim - 1, float(ncol))


def _slab_pairs(dim: int, R: float, square: bool):
    """Pair arrays of :func:`_slab` (R in units of the spacing): separations ``d`` (n, n,
    dim, r = x_j - x_i, minimum image sideways), in-support mask, distances (1 outside),
    q = |r| / R, the gradient factor F (grad_i W_ij = F r), the kernel W_ij, the rows and
    the lateral area A."""
    x, row, per = _slab(dim, R, square)
    d = x[None, :, :] - x[:, None, :]
    for k in range(dim - 1):
        d[..., k] -= per[k] * np.round(d[..., k] / per[k])
    dist = np.sqrt((d**2).sum(-1))
    m = (dist > 0) & (dist < R)
    dd = np.where(m, dist, 1.0)
    q = np.where(m, dist / R, 1.0)
    F = np.where(m, -_wendland_dwdq(q, dim) / R**dim / R / dd, 0.0)
    c_w = 7.0 / math.pi if dim == 2 else 21.0 / (2.0 * math.pi)
    W = np.where(m, c_w / R**dim * (1.0 - q) ** 4 * (1.0 + 4.0 * q), 0.0)
    return d, m, dd, q, F, W, row, float(np.prod(per))


def _curvature_pairs(d, F, W, R):
    """V_j W_ij (n_i - n_j)_n of the slab (normals n = R grad C, unit volumes)."""
    nrm = R * np.einsum("ij,ij->i", F, d[..., -1])
    return W * (nrm[:, None] - nrm[None, :])


@lru_cache(maxsize=32)
def lattice_sums(dim: int, R_over_dx: float, square: bool = False) -> tuple[float, float, float]:
    """(S_c, S_k, P_k): tension of a flat interface per unit gamma rho0^2 R^2 (cohesion) and
    per unit gamma_k rho0 R^2 (curvature term), and the largest normal stress of the
    curvature forces per unit gamma_k rho0 R, from pair sums over a slab (4 R thick,
    periodic sideways) of a hexagonal (2D) / simple cubic (3D) lattice of number density
    1/dx^dim, normals and pair weights V_j W_ij from the Wendland C2 kernel.  The cohesion's
    sum depends on the lattice by ~4 % (2D square: 0.00431, hexagonal: 0.00415 at R = 3 dx),
    the weighted curvature sum by 0.3 % (``square``: the square lattice in 2D).

    Mechanical tension of the slab's two faces: 2 sigma A = int (P_N - P_T) dz A with the
    pair virial (Irving-Kirkwood), r = x_j - x_i, over ordered pairs (i, j):

        4 sigma_c A = sum gamma m^2 C(|r|) (r_x^2 - r_n^2) / |r|
        4 sigma_k A = sum m gamma_k V_j W_ij r_n (n_i - n_j)_n        (paper's sign)

    with a continuum (isotropic) pressure balancing the normal stress; the SPH pressure
    that balances the curvature forces is not isotropic in the surface layers, see
    :func:`sph_curvature_tension`, which calibrates the curvature term.  P_k: the normal
    force per area of each row accumulated from the face.
    """
    R = R_over_dx
    d, m, dd, q, F, W, row, A = _slab_pairs(dim, R, square)
    C = np.where(m, _akinci_c(q) / R**dim, 0.0)
    rn = d[..., -1]
    S_c = float(np.sum(C * (d[..., 0] ** 2 - rn**2) / dd)) / (4 * A * R * R)
    dn = _curvature_pairs(d, F, W, R)
    S_k = float(np.sum(rn * dn)) / (4 * A * R * R)
    fy = -dn.sum(1)  # paper's sign, per particle (m = 1)
    rows = row.max() + 1
    per_row = np.bincount(row, weights=fy, minlength=rows) / A
    P_k = float(np.abs(np.cumsum(per_row[: rows // 2])).max())
    return S_c, S_k, P_k / R


@lru_cache(maxsize=32)
def sph_curvature_tension(dim: int, R_over_dx: float, square: bool = False) -> float:
    """Tension of a flat interface per unit gamma_k rho0 R^2 of the curvature term held by
    the SPH pressure: the slab of :func:`lattice_sums` (unit mass and density) with the
    row pressures p_k for which every row is in equilibrium under the curvature forces
    and the symmetric SPH pressure gradient a_i = -sum_j (p_i + p_j) grad_i W_ij (Park 2019
    eq. 2.85; outside the slab p = 0), and the tension from the virial of both pair forces,
    2 sigma A = -1/2 sum_(i,j) (r_n f_n - r_x f_x):

        4 sigma_k A = sum V_j W_ij r_n (n_i - n_j)_n
                      + sum (p_i + p_j) F_ij (r_n^2 - r_x^2).

    The second sum, zero for an isotropic pressure, is the anisotropy of the SPH pressure
    stress in the truncated support of the surface layers.  It raises the tension by 38 %
    at R = 3 dx (2D hexagonal; 42 % square, 32 % at R = 12 dx): a model calibrated by
    :func:`lattice_sums` alone carries ~1.3-1.5 sigma (module doc)."""
    R = R_over_dx
    d, m, dd, q, F, W, row, A = _slab_pairs(dim, R, square)
    rn = d[..., -1]
    dn = _curvature_pairs(d, F, W, R)
    rows = row.max() + 1
    # row balance: -p_i sum_j F r_n - sum_j p_j F r_n - sum_j dn = 0, p constant per row
    Fr = F * rn
    onehot = np.eye(rows)[row]  # (n, rows)
    M = -(onehot.T @ (Fr.sum(1)[:, None] * onehot) + onehot.T @ Fr @ onehot)
    b = np.bincount(row, weights=dn.sum(1), minlength=rows)
    p = np.linalg.lstsq(M, b, rcond=None)[0][row]
    rx = d[..., 0]
    pressure = float(np.sum((p[:, None] + p[None, :]) * F * (rn**2 - rx**2)))
    return (float(np.sum(rn * dn)) + pressure) / (4 * A * R * R)


def akinci_constants(sigma: float, rho0: float, R: float, dx: float, dim: int,
                     share: float = CURVATURE_DEFAULT) -> tuple[float, float]:
    """(gamma, gamma_k) such that the cohesion carries (1 - share) sigma and the curvature
    term share sigma on a lattice of spacing ``dx`` (:func:`lattice_tensions`)."""
    S_c, S_k = lattice_tensions(dim, round(R / dx, 6))
    return ((1.0 - share) * sigma / (rho0 * rho0 * R * R * S_c),
            share * sigma / (rho0 * R * R * S_k))


def akinci_constant(sigma: float, rho0: float, R: float, dim: int) -> float:
    """gamma [m^(dim+1)/(kg s^2)] of the cohesion alone for ``sigma`` [N/m] from the
    continuum half-space integral (the lattice sum of :func:`lattice_tensions` is ~10 %
    above it at R = 3 dx)."""
    return sigma / (rho0 * rho0 * R**2 * AKINCI_C[dim])


def internal_pressure(gamma: float, rho0: float, R: float, dim: int) -> float:
    """Virial pressure [Pa] of the cohesion ``gamma`` in the bulk (negative: tension),
    -AKINCI_P gamma rho0^2 R, of order sigma / R."""
    return -AKINCI_P[dim] * gamma * rho0 * rho0 * R


def akinci_c0_pressure(sigma: float, rho0: float, R: float, dx: float, dim: int,
                       R_drop: float, share: float = CURVATURE_DEFAULT) -> float:
    """The largest pressure [Pa] the model puts on the EOS in a drop of radius ``R_drop``
    (what rho0 c0^2 must exceed ~100-fold for a 1 % density variation): the Laplace
    pressure plus the larger of the cohesion's internal (virial) pressure and the normal
    stress of the curvature forces in the surface layers (:func:`lattice_sums`), both of
    order sigma / R."""
    gamma, gamma_k = akinci_constants(sigma, rho0, R, dx, dim, share)
    P_k = lattice_sums(dim, round(R / dx, 6))[2] * gamma_k * rho0 * R
    return (dim - 1) * sigma / R_drop + max(-internal_pressure(gamma, rho0, R, dim), P_k)


def adhesion_ratio(theta_deg: float | None) -> float:
    """The wall's colour psi = (1 + cos theta) / 2 for the contact angle ``theta_deg``
    (None: 0, no wetting; module doc)."""
    if theta_deg is None:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.radians(theta_deg)))


def contact_angle_of_ratio(ratio: float) -> float:
    """Inverse of :func:`adhesion_ratio`: theta [deg]."""
    return math.degrees(math.acos(min(1.0, max(-1.0, 2.0 * ratio - 1.0))))


@njit(cache=True, inline="always")
def _akinci_shape(q):
    a = (1.0 - q) * (1.0 - q) * (1.0 - q) * q * q * q
    if q > 0.5:
        return 32.0 / math.pi * a
    return 32.0 / math.pi * (2.0 * a - 1.0 / 64.0)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def akinci_accel(x, m, V, rho, kind, offsets, indices, R, sigma, kernel_code, gamma, gamma_k,
                 gamma_a, psi, rho0, period, nrm, acc):
    """acc[i] += Akinci cohesion + curvature (fluid j) + adhesion (wall j) on fluid rows;
    ``nrm`` = R grad C over fluid neighbours (into the liquid), ``gamma_k`` [m/s^2],
    ``gamma_a`` in the units of ``gamma``."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    Rd = R ** dim
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        ri = rho[i]
        ni0 = nrm[i, 0]
        ni1 = nrm[i, 1] if dim > 1 else 0.0
        ni2 = nrm[i, 2] if dim > 2 else 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            fluid = kind[j] == FLUID
            if not fluid and (kind[j] != WALL or psi == 0.0):
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            wk = V[j] * sigma * kernel_f(d / R, kernel_code)  # kernel weight of the pair
            if fluid:
                K = 2.0 * rho0 / (ri + rho[j])
                # cohesion: -gamma m_j C (x_i - x_j)/d = +gamma m_j C r/d
                fc = K * gamma * m[j] * _akinci_shape(d / R) / (Rd * d)
                fk = -K * gamma_k * wk  # the paper's sign: adds tension (module doc)
                a0 += fc * r0 + fk * (ni0 - nrm[j, 0])
                if dim > 1:
                    a1 += fc * r1 + fk * (ni1 - nrm[j, 1])
                if dim > 2:
                    a2 += fc * r2 + fk * (ni2 - nrm[j, 2])
            else:  # wall of colour psi: adhesion (rest mass rho0 V_b) and curvature pair
                fa = gamma_a * rho0 * V[j] * _akinci_shape(d / R) / (Rd * d)
                fw = -psi * gamma_k * wk
                a0 += fa * r0 + fw * (ni0 - nrm[j, 0])
                if dim > 1:
                    a1 += fa * r1 + fw * (ni1 - nrm[j, 1])
                if dim > 2:
                    a2 += fa * r2 + fw * (ni2 - nrm[j, 2])
        acc[i, 0] += a0
        if dim > 1:
            acc[i, 1] += a1
        if dim > 2:
            acc[i, 2] += a2


def _share(pa) -> float:
    v = pa.st_params.get("akinci_curvature", getattr(pa, "akinci_curvature", None))
    return CURVATURE_DEFAULT if v is None else float(v)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def wall_rows_gradient(x, V, kind, offsets, indices, R, sigma, kernel_code, period, g):
    """g[b] = sum_fluid V_j grad_b W_bj for wall rows b (their fluid neighbours)."""
    n, dim = x.shape
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        if kind[i] != WALL:
            continue
        g0, g1, g2 = color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kernel_code,
                                        period, periodic, True)
        g[i, 0] = g0
        if dim > 1:
            g[i, 1] = g1
        if dim > 2:
            g[i, 2] = g2


def _calibrate(pa, m_bar: float, R: float, dim: int):
    """((gamma, gamma_k, gamma_a), the sigma they represent) on the lattice of the mean
    particle spacing dx = (m_bar / rho0)^(1/dim): from the material's sigma, or from
    ``akinci_gamma`` (gamma_k then keeps the share ``akinci_curvature``); gamma_a from the
    contact angle (the wall colour psi, module doc)."""
    dx = (m_bar / pa.rho0) ** (1.0 / dim)
    share = _share(pa)
    if share > 0.0 and getattr(pa, "delta", 0.0) > 0.0 and getattr(pa, "pressure",
                                                                   "wcsph") == "wcsph":
        logger.warning("surface_tension = 'akinci' with delta = %g: the density diffusion "
                       "relaxes the pressure step that holds the curvature forces in the "
                       "surface layers; the surface roughens and the tension drifts "
                       "(sphfem.fluid.surface_tension_akinci2013): set [fluid] delta = 0",
                       pa.delta)
    S_c, S_k = lattice_tensions(dim, round(R / dx, 6))
    gamma = pa.st_params.get("akinci_gamma", getattr(pa, "akinci_gamma", None))
    if gamma is None:
        gamma, gamma_k = akinci_constants(pa.sigma, pa.rho0, R, dx, dim, share)
        sig = pa.sigma
    else:
        if share >= 1.0:
            raise ValueError("akinci_gamma needs akinci_curvature < 1 (gamma is the cohesion's)")
        sig = gamma * pa.rho0**2 * R**2 * S_c / (1.0 - share)
        gamma_k = share * sig / (pa.rho0 * R * R * S_k)
    # wetting (module doc): the wall's colour psi = (1 + cos theta) / 2 in the normals and
    # the adhesion pair potential gamma_a = psi gamma
    psi = adhesion_ratio(_param(pa, "akinci_contact_angle", None))
    return (float(gamma), float(gamma_k), float(psi * gamma), float(psi)), float(sig)


def _param(pa, key, default):
    v = pa.st_params.get(key, getattr(pa, key, None))
    return default if v is None else v


class AkinciState:
    """Work arrays of the pass: the normals n = R grad C of fluid and wall rows, the colour
    gradient over fluid and wall neighbours, and the walls' own part of theirs (walls do not
    move: computed once, from a list of the wall particles alone)."""

    def __init__(self, n: int, dim: int):
        self.n = n
        self.nrm = np.zeros((n, dim))
        self.gall = np.zeros((n, dim))
        self.gww = None
        self.wall_key = None


def _wall_wall_gradient(solver, state):
    """sum_wall V_b' grad_b W_bb' of every wall row b (kept while the walls do not move)."""
    p = solver.p
    w = np.flatnonzero(p.kind == WALL)
    key = (w.size, float(p.x[w].sum()) if w.size else 0.0)
    if state.gww is not None and state.wall_key == key:
        return state.gww
    g = np.zeros((p.n, solver.dim))
    if w.size:
        xw = np.ascontiguousarray(p.x[w])
        nl = build_neighbor_list(xw, solver.R, xw.min(0) - solver.R, xw.max(0) + solver.R,
                                 solver.period)
        gw = np.zeros_like(xw)
        color_gradient(xw, np.ascontiguousarray(p.vol[w]), np.full(w.size, FLUID, p.kind.dtype),
                       nl.offsets, nl.indices, solver.R, solver.sigma, solver.kernel_code,
                       solver.period, True, gw)
        g[w] = gw
    state.gww, state.wall_key = g, key
    return g


def _accelerate(solver, state):
    p, s, nl, R, pa = solver.p, solver._scratch, solver.nbrs, solver.R, solver.params
    if state is None or state.n != p.n:
        state = AkinciState(p.n, solver.dim)
    gamma, gamma_k, gamma_a, psi = solver.st_constant
    color_gradient(p.x, s.V, p.kind, nl.offsets, nl.indices, R, solver.sigma, solver.kernel_code,
                   solver.period, True, state.nrm)
    if psi > 0.0:  # the wall's colour psi: n = R (grad C_fluid + psi grad C_wall), all rows
        color_gradient(p.x, s.V, p.kind, nl.offsets, nl.indices, R, solver.sigma,
                       solver.kernel_code, solver.period, False, state.gall)
        state.nrm += psi * (state.gall - state.nrm)
        wall_rows_gradient(p.x, s.V, p.kind, nl.offsets, nl.indices, R, solver.sigma,
                           solver.kernel_code, solver.period, state.gall)
        wall = p.kind == WALL
        state.nrm[wall] = state.gall[wall] + psi * _wall_wall_gradient(solver, state)[wall]
    state.nrm *= R
    akinci_accel(p.x, p.m, s.V, p.rho, p.kind, nl.offsets, nl.indices, R, solver.sigma,
                 solver.kernel_code, gamma, gamma_k, gamma_a, psi, pa.rho0, solver.period,
                 state.nrm, p.acc)
    return state


_WHEN = ("surface_tension", ("akinci",))

METHOD = register(SurfaceTensionMethod(
    name="akinci",
    doc="cohesion + curvature of Akinci et al. (2013) with adhesion to walls; both terms "
        "calibrated to sigma by lattice sums of the flat-interface tension, akinci_curvature "
        "the curvature term's share (default 1: the cohesion makes the particle lattice "
        "elastic), wetting from the contact angle (see "
        "sphfem.fluid.surface_tension_akinci2013)",
    params=(
        Param("akinci_gamma", float, None, positive=True, when=_WHEN,
              doc="Akinci coefficient gamma [m^(dim+1)/(kg s^2)]; unset: computed from the "
                  "material's sigma [N/m]"),
        Param("akinci_curvature", float, CURVATURE_DEFAULT, ge=0.0, le=1.0, when=_WHEN,
              doc="share of sigma carried by the curvature term (0: cohesion only); "
                  "both terms calibrated by lattice sums"),
        Param("akinci_contact_angle", float, None, ge=0.0, le=180.0, when=_WHEN,
              doc="equilibrium contact angle on walls [deg]: the wall's colour psi = "
                  "(1 + cos theta) / 2 in the normals and the adhesion gamma_a = psi gamma; "
                  "unset: no wetting (180 deg)"),
    ),
    constant_key="akinci_gamma",
    calibrate=_calibrate,
    accelerate=_accelerate,
))
