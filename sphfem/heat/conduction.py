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

  Positivity limiter (optional, on by default in the heat module): on disordered particles
  some corrected weights are negative, and the explicit scheme can then grow without bound
  at any step (eigenvalues with positive real part; 20 % random disorder blows up within
  100 steps).  A row with a negative weight is blended with its Brookshaw row,
      w_ij <- (1 - beta_i) w^FM_ij + beta_i w^B_ij,
      beta_i = max_{j: w^FM_ij < 0} (-w^FM_ij) / (w^B_ij - w^FM_ij),
  the smallest blend with every weight >= 0.  Each row is then a positive combination of
  differences, so its Gershgorin disc lies in the left half-plane, Heun at the Gershgorin
  step is stable and keeps the maximum principle.  Rows whose weights are all >= 0
  (lattice interiors) keep the exact corrected weights.
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


@njit(cache=True, parallel=True)
def positivity_limit(w, wb, offsets, limited):
    """Blend each row of ``w`` holding a negative weight with the non-negative row ``wb``
    just enough that every weight is >= 0 (module docstring); in place.  ``limited[i]`` is
    set to the blend factor beta_i (0 where the row was left alone)."""
    n = offsets.shape[0] - 1
    for i in prange(n):
        beta = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            if w[jj] < 0.0:
                beta = max(beta, -w[jj] / (wb[jj] - w[jj]))
        limited[i] = beta
        if beta > 0.0:
            for jj in range(offsets[i], offsets[i + 1]):
                w[jj] = max((1.0 - beta) * w[jj] + beta * wb[jj], 0.0)


def pair_conductances(k, x, vol, offsets, indices, R, sigma, kind, period,
                      laplacian: str = "cleary", cond_max: float = op.COND_MAX,
                      plain_rows=None, limiter_rows=None):
    """Conductances g_ij of eq. (1) for every neighbour pair, the correction mask and the
    limiter's blend factors.

    Returns ``(g, ok, beta)``: ``ok[i]`` is False where the Fatehi-Manzari correction of
    particle ``i`` was singular and the plain weights were used (always True for
    ``cleary``).  ``plain_rows`` (bool per particle) forces the plain weights on those rows
    of the corrected form (free-surface particles, see
    :class:`sphfem.heat.system.HeatSystem`); they are not counted in ``ok``.
    ``limiter_rows`` (bool per particle, or None for no limiter) are the rows the
    positivity limiter may blend; ``beta[i]`` is its blend factor (0: exact weights kept).
    """
    args = (x, vol, offsets, indices, R, sigma, kind, period)
    beta = np.zeros(x.shape[0])
    if laplacian == "cleary":
        w = op.laplacian_weights_brookshaw(*args)
        ok = np.ones(x.shape[0], dtype=bool)
    elif laplacian == "fatehi_manzari":
        w, ok = op.laplacian_weights_corrected(*args, cond_max=cond_max)
        wb = None
        if plain_rows is not None and np.any(plain_rows):
            wb = op.laplacian_weights_brookshaw(*args)
            rows = np.repeat(np.asarray(plain_rows, bool), np.diff(offsets))
            w = np.where(rows, wb, w)
        if limiter_rows is not None and np.any(limiter_rows):
            wb = op.laplacian_weights_brookshaw(*args) if wb is None else wb
            rows = np.repeat(~np.asarray(limiter_rows, bool), np.diff(offsets))
            w = np.ascontiguousarray(w)
            w_keep = w[rows].copy()
            positivity_limit(w, wb, offsets, beta)
            w[rows] = w_keep
            beta[~np.asarray(limiter_rows, bool)] = 0.0
    else:
        raise ValueError(f"unknown laplacian {laplacian!r}; expected one of {LAPLACIANS}")
    return harmonic_conductance(w, np.ascontiguousarray(k, dtype=np.float64), offsets,
                                indices), ok, beta


def conduction_rate(T, g, offsets, indices, rho_c):
    """dT_i/dt = sum_j g_ij (T_j - T_i) / (rho_i c_i) for every particle (eq. 1)."""
    return op.apply_pair_weights(T, g, offsets, indices) / rho_c
