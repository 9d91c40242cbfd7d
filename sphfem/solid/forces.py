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

from sphfem.neighbors import min_image
from sphfem.operators import FASTMATH


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
def hourglass_forces(x, X, vol, offsets, indices, w, F, E, alpha_hg, period, f):
    """Add the Ganzenmueller (2015) hourglass forces to f (n, dim)."""
    n, dim = x.shape
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
