"""Internal forces of a total-Lagrangian SPH body: momentum-conserving reference divergence
and hourglass control.

Divergence of P (Ganzenmueller 2015 eq. 9; Vignjevic et al. 2006; Park 2019 eq. 2.129 and
alg. 2.7), written as the force on particle i (m_i a_i = f_i):

    f_i = sum_{j in N0_i} V0_i V0_j (P_i B0_i gW_ij - P_j B0_j gW_ji)
        = sum_j V0_i V0_j (P_i B0_i + P_j B0_j) gW_ij            (gW_ji = -gW_ij)

Each pair contributes equal and opposite forces, so the total linear momentum is conserved
to round-off (the thesis' "popular formulation"; its eq. 2.129 has a stray rho0).

Hourglass control (Ganzenmueller 2015, "An hourglass control algorithm for Lagrangian
Smooth Particle Hydrodynamics", CMAME 286): the deformation gradient is blind to
zero-energy particle modes; the error of the linear prediction of a neighbour's position

    eps^i_ij = F_i X_ij - x_ij,      delta^i_ij = eps^i_ij . x_ij / |x_ij|

(X_ij = X_j - X_i, x_ij = x_j - x_i) is penalised with the pairwise central force

    f^HG_i = -(alpha_hg / 2) sum_j V0_i V0_j W0_ij (E_ij / |X_ij|^2)
              (delta^i_ij + delta^j_ji) x_ij / |x_ij|,     E_ij = (E_i + E_j) / 2 ,

which vanishes for every affine motion (eps = 0) and is antisymmetric in (i, j).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sphfem.kernels import FASTMATH
from sphfem.neighbors import min_image


@njit(cache=True, fastmath=FASTMATH)
def stress_forces(vol, offsets, indices, gw, B, P, f):
    """Write f_i = sum_j V_i V_j (P_i B_i + P_j B_j) gW_ij into f (n, dim)."""
    n, dim = f.shape
    PB = np.empty((n, dim, dim))
    for i in range(n):
        for p in range(dim):
            for q in range(dim):
                s = 0.0
                for k in range(dim):
                    s += P[i, p, k] * B[i, k, q]
                PB[i, p, q] = s
    if dim == 2:
        for i in range(n):
            f0 = f1 = 0.0
            p00, p01, p10, p11 = PB[i, 0, 0], PB[i, 0, 1], PB[i, 1, 0], PB[i, 1, 1]
            for jj in range(offsets[i], offsets[i + 1]):
                j = indices[jj]
                g0 = vol[j] * gw[jj, 0]
                g1 = vol[j] * gw[jj, 1]
                f0 += (p00 + PB[j, 0, 0]) * g0 + (p01 + PB[j, 0, 1]) * g1
                f1 += (p10 + PB[j, 1, 0]) * g0 + (p11 + PB[j, 1, 1]) * g1
            f[i, 0] = vol[i] * f0
            f[i, 1] = vol[i] * f1
        return
    for i in range(n):
        for p in range(dim):
            f[i, p] = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            vv = vol[i] * vol[j]
            for p in range(dim):
                s = 0.0
                for q in range(dim):
                    s += (PB[i, p, q] + PB[j, p, q]) * gw[jj, q]
                f[i, p] += vv * s


@njit(cache=True, fastmath=FASTMATH)
def _hourglass_2d(x, X, vol, offsets, indices, w, F, E, alpha_hg, period, f):
    """Scalar twin of :func:`hourglass_forces` for dim = 2."""
    L0, L1 = period[0], period[1]
    for i in range(x.shape[0]):
        fi0 = fi1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            R0 = min_image(X[j, 0] - X[i, 0], L0)
            R1 = min_image(X[j, 1] - X[i, 1], L1)
            r0 = min_image(x[j, 0] - x[i, 0], L0)
            r1 = min_image(x[j, 1] - x[i, 1], L1)
            D2 = R0 * R0 + R1 * R1
            d2 = r0 * r0 + r1 * r1
            if D2 == 0.0 or d2 == 0.0:
                continue
            e0 = (F[i, 0, 0] + F[j, 0, 0]) * R0 + (F[i, 0, 1] + F[j, 0, 1]) * R1 - 2.0 * r0
            e1 = (F[i, 1, 0] + F[j, 1, 0]) * R0 + (F[i, 1, 1] + F[j, 1, 1]) * R1 - 2.0 * r1
            c = (-0.25 * alpha_hg * vol[i] * vol[j] * w[jj] * (E[i] + E[j]) / D2
                 * (e0 * r0 + e1 * r1) / d2)
            fi0 += c * r0
            fi1 += c * r1
        f[i, 0] += fi0
        f[i, 1] += fi1


@njit(cache=True, fastmath=FASTMATH)
def hourglass_forces(x, X, vol, offsets, indices, w, F, E, alpha_hg, period, f):
    """Add the Ganzenmueller (2015) hourglass forces to f (n, dim)."""
    n, dim = x.shape
    if dim == 2:
        _hourglass_2d(x, X, vol, offsets, indices, w, F, E, alpha_hg, period, f)
        return
    R0 = np.empty(dim)
    r = np.empty(dim)
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            D2 = 0.0
            d2 = 0.0
            for k in range(dim):
                R0[k] = min_image(X[j, k] - X[i, k], period[k])
                r[k] = min_image(x[j, k] - x[i, k], period[k])
                D2 += R0[k] * R0[k]
                d2 += r[k] * r[k]
            if D2 == 0.0 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            delta = 0.0  # (delta^i_ij + delta^j_ji) = ((F_i + F_j) X_ij - 2 x_ij) . x_ij / d
            for p in range(dim):
                s = 0.0
                for q in range(dim):
                    s += (F[i, p, q] + F[j, p, q]) * R0[q]
                delta += (s - 2.0 * r[p]) * r[p]
            delta /= d
            c = -0.5 * alpha_hg * vol[i] * vol[j] * w[jj] * 0.5 * (E[i] + E[j]) / D2 * delta / d
            for p in range(dim):
                f[i, p] += c * r[p]


@njit(cache=True, fastmath=FASTMATH)
def pair_forces_2d(x, vol, offsets, indices, vgw, dX, hgw, B, P, F, E, alpha_hg, period, f):
    """Fused 2D pass: f = :func:`stress_forces` + :func:`hourglass_forces`, with the
    per-pair constants of the reference configuration precomputed: ``vgw`` = V0_j gW_ij,
    ``dX`` = X_ij, ``hgw`` = V0_i V0_j W0_ij / |X_ij|^2 (0 for coincident particles)."""
    n = x.shape[0]
    L0, L1 = period[0], period[1]
    PB = np.empty((n, 2, 2))
    for i in range(n):
        for p in range(2):
            for q in range(2):
                PB[i, p, q] = P[i, p, 0] * B[i, 0, q] + P[i, p, 1] * B[i, 1, q]
    c0 = -0.25 * alpha_hg
    for i in range(n):
        fs0 = fs1 = fh0 = fh1 = 0.0
        p00, p01, p10, p11 = PB[i, 0, 0], PB[i, 0, 1], PB[i, 1, 0], PB[i, 1, 1]
        f00, f01, f10, f11 = F[i, 0, 0], F[i, 0, 1], F[i, 1, 0], F[i, 1, 1]
        xi0, xi1, Ei = x[i, 0], x[i, 1], E[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            g0, g1 = vgw[jj, 0], vgw[jj, 1]
            fs0 += (p00 + PB[j, 0, 0]) * g0 + (p01 + PB[j, 0, 1]) * g1
            fs1 += (p10 + PB[j, 1, 0]) * g0 + (p11 + PB[j, 1, 1]) * g1
            if alpha_hg != 0.0:
                r0 = min_image(x[j, 0] - xi0, L0)
                r1 = min_image(x[j, 1] - xi1, L1)
                d2 = r0 * r0 + r1 * r1
                if d2 == 0.0:
                    continue
                R0, R1 = dX[jj, 0], dX[jj, 1]
                e0 = (f00 + F[j, 0, 0]) * R0 + (f01 + F[j, 0, 1]) * R1 - 2.0 * r0
                e1 = (f10 + F[j, 1, 0]) * R0 + (f11 + F[j, 1, 1]) * R1 - 2.0 * r1
                c = hgw[jj] * (Ei + E[j]) * (e0 * r0 + e1 * r1) / d2
                fh0 += c * r0
                fh1 += c * r1
        f[i, 0] = vol[i] * fs0 + c0 * fh0
        f[i, 1] = vol[i] * fs1 + c0 * fh1


@njit(cache=True, fastmath=FASTMATH)
def hourglass_energy(x, offsets, indices, dX, hgw, F, E, alpha_hg, period):
    """Pseudo-potential of the hourglass forces with F frozen: per pair (alpha_hg / 16)
    V_i V_j W0_ij (E_i + E_j) / |X_ij|^2 g^2, g = ((F_i + F_j) X_ij - 2 x_ij) . x_ij /
    |x_ij| (the force is -d/dx of it when F and the direction are held; summed over the CSR
    list, which holds each pair twice).  Accounts for the energy the hourglass control
    stores in the energy balance of the diagnostics."""
    n, dim = x.shape
    total = 0.0
    r = np.empty(dim)
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d2 = 0.0
            for k in range(dim):
                r[k] = min_image(x[j, k] - x[i, k], period[k])
                d2 += r[k] * r[k]
            if d2 == 0.0 or hgw[jj] == 0.0:
                continue
            g = 0.0
            for p in range(dim):
                s = 0.0
                for q in range(dim):
                    s += (F[i, p, q] + F[j, p, q]) * dX[jj, q]
                g += (s - 2.0 * r[p]) * r[p]
            g /= np.sqrt(d2)
            total += hgw[jj] * (E[i] + E[j]) * g * g
    return alpha_hg / 32.0 * total
