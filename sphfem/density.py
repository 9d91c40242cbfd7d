"""Summation density rho_i = m_i W(0) + sum_j m_j W(|x_i - x_j|), over a CSR neighbour list.

The neighbour list (:mod:`sphfem.neighbors`) excludes self, so the self term is added
explicitly.  The loop is a gather over destination particles (``prange``), race free and,
with the sorted neighbour segments, independent of the thread count.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.kernels import kernel_code, kernel_f, kernel_sigma
from sphfem.neighbors import FASTMATH, NeighborList, min_image


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def summation_density(x, m, offsets, indices, R, sigma, kind, period):
    """rho_i = m_i W(0) + sum_j m_j W_ij for support radius ``R`` and ``sigma(kind, dim, R)``.

    ``x`` (n, dim) positions, ``m`` (n,) masses, ``offsets``/``indices`` the CSR neighbour
    list (self excluded), ``kind`` a kernel code of :mod:`sphfem.kernels`, ``period`` (dim,)
    periodic lengths (0: not periodic).
    """
    n, dim = x.shape
    rho = np.empty(n)
    inv_R = 1.0 / R
    w0 = kernel_f(0.0, kind)
    L0 = period[0]
    L1 = period[1] if dim > 1 else 0.0
    L2 = period[2] if dim > 2 else 0.0
    for i in prange(n):
        xi0 = x[i, 0]
        xi1 = x[i, 1] if dim > 1 else 0.0
        xi2 = x[i, 2] if dim > 2 else 0.0
        acc = 0.0
        # unsigned indices: no negative-index wraparound code, so the loop vectorises
        for q in range(np.uint64(offsets[i]), np.uint64(offsets[i + 1])):
            j = np.uint64(indices[q])
            d = min_image(xi0 - x[j, 0], L0)
            r2 = d * d
            if dim > 1:
                d = min_image(xi1 - x[j, 1], L1)
                r2 += d * d
            if dim > 2:
                d = min_image(xi2 - x[j, 2], L2)
                r2 += d * d
            acc += m[j] * kernel_f(np.sqrt(r2) * inv_R, kind)
        rho[i] = sigma * (m[i] * w0 + acc)
    return rho


def density(x, m, nbrs: NeighborList, kernel: str = "wendland_c2") -> np.ndarray:
    """Summation density with the neighbour list's radius as the kernel support radius."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    kind = kernel_code(kernel)
    sigma = kernel_sigma(kind, x.shape[1], nbrs.radius)
    m = np.ascontiguousarray(np.broadcast_to(np.asarray(m, dtype=np.float64), (x.shape[0],)))
    return summation_density(
        x, m, nbrs.offsets, nbrs.indices, nbrs.radius, sigma, kind, nbrs.period
    )
