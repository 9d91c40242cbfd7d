"""Fused numba passes of one weakly compressible delta-SPH force evaluation.

Notation (as in :mod:`sphfem.operators`): for particle i and neighbour j, ``r = x_j - x_i``
(minimum image on periodic axes), ``d = |r|``, and ``F = -dW/dr / d >= 0`` so that
``grad_i W_ij = F r``.  Every pass is a gather over destination particles (iteration i
writes row i only), so results do not depend on the thread count.  The neighbour list may
hold pairs beyond the support R (a Verlet list with a skin); they are skipped before the
square root.

Per-particle inputs prepared by :func:`prepare_fluid` / :func:`prepare_all`:
``pr = p / rho^2``, ``V`` (volume: m / rho for fluid, the fixed ``vol`` for walls),
``meff`` (mass: m for fluid, rho_w V_w for walls), ``isf`` (1.0 for fluid, 0.0 otherwise)
and ``vg`` (velocity seen by the viscous term: v for fluid, the Adami ghost velocity for
walls).

Passes (Park 2019 equation numbers in brackets):

* :func:`density_gradient` -- renormalisation matrix B_i and the renormalised density
  gradient <grad rho>_i = B_i sum_j V_j (rho_j - rho_i) grad_i W_ij in one loop [2.90-2.91];
* :func:`fluid_forces` -- for fluid rows: symmetric pressure gradient [2.85], Morris laminar
  viscosity with per-particle mu and (rho_i + rho_j)^2 [2.86], continuity [2.87] with the
  delta-SPH diffusive term of Antuono et al. (2010) / Marrone et al. (2011) [2.88-2.89]
  (fluid-fluid pairs only), body force; for wall rows: the force the wall particle receives
  from the fluid, the exact negative of the pair forces on the fluid.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.fluid.eos import tait_pressure
from sphfem.kernels import WENDLAND_C2, kernel_dfdq
from sphfem.neighbors import min_image
from sphfem.particles import FLUID, WALL

FASTMATH = {"reassoc", "contract", "arcp", "afn"}


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def prepare_fluid(rho, m, v, kind, rho0, B, gamma, p, vg):
    """Tait pressure and viscous velocity of the fluid particles."""
    n = rho.shape[0]
    dim = v.shape[1]
    for i in prange(n):
        if kind[i] == FLUID:
            p[i] = tait_pressure(rho[i], rho0, B, gamma)
            for k in range(dim):
                vg[i, k] = v[i, k]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def prepare_all(rho, p, m, vol, kind, pr, V, meff, isf):
    """p / rho^2, volume, effective mass and the fluid flag of every particle."""
    n = rho.shape[0]
    for i in prange(n):
        r = rho[i]
        if kind[i] == FLUID:
            pr[i] = p[i] / (r * r)
            V[i] = m[i] / r
            meff[i] = m[i]
            isf[i] = 1.0
        elif kind[i] == WALL:
            pr[i] = p[i] / (r * r)
            V[i] = vol[i]
            meff[i] = r * vol[i]
            isf[i] = 0.0
        else:  # other kinds do not interact with the fluid
            pr[i] = 0.0
            V[i] = 0.0
            meff[i] = 0.0
            isf[i] = 0.0


@njit(cache=True, inline="always")
def _F(d, R, fac2, kkind):
    """F = -dW/dr / d for the support radius R, ``fac2 = sigma / R^2``.

    Wendland C2: f'(q) = -20 q (1 - q)^3, so F = 20 sigma (1 - q)^3 / R^2 without a
    division by d.
    """
    q = d / R
    if kkind == WENDLAND_C2:
        a = 1.0 - q
        return fac2 * 20.0 * a * a * a
    return -fac2 * kernel_dfdq(q, kkind) / q


def _view_keep():
    keep = [0] * (max(FLUID, WALL) + 1)
    keep[FLUID] = (1 << FLUID) | (1 << WALL)
    keep[WALL] = 1 << FLUID
    return tuple(keep)


#: the fluid's view as a pair filter of :func:`sphfem.neighbors.build_neighbor_list`
#: (``keep``: bit masks of the kept neighbour kinds by row kind): the same rows as
#: :func:`filter_rows`, built in the search itself without a second pass over the list
VIEW_KEEP = _view_keep()


def filter_rows(offsets, indices, kind, buf=None):
    """The fluid's view of a neighbour list (CSR), from the kind array alone.

    Fluid rows keep their FLUID and WALL neighbours, wall rows only their FLUID neighbours
    (deep walls get empty rows), rows of other kinds (SOLID, GHOST) are emptied: wall-wall
    pairs and pairs with kinds the fluid does not interact with then cost nothing in the
    passes.  Built once per neighbour-list build and reused until the next one.  One pass
    over the list (kept entries go to the rows' own slots of ``buf``, a work buffer of at
    least ``indices``' length), then a copy of the kept entries.
    """
    if buf is None or buf.shape[0] < indices.shape[0]:
        buf = np.empty_like(indices)
    counts = np.empty(offsets.shape[0] - 1, dtype=np.int64)
    _filter_own_slots(offsets, indices, kind, buf, counts)
    new_off = np.zeros(offsets.shape[0], dtype=np.int64)
    np.cumsum(counts, out=new_off[1:])
    out = np.empty(new_off[-1], dtype=indices.dtype)
    _gather_rows(offsets, new_off, buf, out)
    return new_off, out


@njit(cache=True, parallel=True)
def _filter_own_slots(offsets, indices, kind, buf, counts):
    """Kept neighbours of row i into ``buf[offsets[i] : offsets[i] + counts[i]]``
    (branch-free: every entry is stored, the slot advances only when it is kept)."""
    n = offsets.shape[0] - 1
    for i in prange(n):
        ki = kind[i]
        o = offsets[i]
        c = 0
        if ki == FLUID:
            for jj in range(o, offsets[i + 1]):
                j = indices[jj]
                kj = kind[j]
                buf[o + c] = j
                c += (kj == FLUID) | (kj == WALL)
        elif ki == WALL:
            for jj in range(o, offsets[i + 1]):
                j = indices[jj]
                buf[o + c] = j
                c += kind[j] == FLUID
        counts[i] = c


@njit(cache=True, parallel=True)
def _gather_rows(offsets, new_off, buf, out):
    n = offsets.shape[0] - 1
    for i in prange(n):
        o = offsets[i]
        k = new_off[i]
        for q in range(new_off[i + 1] - k):
            out[k + q] = buf[o + q]


@njit(cache=True, inline="always")
def _sep(x, i, j, dim, period, periodic):
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
def _invert(M, dim, Binv, cond_max):
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
def _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic, nb):
    """Compact a non-fluid row: a wall keeps its fluid neighbours with 0 < r < R."""
    if kind[i] != WALL:
        return 0
    c = 0
    o = offsets[i]
    for jj in range(o, offsets[i + 1]):
        j = indices[jj]
        if kind[j] != FLUID:
            continue
        r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        if d2 >= R2 or d2 == 0.0:
            continue
        nb[o + c] = j
        c += 1
    return c


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def compact_rows(x, kind, offsets, indices, R, period, nb, cnt):
    """In-range rows of the fluid's view: ``nb[offsets[i] : offsets[i] + cnt[i]]``.

    Fluid rows keep their neighbours with 0 < r < R, wall rows their fluid neighbours with
    0 < r < R, other rows nothing -- exactly the pairs :func:`fluid_forces` would not skip
    (same order, so the sums are bit-identical).  Written into the rows' own slots of
    ``nb`` (a fluid-owned buffer shaped like ``indices``; no prefix sum).  Used when
    :func:`density_gradient`, which emits the same rows, does not run.
    """
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            cnt[i] = _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic,
                                     nb)
            continue
        c = 0
        o = offsets[i]
        for jj in range(o, offsets[i + 1]):
            j = indices[jj]
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            nb[o + c] = j
            c += 1
        cnt[i] = c


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def density_gradient(x, rho, V, kind, offsets, indices, R, sigma, kkind, period, cond_max,
                     grad, ok, nb, cnt):
    """Renormalised density gradient of every fluid particle (rows of others are zeroed).

    Sums over all interacting neighbours (fluid and wall).  Where the moment matrix is
    singular or worse conditioned than ``cond_max`` (free surface, sparse splashes),
    ``ok[i] = False`` and the plain difference gradient is used.

    Also compacts the rows as :func:`compact_rows` does (``nb``, ``cnt``), from the pair
    distances it computes anyway: the later passes then visit only the in-range pairs.
    """
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            for k in range(dim):
                grad[i, k] = 0.0
            ok[i] = True
            cnt[i] = _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic,
                                     nb)
            continue
        c = 0
        o = offsets[i]
        m00 = 0.0
        m01 = 0.0
        m02 = 0.0
        m11 = 0.0
        m12 = 0.0
        m22 = 0.0
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        ri = rho[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            nb[o + c] = j
            c += 1
            s = V[j] * _F(np.sqrt(d2), R, fac2, kkind)  # V_j F
            t = s * (rho[j] - ri)
            g0 += t * r0
            g1 += t * r1
            g2 += t * r2
            m00 += s * r0 * r0
            m01 += s * r0 * r1
            m02 += s * r0 * r2
            m11 += s * r1 * r1
            m12 += s * r1 * r2
            m22 += s * r2 * r2
        cnt[i] = c
        M = np.empty((3, 3))
        M[0, 0] = m00
        M[0, 1] = m01
        M[0, 2] = m02
        M[1, 0] = m01
        M[1, 1] = m11
        M[1, 2] = m12
        M[2, 0] = m02
        M[2, 1] = m12
        M[2, 2] = m22
        Bi = np.empty((3, 3))
        good = _invert(M, dim, Bi, cond_max)
        ok[i] = good
        g = (g0, g1, g2)
        for p in range(dim):
            if good:
                acc = 0.0
                for q in range(dim):
                    acc += Bi[p, q] * g[q]
                grad[i, p] = acc
            else:
                grad[i, p] = g[p]


# columns of the packed per-particle rows read by the force pass (one or two cache lines
# per neighbour instead of ~18 scattered arrays)
_X, _V, _VG, _RHO, _PR, _VOL, _M, _ISF, _MU, _G = 0, 3, 6, 9, 10, 11, 12, 13, 14, 15
NPACK = 18


@njit(cache=True, parallel=True)
def pack_rows(x, v, vg, rho, pr, V, meff, isf, mu, grad, P):
    """Fill P (n, NPACK) with the per-particle quantities of the force pass (zero-padded)."""
    n, dim = x.shape
    for i in prange(n):
        for k in range(3):
            if k < dim:
                P[i, _X + k] = x[i, k]
                P[i, _V + k] = v[i, k]
                P[i, _VG + k] = vg[i, k]
                P[i, _G + k] = grad[i, k]
            else:
                P[i, _X + k] = 0.0
                P[i, _V + k] = 0.0
                P[i, _VG + k] = 0.0
                P[i, _G + k] = 0.0
        P[i, _RHO] = rho[i]
        P[i, _PR] = pr[i]
        P[i, _VOL] = V[i]
        P[i, _M] = meff[i]
        P[i, _ISF] = isf[i]
        P[i, _MU] = mu[i]


@njit(cache=True, inline="always")
def _psep(P, i, j, period, periodic):
    r0 = P[j, 0] - P[i, 0]
    r1 = P[j, 1] - P[i, 1]
    r2 = P[j, 2] - P[i, 2]
    if periodic:
        r0 = min_image(r0, period[0])
        r1 = min_image(r1, period[1])
        r2 = min_image(r2, period[2])
    return r0, r1, r2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def fluid_forces(P, kind, offsets, cnt, indices, R, sigma, kkind, period, gravity, eps2,
                 delta_coef, art_coef, acc, drho, f_wall):
    """Accelerations and density rates of fluid particles; fluid forces on wall particles.

    ``P`` holds the packed rows of :func:`pack_rows`; row i's neighbours are
    ``indices[offsets[i] : offsets[i] + cnt[i]]`` (the compacted rows of :func:`compact_rows` /
    :func:`density_gradient`, or a full list with ``cnt = diff(offsets)``: pairs beyond R are
    skipped either way).  ``eps2`` is the viscous regulariser (eps_visc h^2), ``delta_coef =
    delta h c0`` (0: no diffusive term), ``art_coef = alpha h c0`` (0: no artificial viscosity;
    Monaghan 1992 in the always-on form of Marrone et al. 2011, symmetrised: pair acceleration 2
    m_j alpha h c0 / (rho_i + rho_j) (u_ji . r) r F / (r^2 + eps2)).  Fluid rows of ``acc``
    (m/s^2) and ``drho`` (kg/m^3/s) and wall rows of ``f_wall`` (N) are written; other rows are
    zeroed (a wall's ``acc``, its prescribed acceleration, is left alone).
    """
    n = P.shape[0]
    dim = acc.shape[1]
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    pp = np.zeros(3)
    for k in range(dim):
        periodic |= period[k] > 0.0
        pp[k] = period[k]
    use_delta = delta_coef != 0.0
    use_art = art_coef != 0.0
    for i in prange(n):
        ki = kind[i]
        if ki != FLUID and ki != WALL:
            for k in range(dim):
                acc[i, k] = 0.0
                f_wall[i, k] = 0.0
            drho[i] = 0.0
            continue
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        cont = 0.0
        diff = 0.0
        ri = P[i, _RHO]
        pri = P[i, _PR]
        if ki == FLUID:
            mui = P[i, _MU]
            vi0 = P[i, _V]
            vi1 = P[i, _V + 1]
            vi2 = P[i, _V + 2]
            gi0 = P[i, _G]
            gi1 = P[i, _G + 1]
            gi2 = P[i, _G + 2]
            for jj in range(offsets[i], offsets[i] + cnt[i]):
                j = indices[jj]
                mj = P[j, _M]
                r0, r1, r2 = _psep(P, i, j, pp, periodic)
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                if d2 >= R2 or d2 == 0.0 or mj == 0.0:
                    continue
                F = _F(np.sqrt(d2), R, fac2, kkind)
                rj = P[j, _RHO]
                fj = P[j, _ISF]
                # pressure, eq. 2.85: -m_j (p_i/rho_i^2 + p_j/rho_j^2) grad_i W
                cp = -mj * (pri + P[j, _PR]) * F
                # viscosity, eq. 2.86 (a wall neighbour takes the fluid's mu, ghost velocity)
                muj = fj * P[j, _MU] + (1.0 - fj) * mui
                rs = ri + rj
                ie = 1.0 / (d2 + eps2)
                cv = mj * 4.0 * (mui + muj) / (rs * rs) * F * d2 * ie
                u0 = P[j, _VG] - vi0
                u1 = P[j, _VG + 1] - vi1
                u2 = P[j, _VG + 2] - vi2
                if use_art:
                    cp += 2.0 * mj * art_coef / rs * F * (u0 * r0 + u1 * r1 + u2 * r2) * ie
                a0 += cp * r0 + cv * u0
                a1 += cp * r1 + cv * u1
                a2 += cp * r2 + cv * u2
                # continuity, eq. 2.87: rho_i sum V_j (v_i - v_j) . grad_i W (wall: its own v)
                VF = P[j, _VOL] * F
                cont -= VF * ((P[j, _V] - vi0) * r0 + (P[j, _V + 1] - vi1) * r1
                              + (P[j, _V + 2] - vi2) * r2)
                if use_delta:  # eqs. 2.88-2.89, fluid-fluid pairs
                    gs = ((gi0 + P[j, _G]) * r0 + (gi1 + P[j, _G + 1]) * r1
                          + (gi2 + P[j, _G + 2]) * r2)
                    diff += fj * ((rj - ri) - 0.5 * gs) * VF
            acc[i, 0] = a0 + gravity[0]
            if dim > 1:
                acc[i, 1] = a1 + gravity[1]
            if dim > 2:
                acc[i, 2] = a2 + gravity[2]
            drho[i] = ri * cont + delta_coef * 2.0 * diff
            for k in range(dim):
                f_wall[i, k] = 0.0
        else:  # wall row: the same pair terms with i and j swapped (rows hold fluid only)
            wi0 = P[i, _VG]
            wi1 = P[i, _VG + 1]
            wi2 = P[i, _VG + 2]
            for jj in range(offsets[i], offsets[i] + cnt[i]):
                j = indices[jj]
                if P[j, _ISF] == 0.0:
                    continue
                mj = P[j, _M]
                r0, r1, r2 = _psep(P, i, j, pp, periodic)
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                if d2 >= R2 or d2 == 0.0:
                    continue
                F = _F(np.sqrt(d2), R, fac2, kkind)
                rs = ri + P[j, _RHO]
                cp = -mj * (pri + P[j, _PR]) * F
                ie = 1.0 / (d2 + eps2)
                cv = mj * 8.0 * P[j, _MU] / (rs * rs) * F * d2 * ie
                u0 = P[j, _V] - wi0
                u1 = P[j, _V + 1] - wi1
                u2 = P[j, _V + 2] - wi2
                if use_art:
                    cp += 2.0 * mj * art_coef / rs * F * (u0 * r0 + u1 * r1 + u2 * r2) * ie
                a0 += cp * r0 + cv * u0
                a1 += cp * r1 + cv * u1
                a2 += cp * r2 + cv * u2
            mi = P[i, _M]
            f_wall[i, 0] = mi * a0
            if dim > 1:
                f_wall[i, 1] = mi * a1
            if dim > 2:
                f_wall[i, 2] = mi * a2
            drho[i] = 0.0
