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

from sphfem.neighbors import min_image
from sphfem.operators import FASTMATH


@njit(cache=True, fastmath=FASTMATH)
def deformation_gradient(x, vol, offsets, indices, gw, B, period, F):
    """Write F_i (n, dim, dim) for current positions ``x`` (n, dim)."""
    n, dim = x.shape
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
