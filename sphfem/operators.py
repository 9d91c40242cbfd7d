"""SPH differential operators on a CSR neighbour list (numba, parallel over particles).

Notation: for particle i and neighbour j, ``r = x_j - x_i`` (minimum image on periodic
axes), ``e = r/|r|``, ``V_j = m_j/rho_j`` and ``gW = grad_i W(|x_i - x_j|)`` (points from i
towards j because dW/dr <= 0), ``kernel_code`` the integer of :func:`sphfem.kernels.kernel_code`
(not a particle kind).  All kernels *gather*: iteration i writes only row i.  Pair
separation and small inverses come from :mod:`sphfem.smallmat`.

Operators (equation numbers of Park (2019) in brackets, sources in the docstrings):

* :func:`interpolate`            f_i = sum_j V_j f_j W_ij (self included)               [2.2]
* :func:`gradient`               sum_j V_j (f_j - f_i) gW                                [2.4]
* :func:`renormalisation_matrix` B_i = [sum_j V_j gW (x) r]^-1                           [2.6]
* :func:`renormalised_gradient`  B_i sum_j V_j (f_j - f_i) gW (exact for linear f)        [2.5]
* :func:`divergence`             sum_j V_j (u_j - u_i) . gW, optionally renormalised      [2.7-2.8]
* :func:`laplacian_weights_brookshaw`  Brookshaw (1985) / Cleary & Monaghan (1999)        [2.10]
* :func:`laplacian_weights_corrected`  Fatehi & Manzari (2011), exact for quadratics [2.11-2.13]

Both Laplacians are linear in f with a compact stencil, so they are stored as one weight per
neighbour pair, ``lap f_i = sum_j w_ij (f_j - f_i)`` (:func:`apply_pair_weights`).  The same
weights assemble the sparse matrix for implicit diffusion (:func:`pair_weights_matrix`).
Where a correction matrix is singular (isolated particles, thin sheets, corners) the
particle falls back to the uncorrected operator and is flagged in the returned ``ok`` mask.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from sphfem.kernels import FASTMATH, kernel_dfdq, kernel_f
from sphfem.smallmat import invert_small, store_renormalisation
from sphfem.smallmat import pair_vector as _pair

#: default largest accepted 1-norm condition number of a correction matrix
COND_MAX = 1e8


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def interpolate(f, x, vol, offsets, indices, R, sigma, kernel_code, period):
    """Kernel interpolation f_i = V_i f_i W(0) + sum_j V_j f_j W_ij (f scalar per particle)."""
    n = x.shape[0]
    out = np.empty(n)
    w0 = sigma * kernel_f(0.0, kernel_code)
    for i in prange(n):
        r = np.empty(x.shape[1])
        acc = vol[i] * f[i] * w0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            acc += vol[j] * f[j] * sigma * kernel_f(d / R, kernel_code)
        out[i] = acc
    return out


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def gradient(f, x, vol, offsets, indices, R, sigma, kernel_code, period):
    """Difference-form gradient sum_j V_j (f_j - f_i) grad_i W_ij, shape (n, dim)."""
    n, dim = x.shape
    out = np.zeros((n, dim))
    for i in prange(n):
        r = np.empty(dim)
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (f[j] - f[i]) * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            for k in range(dim):
                out[i, k] += s * r[k]
    return out


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _renormalisation_matrix(x, vol, offsets, indices, R, sigma, kernel_code, period, cond_max):
    n, dim = x.shape
    B = np.zeros((n, dim, dim))
    ok = np.zeros(n, dtype=np.bool_)
    for i in prange(n):
        r = np.empty(dim)
        M = np.zeros((dim, dim))
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            for p in range(dim):
                for q in range(dim):
                    M[p, q] += s * r[p] * r[q]
        Bi = np.empty((dim, dim))
        store_renormalisation(M, Bi, cond_max, B, ok, i)
    return B, ok


def renormalisation_matrix(x, vol, offsets, indices, R, sigma, kernel_code, period,
                           cond_max=COND_MAX):
    """Renormalisation matrices B_i = [sum_j V_j grad_i W_ij (x) r_ij]^-1 (Park eq. 2.6).

    Returns ``(B, ok)``: B has shape (n, dim, dim); where the moment matrix is singular or
    worse conditioned than ``cond_max``, ``ok[i]`` is False and ``B[i]`` is the identity
    (the plain operator).  ``(~ok).sum()`` is the fallback count for diagnostics.
    """
    return _renormalisation_matrix(x, vol, offsets, indices, R, sigma, kernel_code, period,
                                   cond_max)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def renormalised_gradient(f, B, x, vol, offsets, indices, R, sigma, kernel_code, period):
    """First-order consistent gradient B_i sum_j V_j (f_j - f_i) grad_i W_ij (Park eq. 2.5)."""
    n, dim = x.shape
    out = np.zeros((n, dim))
    for i in prange(n):
        r = np.empty(dim)
        g = np.zeros(dim)
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (f[j] - f[i]) * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            for k in range(dim):
                g[k] += s * r[k]
        for p in range(dim):
            acc = 0.0
            for q in range(dim):
                acc += B[i, p, q] * g[q]
            out[i, p] = acc
    return out


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _divergence(u, B, use_b, x, vol, offsets, indices, R, sigma, kernel_code, period):
    n, dim = x.shape
    out = np.zeros(n)
    for i in prange(n):
        r = np.empty(dim)
        G = np.zeros((dim, dim))  # G[k, p] = sum V (u_j^k - u_i^k) gW^p
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            for k in range(dim):
                du = s * (u[j, k] - u[i, k])
                for p in range(dim):
                    G[k, p] += du * r[p]
        acc = 0.0
        for k in range(dim):
            if use_b:
                for p in range(dim):
                    acc += B[i, k, p] * G[k, p]
            else:
                acc += G[k, k]
        out[i] = acc
    return out


def divergence(u, x, vol, offsets, indices, R, sigma, kernel_code, period, B=None):
    """Divergence sum_j V_j (u_j - u_i) . grad_i W_ij; renormalised with ``B`` when given.

    With B: div u_i = sum_kp B_i^{kp} sum_j V_j (u_j^k - u_i^k) (grad_i W_ij)^p, exact for
    linear u (Park eq. 2.8 written component-wise).
    """
    n, dim = x.shape
    use_b = B is not None
    Bm = B if use_b else np.zeros((1, dim, dim))
    return _divergence(u, Bm, use_b, x, vol, offsets, indices, R, sigma, kernel_code, period)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def laplacian_weights_brookshaw(x, vol, offsets, indices, R, sigma, kernel_code, period):
    """Pair weights of Brookshaw's Laplacian (Brookshaw 1985; Cleary & Monaghan 1999, eq. 2.10):

    lap f_i = sum_j 2 V_j (f_i - f_j) (x_ij . grad_i W_ij) / |x_ij|^2 = sum_j w_ij (f_j - f_i)
    with w_ij = -2 V_j (dW/dr) / r >= 0.
    """
    n, dim = x.shape
    w = np.zeros(indices.shape[0])
    for i in prange(n):
        r = np.empty(dim)
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d > 0.0:
                w[jj] = -2.0 * vol[j] * sigma * kernel_dfdq(d / R, kernel_code) / (R * d)
    return w


@njit(cache=True, inline="always")
def _sym_index(o, p, dim):
    """Index of the symmetric pair (o, p), o <= p, in the packed list 00,01,..,11,.."""
    if o > p:
        o, p = p, o
    return o * dim - (o * (o - 1)) // 2 + (p - o)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _laplacian_weights_corrected(x, vol, offsets, indices, R, sigma, kernel_code, period, cond_max):
    n, dim = x.shape
    ns = dim * (dim + 1) // 2
    w = np.zeros(indices.shape[0])
    ok = np.zeros(n, dtype=np.bool_)
    for i in prange(n):
        r = np.empty(dim)
        M = np.zeros((dim, dim))
        Q = np.zeros((dim, dim, dim))  # Q[m, n, p] = sum V r^m r^n gW^p
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))  # gW = s r
            for p in range(dim):
                for q in range(dim):
                    M[p, q] += s * r[p] * r[q]
                    for m in range(dim):
                        Q[m, q, p] += s * r[m] * r[q] * r[p]
        B = np.empty((dim, dim))
        condb = invert_small(M, B)
        fallback = condb > cond_max
        L = np.zeros((dim, dim))
        if not fallback:
            # A'[k, m, n] = B[k, p] Q[m, n, p]: gradient error for a quadratic field
            Ap = np.zeros((dim, dim, dim))
            for k in range(dim):
                for m in range(dim):
                    for q in range(dim):
                        acc = 0.0
                        for p in range(dim):
                            acc += B[k, p] * Q[m, q, p]
                        Ap[k, m, q] = acc
            # T[o, p, m, n] = sum V (r^m e^n - A'^{kmn} e^k) e^o gW^p, symmetrised in (m, n)
            S = np.zeros((ns, ns))
            for jj in range(offsets[i], offsets[i + 1]):
                j = indices[jj]
                d = _pair(x, i, j, period, r)
                if d == 0.0:
                    continue
                s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
                for m in range(dim):
                    for q in range(m, dim):
                        am = 0.0
                        aq = 0.0
                        for k in range(dim):
                            am += Ap[k, m, q] * r[k]
                            aq += Ap[k, q, m] * r[k]
                        c = 0.5 * (r[m] * r[q] + r[m] * r[q]) / d - 0.5 * (am + aq) / d
                        row = _sym_index(m, q, dim)
                        for o in range(dim):
                            for p in range(o, dim):
                                t = c * (r[o] / d) * s * r[p]
                                if o != p:
                                    t *= 2.0  # L^{op} = L^{po} both multiply T^{op}=T^{po}
                                S[row, _sym_index(o, p, dim)] += t
            Sinv = np.empty((ns, ns))
            conds = invert_small(S, Sinv)
            if conds > cond_max:
                fallback = True
            else:
                for o in range(dim):
                    for p in range(o, dim):
                        col = _sym_index(o, p, dim)
                        acc = 0.0
                        for m in range(dim):
                            acc += Sinv[col, _sym_index(m, m, dim)]
                        L[o, p] = acc
                        L[p, o] = acc
        if fallback:
            for jj in range(offsets[i], offsets[i + 1]):
                j = indices[jj]
                d = _pair(x, i, j, period, r)
                if d > 0.0:
                    w[jj] = -2.0 * vol[j] * sigma * kernel_dfdq(d / R, kernel_code) / (R * d)
            continue
        ok[i] = True
        # lap f_i = sum_j c_ij [(f_j - f_i) - r . g_i],  c_ij = 2 V_j (L : e (x) gW) / |r|,
        # g_i = B sum_l V_l (f_l - f_i) gW_il  =>  w_ij = c_ij - V_j a . gW_ij, a = B^T sum c r
        cr = np.zeros(dim)
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            le = 0.0
            for o in range(dim):
                for p in range(dim):
                    le += L[o, p] * r[o] * r[p]
            c = 2.0 * s * le / (d * d)  # V_j folded into s
            w[jj] = c
            for k in range(dim):
                cr[k] += c * r[k]
        a = np.zeros(dim)
        for p in range(dim):
            acc = 0.0
            for k in range(dim):
                acc += cr[k] * B[k, p]
            a[p] = acc
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d = _pair(x, i, j, period, r)
            if d == 0.0:
                continue
            s = vol[j] * (-sigma * kernel_dfdq(d / R, kernel_code) / (R * d))
            ag = 0.0
            for k in range(dim):
                ag += a[k] * r[k]
            w[jj] -= s * ag
    return w, ok


def laplacian_weights_corrected(
    x, vol, offsets, indices, R, sigma, kernel_code, period, cond_max=COND_MAX
):
    """Pair weights of the Fatehi & Manzari (2011) second-order consistent Laplacian.

    With r = x_j - x_i, e = r/|r| and the renormalised gradient g_i (eq. 2.5),
        lap f_i = L_i : sum_j 2 V_j e (x) gW [(f_j - f_i)/|r| - e . g_i]
    where the symmetric tensor L_i solves  sym_mn(L_i^{op} T_i^{opmn}) = delta^{mn},
        T_i^{opmn} = sum_j V_j (r^m e^n - A^{kmn} e^k) e^o gW^p,
        A^{kmn} = B_i^{kp} sum_j V_j r^m r^n gW^p  (the gradient's error on a quadratic),
    so that the operator is exact for every quadratic field (errata: the printed eqs.
    2.99-2.101 of Park (2019) are garbled; this is the derivation from the Taylor series).
    Expanding g_i makes the operator a compact stencil ``sum_j w_ij (f_j - f_i)``.

    Returns ``(w, ok)``; particles whose B or L system has a condition number above
    ``cond_max`` fall back to Brookshaw weights and have ``ok[i] = False``.
    """
    return _laplacian_weights_corrected(
        x, vol, offsets, indices, R, sigma, kernel_code, period, cond_max
    )


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def apply_pair_weights(f, w, offsets, indices):
    """sum_j w_ij (f_j - f_i) for scalar f (the Laplacian given its pair weights)."""
    n = offsets.shape[0] - 1
    out = np.zeros(n)
    for i in prange(n):
        acc = 0.0
        fi = f[i]
        for jj in range(offsets[i], offsets[i + 1]):
            acc += w[jj] * (f[indices[jj]] - fi)
        out[i] = acc
    return out


def pair_weights_matrix(w, offsets, indices, scale=None) -> sp.csr_matrix:
    """Sparse matrix A with (A f)_i = scale_i sum_j w_ij (f_j - f_i)."""
    n = offsets.shape[0] - 1
    counts = np.diff(offsets)
    rows = np.repeat(np.arange(n), counts)
    vals = w if scale is None else w * np.repeat(scale, counts)
    A = sp.csr_matrix((vals, indices, offsets), shape=(n, n))
    diag = -np.bincount(rows, weights=vals, minlength=n)
    return (A + sp.diags(diag)).tocsr()
