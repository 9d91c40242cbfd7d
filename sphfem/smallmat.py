"""Small inline numba kernels shared by the SPH passes: pair separation, inverses of small
matrices, and the per-particle renormalisation step.

One implementation of each, used by :mod:`sphfem.operators`, :mod:`sphfem.fluid.passes`
(and the fluid modules that import from it) and :mod:`sphfem.solid.reference`.  The pair and
3x3 helpers are ``inline="always"``: numba inlines them into the callers' loops, so the
compiled (vectorised) pair loops are the same as with hand-written copies.

* :func:`pair_sep`     r = x_j - x_i as scalars (zero-padded to 3), minimum image on
  periodic axes;
* :func:`pair_vector`  the same into an array, returning |r|;
* :func:`invert_small` Gauss-Jordan inverse with partial pivoting (any small n) and its
  1-norm condition number;
* :func:`invert3` / :func:`invert_sym3`  explicit cofactor inverses of 1x1..3x3 (general /
  symmetric on scalars) with a condition-number test;
* :func:`store_renormalisation`  B_i = M_i^-1 (Park 2019 eq. 2.6, Johnson & Beissel 1996)
  or the identity where M_i is singular or worse conditioned than ``cond_max``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sphfem.neighbors import min_image


@njit(cache=True, inline="always")
def pair_sep(x, i, j, dim, period, periodic):
    """Components of r = x_j - x_i (zero-padded to 3) with the minimum image if needed."""
    r0 = x[j, 0] - x[i, 0]
    r1 = x[j, 1] - x[i, 1] if dim > 1 else 0.0
    r2 = x[j, 2] - x[i, 2] if dim > 2 else 0.0
    if periodic:
        r0 = min_image(r0, period[0])
        if dim > 1:
            r1 = min_image(r1, period[1])
        if dim > 2:
            r2 = min_image(r2, period[2])
    return r0, r1, r2


@njit(cache=True, inline="always")
def pair_vector(x, i, j, period, r):
    """Fill r = x_j - x_i (minimum image on every axis) and return |r|.

    The array form of :func:`pair_sep` for the generic operators.  It keeps its own loop
    over the axes rather than calling :func:`pair_sep`: under ``fastmath`` the unrolled sum
    is contracted in a different order, which changes |r| in the last bit and with it the
    roundoff-level figures of the operator validations.
    """
    s = 0.0
    for k in range(x.shape[1]):
        d = min_image(x[j, k] - x[i, k], period[k])
        r[k] = d
        s += d * d
    return np.sqrt(s)


@njit(cache=True)
def invert_small(A, Ainv):
    """Gauss-Jordan inverse with partial pivoting of a small dense matrix.

    Writes A^-1 into ``Ainv`` and returns the 1-norm condition number ||A|| ||A^-1||
    (``inf`` when a pivot vanishes).  Used for the 1x1 to 6x6 correction systems.
    """
    n = A.shape[0]
    a = A.copy()
    for p in range(n):
        for q in range(n):
            Ainv[p, q] = 1.0 if p == q else 0.0
    norm_a = 0.0
    for q in range(n):
        s = 0.0
        for p in range(n):
            s += abs(A[p, q])
        norm_a = max(norm_a, s)
    if norm_a == 0.0:
        return np.inf
    for c in range(n):
        piv = c
        for p in range(c + 1, n):
            if abs(a[p, c]) > abs(a[piv, c]):
                piv = p
        if abs(a[piv, c]) <= 1e-300 or abs(a[piv, c]) < 1e-14 * norm_a:
            return np.inf
        if piv != c:
            for q in range(n):
                a[c, q], a[piv, q] = a[piv, q], a[c, q]
                Ainv[c, q], Ainv[piv, q] = Ainv[piv, q], Ainv[c, q]
        d = 1.0 / a[c, c]
        for q in range(n):
            a[c, q] *= d
            Ainv[c, q] *= d
        for p in range(n):
            if p != c and a[p, c] != 0.0:
                f = a[p, c]
                for q in range(n):
                    a[p, q] -= f * a[c, q]
                    Ainv[p, q] -= f * Ainv[c, q]
    norm_i = 0.0
    for q in range(n):
        s = 0.0
        for p in range(n):
            s += abs(Ainv[p, q])
        norm_i = max(norm_i, s)
    return norm_a * norm_i


@njit(cache=True, inline="always")
def store_renormalisation(M, Bi, cond_max, B, ok, i):
    """B[i] = M^-1 and ok[i] = True when cond_1(M) <= cond_max, else B[i] = I (the plain
    operator) with ok[i] left False.  ``Bi`` is a (dim, dim) work array."""
    cond = invert_small(M, Bi)
    if cond <= cond_max:
        ok[i] = True
        B[i] = Bi
    else:
        for p in range(M.shape[0]):
            B[i, p, p] = 1.0


@njit(cache=True, inline="always")
def invert3(M, dim, Binv, cond_max):
    """Explicit inverse of a 1x1..3x3 matrix into ``Binv``; False if worse than cond_max."""
    na = 0.0
    for q in range(dim):
        s = 0.0
        for p in range(dim):
            s += abs(M[p, q])
        na = max(na, s)
    if na == 0.0:
        return False
    if dim == 1:
        Binv[0, 0] = 1.0 / M[0, 0]
    elif dim == 2:
        det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
        if abs(det) < 1e-14 * na * na:
            return False
        Binv[0, 0] = M[1, 1] / det
        Binv[0, 1] = -M[0, 1] / det
        Binv[1, 0] = -M[1, 0] / det
        Binv[1, 1] = M[0, 0] / det
    else:
        c00 = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
        c01 = M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]
        c02 = M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]
        det = M[0, 0] * c00 + M[0, 1] * c01 + M[0, 2] * c02
        if abs(det) < 1e-14 * na * na * na:
            return False
        idet = 1.0 / det
        Binv[0, 0] = c00 * idet
        Binv[1, 0] = c01 * idet
        Binv[2, 0] = c02 * idet
        Binv[0, 1] = (M[0, 2] * M[2, 1] - M[0, 1] * M[2, 2]) * idet
        Binv[1, 1] = (M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]) * idet
        Binv[2, 1] = (M[0, 1] * M[2, 0] - M[0, 0] * M[2, 1]) * idet
        Binv[0, 2] = (M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]) * idet
        Binv[1, 2] = (M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]) * idet
        Binv[2, 2] = (M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]) * idet
    ni = 0.0
    for q in range(dim):
        s = 0.0
        for p in range(dim):
            s += abs(Binv[p, q])
        ni = max(ni, s)
    c = na * ni
    return c <= cond_max and np.isfinite(c)


@njit(cache=True, inline="always")
def invert_sym3(m00, m01, m02, m11, m12, m22, dim, cond_max):
    """:func:`invert3` of the symmetric matrix [[m00 m01 m02] [m01 m11 m12] [m02 m12 m22]]
    on scalars (no temporary arrays): (good, b00, b01, b02, b10, b11, b12, b20, b21, b22)."""
    M = ((m00, m01, m02), (m01, m11, m12), (m02, m12, m22))
    na = 0.0
    for q in range(dim):
        s = 0.0
        for p in range(dim):
            s += abs(M[p][q])
        na = max(na, s)
    b00 = b01 = b02 = b10 = b11 = b12 = b20 = b21 = b22 = 0.0
    good = na != 0.0
    if good:
        if dim == 1:
            b00 = 1.0 / m00
        elif dim == 2:
            det = m00 * m11 - m01 * m01
            if abs(det) < 1e-14 * na * na:
                good = False
            else:
                b00 = m11 / det
                b01 = -m01 / det
                b10 = -m01 / det
                b11 = m00 / det
        else:
            c00 = m11 * m22 - m12 * m12
            c01 = m12 * m02 - m01 * m22
            c02 = m01 * m12 - m11 * m02
            det = m00 * c00 + m01 * c01 + m02 * c02
            if abs(det) < 1e-14 * na * na * na:
                good = False
            else:
                idet = 1.0 / det
                b00 = c00 * idet
                b10 = c01 * idet
                b20 = c02 * idet
                b01 = (m02 * m12 - m01 * m22) * idet
                b11 = (m00 * m22 - m02 * m02) * idet
                b21 = (m01 * m02 - m00 * m12) * idet
                b02 = (m01 * m12 - m02 * m11) * idet
                b12 = (m02 * m01 - m00 * m12) * idet
                b22 = (m00 * m11 - m01 * m01) * idet
    if good:
        B = ((b00, b01, b02), (b10, b11, b12), (b20, b21, b22))
        ni = 0.0
        for q in range(dim):
            s = 0.0
            for p in range(dim):
                s += abs(B[p][q])
            ni = max(ni, s)
        c = na * ni
        good = c <= cond_max and np.isfinite(c)
    return good, b00, b01, b02, b10, b11, b12, b20, b21, b22
