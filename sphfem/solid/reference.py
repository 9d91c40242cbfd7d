"""Reference configuration of a total-Lagrangian SPH body: neighbours, kernel gradients, B0.

The neighbour list is built once on the reference positions X and kept for the whole run
(Park 2019, fig. 2.16: initial neighbours may leave the support in the current
configuration).  Per neighbour pair (i, j) with R_ij = X_j - X_i (minimum image on periodic
axes) this module stores

    gW_ij = grad_i W(|X_i - X_j|) = -W'(r) R_ij / r      (points from i towards j)
    W_ij  = W(|R_ij|)                                        (used by the hourglass control)

and per particle the reference correction tensor (Park eq. 2.117, Johnson & Beissel 1996)

    B0_i = [ sum_j V0_j R_ij (x) gW_ij ]^-1 .

With gW_ij parallel to R_ij the moment matrix is symmetric, so B0_i is symmetric.  Where it
is singular or worse conditioned than ``cond_max`` (isolated particles, thin strands) the
particle falls back to B0_i = I (plain gradient) and ``ok[i]`` is False; the count goes into
the diagnostics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from sphfem import kernels
from sphfem.kernels import FASTMATH
from sphfem.neighbors import build_neighbor_list
from sphfem.operators import COND_MAX, renormalisation_matrix
from sphfem.smallmat import pair_vector


@njit(cache=True, fastmath=FASTMATH)
def _pair_kernels(X, offsets, indices, R, sigma, kernel_code, period):
    """Pair gradients gW (npairs, dim) and kernel values W (npairs,) on positions X."""
    n, dim = X.shape
    npair = indices.shape[0]
    gw = np.zeros((npair, dim))
    w = np.zeros(npair)
    r = np.empty(dim)
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = pair_vector(X, i, j, period, r)
            if d == 0.0:
                continue
            w[jj] = sigma * kernels.kernel_f(d / R, kernel_code)
            s = -sigma * kernels.kernel_dfdq(d / R, kernel_code) / (R * d)
            for k in range(dim):
                gw[jj, k] = s * r[k]
    return gw, w


def reference_pairs(X, vol, offsets, indices, R, sigma, kernel_code, period, cond_max):
    """Pair gradients gW (npairs, dim), pair kernel values W (npairs,), B0 (n, dim, dim) and
    the correction mask ok (n,) on the reference positions X (n, dim).  B0 and ok come from
    the shared renormalisation kernel :func:`sphfem.operators.renormalisation_matrix`
    (Park eq. 2.6, the same tensor as eq. 2.117)."""
    gw, w = _pair_kernels(X, offsets, indices, R, sigma, kernel_code, period)
    B, ok = renormalisation_matrix(X, vol, offsets, indices, R, sigma, kernel_code, period,
                                   cond_max)
    return gw, w, B, ok


@dataclass
class ReferenceConfig:
    """Everything about the undeformed body that the run keeps: positions ``X`` (n, dim),
    volumes ``vol`` (V0), CSR neighbours, pair arrays ``gw``/``w``, ``B`` and ``ok``."""

    X: np.ndarray
    vol: np.ndarray
    offsets: np.ndarray
    indices: np.ndarray
    gw: np.ndarray
    w: np.ndarray
    B: np.ndarray
    ok: np.ndarray
    R: float
    period: np.ndarray

    @property
    def n(self) -> int:
        return self.X.shape[0]

    @property
    def dim(self) -> int:
        return self.X.shape[1]

    @property
    def fallbacks(self) -> int:
        return int((~self.ok).sum())


def build_reference(X, vol, R: float, kernel: str = "wendland_c2", period=None,
                    cond_max: float = COND_MAX) -> ReferenceConfig:
    """Neighbour list within the support radius ``R`` of the reference positions and the
    pair gradients / correction tensors of :func:`reference_pairs`."""
    X = np.ascontiguousarray(np.asarray(X, dtype=np.float64))
    if X.ndim != 2 or X.shape[1] not in (2, 3):
        raise ValueError(f"TL-SPH positions must have shape (n, 2) or (n, 3), got {X.shape}")
    n, dim = X.shape
    # a writable copy: a read-only view (broadcast_to of an array) would make numba compile
    # a second, read-only specialisation of the kernels (~12-16 s of CPU in the test suite)
    vol = np.array(np.broadcast_to(np.asarray(vol, float), (n,)), dtype=np.float64)
    period = np.zeros(dim) if period is None else np.asarray(period, float)
    code = kernels.kernel_code(kernel)
    sigma = kernels.kernel_sigma(code, dim, R)
    lo = X.min(axis=0) - R
    hi = X.max(axis=0) + R
    if np.any(period > 0):
        lo = np.where(period > 0, X.min(axis=0), lo)
        hi = np.where(period > 0, lo + period, hi)
    nl = build_neighbor_list(X, R, lo, hi, period)
    offsets = np.ascontiguousarray(nl.offsets)
    indices = np.ascontiguousarray(nl.indices)
    gw, w, B, ok = reference_pairs(X, vol, offsets, indices, R, sigma, code, period,
                                   cond_max)
    ref = ReferenceConfig(X, vol, offsets, indices, gw, w, B, ok, float(R), period)
    # per-pair constants of the fused 2D force pass (sphfem.solid.forces.pair_forces_2d)
    rows = np.repeat(np.arange(n), np.diff(offsets))
    dX = X[indices] - X[rows]
    for k in range(dim):
        if period[k] > 0:
            dX[:, k] -= period[k] * np.round(dX[:, k] / period[k])
    D2 = np.einsum("ij,ij->i", dX, dX)
    ref.vgw = np.ascontiguousarray(vol[indices][:, None] * gw)
    ref.dX = np.ascontiguousarray(dX)
    with np.errstate(divide="ignore", invalid="ignore"):
        ref.hgw = np.where(D2 > 0, vol[rows] * vol[indices] * w / D2, 0.0)
    return ref
