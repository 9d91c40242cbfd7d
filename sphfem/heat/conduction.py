"""Pair conductances of the SPH heat equation rho c dT/dt = div(k grad T).

Both discretisations are stored as one conductance per neighbour pair, so that

    rho_i c_i dT_i/dt = sum_j g_ij (T_j - T_i)                                   (1)

is :func:`sphfem.operators.apply_pair_weights` divided by rho_i c_i, and the implicit
matrix is :func:`sphfem.operators.pair_weights_matrix` with the same ``g``.

* ``cleary`` -- Cleary (1998), Cleary & Monaghan (1999); Park (2019) eq. 2.68 / 2.97:
      g_ij = k_ij w_ij,   k_ij = 2 k_i k_j / (k_i + k_j)  (harmonic mean),
      w_ij = -2 V_j (dW/dr)(r_ij) / r_ij    (Brookshaw weights, >= 0).
  The 4 k_i k_j/(k_i + k_j) of eq. 2.97 is 2 k_ij.  With equal kernels V_i g_ij = V_j g_ji,
  so the heat m_i c_i dT_i/dt = V_i sum_j g_ij (T_j - T_i) leaving i is what j receives:
  sum_i m_i c_i T_i is conserved to round-off when no ghost supplies heat.
* ``fatehi_manzari`` -- Park (2019) eq. 2.101 idea with the Fatehi & Manzari (2011)
  corrected weights (exact for quadratic T in one material):
      g_ij = k_ij w^FM_ij
  Where the correction matrix of particle i is singular the weights fall back to the
  Brookshaw ones (``ok[i] = False``, counted by the caller).  Not pairwise symmetric, so
  energy is conserved only to truncation error.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem import operators as op

LAPLACIANS = ("cleary", "fatehi_manzari")


@njit(cache=True, parallel=True)
def harmonic_conductance(w, k, offsets, indices):
    """g_ij = w_ij * 2 k_i k_j / (k_i + k_j) (zero where k_i + k_j == 0)."""
    n = offsets.shape[0] - 1
    g = np.empty_like(w)
    for i in prange(n):
        ki = k[i]
        for jj in range(offsets[i], offsets[i + 1]):
            kj = k[indices[jj]]
            s = ki + kj
            g[jj] = w[jj] * (2.0 * ki * kj / s) if s > 0.0 else 0.0
    return g


def pair_conductances(k, x, vol, offsets, indices, R, sigma, kind, period,
                      laplacian: str = "cleary", cond_max: float = op.COND_MAX,
                      plain_rows=None):
    """Conductances g_ij of eq. (1) for every neighbour pair, and the correction mask.

    Returns ``(g, ok)``: ``ok[i]`` is False where the Fatehi-Manzari correction of particle
    ``i`` was singular and the plain weights were used (always True for ``cleary``).
    ``plain_rows`` (bool per particle) forces the plain weights on those rows of the
    corrected form (free-surface particles, see :class:`sphfem.heat.system.HeatSystem`);
    they are not counted in ``ok``.
    """
    args = (x, vol, offsets, indices, R, sigma, kind, period)
    if laplacian == "cleary":
        w = op.laplacian_weights_brookshaw(*args)
        ok = np.ones(x.shape[0], dtype=bool)
    elif laplacian == "fatehi_manzari":
        w, ok = op.laplacian_weights_corrected(*args, cond_max=cond_max)
        if plain_rows is not None and np.any(plain_rows):
            wb = op.laplacian_weights_brookshaw(*args)
            rows = np.repeat(np.asarray(plain_rows, bool), np.diff(offsets))
            w = np.where(rows, wb, w)
    else:
        raise ValueError(f"unknown laplacian {laplacian!r}; expected one of {LAPLACIANS}")
    return harmonic_conductance(w, np.ascontiguousarray(k, dtype=np.float64), offsets,
                                indices), ok


def conduction_rate(T, g, offsets, indices, rho_c):
    """dT_i/dt = sum_j g_ij (T_j - T_i) / (rho_i c_i) for every particle (eq. 1)."""
    return op.apply_pair_weights(T, g, offsets, indices) / rho_c
