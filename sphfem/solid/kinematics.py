"""Deformation gradient of a total-Lagrangian SPH body (Park 2019, eq. 2.128, alg. 2.6).

    F_i = [ sum_{j in N0_i} V0_j (x_j - x_i) (x) gW_ij ] . B0_i

over the *reference* neighbours N0_i with the reference gradients gW_ij and correction
B0_i of :mod:`sphfem.solid.reference` (current separations x_j - x_i by minimum image on
periodic axes).  Because B0_i inverts the same moment matrix, F is exact for every affine
motion x = A X + c (F = A), in particular F = Q for a rigid rotation (no spurious strain).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sphfem.kernels import FASTMATH
from sphfem.neighbors import min_image


@njit(cache=True, fastmath=FASTMATH)
def _deformation_gradient_2d(x, vol, offsets, indices, gw, B, period, F):
    """Scalar-register twin of :func:`deformation_gradient` for dim = 2."""
    n = x.shape[0]
    L0, L1 = period[0], period[1]
    for i in range(n):
        a00 = a01 = a10 = a11 = 0.0
        xi0, xi1 = x[i, 0], x[i, 1]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0 = min_image(x[j, 0] - xi0, L0)
            r1 = min_image(x[j, 1] - xi1, L1)
            g0 = vol[j] * gw[jj, 0]
            g1 = vol[j] * gw[jj, 1]
            a00 += r0 * g0
            a01 += r0 * g1
            a10 += r1 * g0
            a11 += r1 * g1
        F[i, 0, 0] = a00 * B[i, 0, 0] + a01 * B[i, 1, 0]
        F[i, 0, 1] = a00 * B[i, 0, 1] + a01 * B[i, 1, 1]
        F[i, 1, 0] = a10 * B[i, 0, 0] + a11 * B[i, 1, 0]
        F[i, 1, 1] = a10 * B[i, 0, 1] + a11 * B[i, 1, 1]


@njit(cache=True, fastmath=FASTMATH)
def deformation_gradient(x, vol, offsets, indices, gw, B, period, F):
    """Write F_i (n, dim, dim) for current positions ``x`` (n, dim)."""
    n, dim = x.shape
    if dim == 2:
        _deformation_gradient_2d(x, vol, offsets, indices, gw, B, period, F)
        return
    A = np.empty((dim, dim))
    r = np.empty(dim)
    for i in range(n):
        A[:, :] = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            vj = vol[j]
            for k in range(dim):
                r[k] = min_image(x[j, k] - x[i, k], period[k])
            for p in range(dim):
                for q in range(dim):
                    A[p, q] += vj * r[p] * gw[jj, q]
        for p in range(dim):
            for q in range(dim):
                s = 0.0
                for k in range(dim):
                    s += A[p, k] * B[i, k, q]
                F[i, p, q] = s
