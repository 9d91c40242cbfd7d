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
from numba import njit, prange, types
from numba.extending import overload

from sphfem.fluid.eos import tait_pressure
from sphfem.kernels import FASTMATH, WENDLAND_C2, kernel_dfdq
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import invert_sym3, pair_sep

#: iterations (blocks of rows) of the pair passes' parallel loops (see :func:`_block`)
NBLOCKS = 64


@njit(cache=True, inline="always")
def _block(b, offsets):
    """Rows [lo, hi) of iteration b of the pair passes' parallel loops: contiguous blocks
    with equal numbers of Verlet-list entries, so the static split of the iterations between
    threads gives each thread about the same work.  The cost per row varies along the
    cell-sorted order (fluid vs wall rows: contiguous halves of the rows of the 3D dam break
    carry 60 / 40 of the pairs); contiguous blocks keep the neighbours' data in cache from
    one row to the next (interleaved blocks were 8-50 % slower on one thread)."""
    n = offsets.shape[0] - 1
    tot = offsets[n]
    lo = np.searchsorted(offsets, b * tot // NBLOCKS)
    hi = n if b == NBLOCKS - 1 else np.searchsorted(offsets, (b + 1) * tot // NBLOCKS)
    return min(lo, n), min(hi, n)


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
def grad_factor(d, R, fac2, kernel_code):
    """F = -dW/dr / d for the support radius R, ``fac2 = sigma / R^2``.

    Wendland C2: f'(q) = -20 q (1 - q)^3, so F = 20 sigma (1 - q)^3 / R^2 without a
    division by d.
    """
    q = d / R
    if kernel_code == WENDLAND_C2:
        a = 1.0 - q
        return fac2 * 20.0 * a * a * a
    return -fac2 * kernel_dfdq(q, kernel_code) / q


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


# The compacted in-range rows (``nb``) come in two forms, told apart by their type when
# numba compiles a pass (the helpers below are overloaded on it):
#
# * an index array shaped like the list's ``indices``: row i's in-range neighbours are
#   ``nb[o : o + c]`` (o = offsets[i], c = cnt[i]), 4 B per listed pair;
# * a tuple ``(pos, indices)`` with ``pos`` uint16 shaped like ``indices``: the in-range
#   entries are ``indices[o + pos[o : o + c]]``, their positions in the list row, 2 B per
#   listed pair (rows of at most 65,536 entries).  The passes gather a row into a small
#   per-block buffer of list indices and run the same pair loops, so the sums are
#   bit-identical to the index form.

#: the largest list row the position form of the compacted rows can address
MAX_POS_ROW = 1 << 16


def _row_tmp(nb, offsets, lo, hi):
    """A per-block buffer of list indices as long as the longest row in [lo, hi) (the
    position form), or an empty one (the index form)."""


@overload(_row_tmp, inline="always")
def _row_tmp_ov(nb, offsets, lo, hi):
    if isinstance(nb, types.BaseTuple):
        def impl(nb, offsets, lo, hi):
            m = 0
            for i in range(lo, hi):
                m = max(m, offsets[i + 1] - offsets[i])
            return np.empty(m, dtype=nb[1].dtype)
        return impl
    return lambda nb, offsets, lo, hi: np.empty(0, dtype=nb.dtype)


def _mark_target(nb, o, e, tmp):
    """Where a row's entries ``o:e`` are marked and squeezed: its own slots of ``nb``
    (index form) or the block's buffer (position form)."""


@overload(_mark_target, inline="always")
def _mark_target_ov(nb, o, e, tmp):
    if isinstance(nb, types.BaseTuple):
        return lambda nb, o, e, tmp: tmp[:e - o]
    return lambda nb, o, e, tmp: nb[o:e]


def _squeeze_into(row, nb, o):
    """Move the entries >= 0 of ``row`` to its front (in place, order kept) and return
    their count; the position form also stores their positions at ``nb[0][o:]``."""


@overload(_squeeze_into, inline="always")
def _squeeze_into_ov(row, nb, o):
    if isinstance(nb, types.BaseTuple):
        def impl(row, nb, o):
            pos = nb[0][o:o + row.shape[0]]
            c = np.uint64(0)
            for k in range(np.uint64(row.shape[0])):  # unsigned: no wraparound code
                pos[c] = k
                c += np.uint64(row[k] >= 0)
            return _squeeze(row)
        return impl
    return lambda row, nb, o: _squeeze(row)


def _put(nb, q, k, j):
    """Store kept entry ``k`` of a row (neighbour ``j``) at slot ``q``."""


@overload(_put, inline="always")
def _put_ov(nb, q, k, j):
    if isinstance(nb, types.BaseTuple):
        def impl(nb, q, k, j):
            nb[0][q] = k
        return impl

    def impl_index(nb, q, k, j):
        nb[q] = j
    return impl_index


def _kept_row(nb, o, c, tmp):
    """Row i's in-range neighbours (list indices) from slot ``o``, ``c`` of them."""


@overload(_kept_row, inline="always")
def _kept_row_ov(nb, o, c, tmp):
    if isinstance(nb, types.BaseTuple):
        def impl(nb, o, c, tmp):
            pos = nb[0][o:o + c]
            row = nb[1][o:]
            for k in range(np.uint64(c)):  # unsigned: no negative-index wraparound
                tmp[k] = row[np.uint64(pos[k])]
            return tmp[:c]
        return impl
    return lambda nb, o, c, tmp: nb[o:o + c]


@njit(cache=True, inline="always")
def _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic, nb):
    """Compact a non-fluid row: a wall keeps its fluid neighbours with 0 < r < R
    (branch-free: every entry is stored, the slot advances only when it is kept)."""
    if kind[i] != WALL:
        return 0
    c = 0
    o = offsets[i]
    for jj in range(o, offsets[i + 1]):
        j = indices[jj]
        r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        _put(nb, o + c, jj - o, j)
        c += (kind[j] == FLUID) & ~((d2 >= R2) | (d2 == 0.0))
    return c


@njit(cache=True)
def _fast_case(dim, periodic, kernel_code):
    """2 or 3: the pair loops run a version compiled for this dim, Wendland C2 and no
    periodic axis; 0: the generic version."""
    if kernel_code == WENDLAND_C2 and not periodic and (dim == 2 or dim == 3):
        return dim
    return 0


@njit(cache=True, inline="always")
def _mark_row(x, i, src, dst, R2, dim, period, periodic):
    """dst[k] = src[k] where 0 < |x_src[k] - x_i| < R, else -1.  No branches and no
    loop-carried dependency (unlike a compacting store), so the out-of-order core overlaps
    the iterations (LLVM does not vectorise it: the stores may alias x)."""
    for k in range(src.shape[0]):
        jj = src[k]
        j = np.uint32(jj)  # unsigned: no negative-index wraparound
        r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        dst[k] = -1 if (d2 >= R2) | (d2 == 0.0) else jj


@njit(cache=True, inline="always")
def _squeeze(row):
    """Move the entries >= 0 of ``row`` to its front (in place, order kept); their count."""
    c = 0
    for k in range(row.shape[0]):
        v = row[k]
        row[c] = v
        c += v >= 0
    return c


@njit(cache=True, inline="always")
def _emit_fluid_row(x, i, offsets, indices, R2, dim, period, periodic, nb, fast, tmp):
    """Compact a fluid row: its neighbours with 0 < r < R, in order (index form: into
    ``nb[o : o + c]``; position form: their positions into ``nb[0][o : o + c]``).  A
    marking loop (versioned like the pair loops, ``fast``: :func:`_fast_case`), then a
    branch-free squeeze.  Returns the kept neighbours' indices (a view of ``nb`` or
    ``tmp``, length c)."""
    o = offsets[i]
    e = offsets[i + 1]
    src = indices[o:e]
    dst = _mark_target(nb, o, e, tmp)
    if fast == 3:
        _mark_row(x, i, src, dst, R2, 3, period, False)
    elif fast == 2:
        _mark_row(x, i, src, dst, R2, 2, period, False)
    else:
        _mark_row(x, i, src, dst, R2, dim, period, periodic)
    return dst[:_squeeze_into(dst, nb, o)]


@njit(cache=True, parallel=True, fastmath=FASTMATH, error_model="numpy")
def compact_rows(x, kind, offsets, indices, R, period, nb, cnt):
    """In-range rows of the fluid's view: ``nb[offsets[i] : offsets[i] + cnt[i]]``.

    Fluid rows keep their neighbours with 0 < r < R, wall rows their fluid neighbours with
    0 < r < R, other rows nothing -- exactly the pairs :func:`fluid_forces` would not skip
    (same order, so the sums are bit-identical).  Written into the rows' own slots of
    ``nb`` (a work buffer shaped like ``indices``, or ``(pos, indices)``: the positions
    in the row, see above; no prefix sum).  Used when :func:`density_gradient`, which
    emits the same rows, does not run.
    """
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    fast = _fast_case(dim, periodic, WENDLAND_C2)
    for b in prange(NBLOCKS):  # blocks of equal list length (balanced threads)
        lo, hi = _block(b, offsets)
        tmp = _row_tmp(nb, offsets, lo, hi)
        for i in range(lo, hi):
            if kind[i] != FLUID:
                cnt[i] = _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic,
                                         nb)
            else:
                cnt[i] = _emit_fluid_row(x, i, offsets, indices, R2, dim, period, periodic, nb,
                                         fast, tmp).shape[0]


@njit(cache=True, inline="always")
def _dg_sums(x, rho, V, row, i, R, fac2, kernel_code, dim, period, periodic):
    """Moment matrix and un-normalised density gradient of row i over its compacted
    neighbours ``row`` (no branches in the loop: it vectorises)."""
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
    for k in range(row.shape[0]):
        j = np.uint32(row[k])  # unsigned: no negative-index wraparound in the gathers
        r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        s = V[j] * grad_factor(np.sqrt(d2), R, fac2, kernel_code)  # V_j F
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
    return m00, m01, m02, m11, m12, m22, g0, g1, g2


@njit(cache=True, parallel=True, fastmath=FASTMATH, error_model="numpy")
def density_gradient(x, rho, V, kind, offsets, indices, R, sigma, kernel_code, period, cond_max,
                     grad, ok, nb, cnt):
    """Renormalised density gradient of every fluid particle (rows of others are zeroed).

    Sums over all interacting neighbours (fluid and wall).  Where the moment matrix is
    singular or worse conditioned than ``cond_max`` (free surface, sparse splashes),
    ``ok[i] = False`` and the plain difference gradient is used.

    Also compacts the rows as :func:`compact_rows` does (``nb``, ``cnt``, either form), from
    the pair distances it computes anyway: the later passes then visit only the in-range
    pairs.
    Per row, a branch-free compaction loop over the Verlet row, then the sums over the
    compacted row (a loop without branches, which LLVM vectorises).
    """
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    fast = _fast_case(dim, periodic, kernel_code)
    for b in prange(NBLOCKS):  # blocks of equal list length (balanced threads)
        lo, hi = _block(b, offsets)
        tmp = _row_tmp(nb, offsets, lo, hi)
        for i in range(lo, hi):
            if kind[i] != FLUID:
                for k in range(dim):
                    grad[i, k] = 0.0
                ok[i] = True
                cnt[i] = _emit_other_row(x, kind, i, offsets, indices, R2, dim, period, periodic,
                                         nb)
                continue
            row = _emit_fluid_row(x, i, offsets, indices, R2, dim, period, periodic, nb, fast,
                                  tmp)
            cnt[i] = row.shape[0]
            # the loop versioned with constant kernel, dim and periodicity for the common
            # cases (loop-invariant branches inside the loop block or blunt SIMD)
            if fast == 3:
                m00, m01, m02, m11, m12, m22, g0, g1, g2 = _dg_sums(
                    x, rho, V, row, i, R, fac2, WENDLAND_C2, 3, period, False)
            elif fast == 2:
                m00, m01, m02, m11, m12, m22, g0, g1, g2 = _dg_sums(
                    x, rho, V, row, i, R, fac2, WENDLAND_C2, 2, period, False)
            else:
                m00, m01, m02, m11, m12, m22, g0, g1, g2 = _dg_sums(
                    x, rho, V, row, i, R, fac2, kernel_code, dim, period, periodic)
            good, b00, b01, b02, b10, b11, b12, b20, b21, b22 = invert_sym3(
                m00, m01, m02, m11, m12, m22, dim, cond_max)
            ok[i] = good
            if good:
                grad[i, 0] = b00 * g0 + b01 * g1 + b02 * g2 if dim > 2 else (
                    b00 * g0 + b01 * g1 if dim > 1 else b00 * g0)
                if dim > 1:
                    grad[i, 1] = b10 * g0 + b11 * g1 + b12 * g2 if dim > 2 else b10 * g0 + b11 * g1
                if dim > 2:
                    grad[i, 2] = b20 * g0 + b21 * g1 + b22 * g2
            else:
                grad[i, 0] = g0
                if dim > 1:
                    grad[i, 1] = g1
                if dim > 2:
                    grad[i, 2] = g2


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
def _fluid_row_sums(P, i, row, R2, R, fac2, kernel_code, dim, pp, periodic, eps2, art_coef):
    """Pair sums of fluid row i over ``row`` (its neighbour indices): acceleration (3),
    continuity and delta-SPH sums.  Pairs at r >= R or r = 0 and massless neighbours are
    skipped (none are left in a compacted row).  No loop-invariant branches (the caller
    versions ``dim``, ``kernel_code``, ``periodic``; a zero ``art_coef`` adds exact zeros), so
    LLVM vectorises the loop (gathers from the packed rows)."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    cont = 0.0
    diff = 0.0
    ri = P[i, _RHO]
    pri = P[i, _PR]
    mui = P[i, _MU]
    vi0 = P[i, _V]
    vi1 = P[i, _V + 1]
    vi2 = P[i, _V + 2]
    gi0 = P[i, _G]
    gi1 = P[i, _G + 1]
    gi2 = P[i, _G + 2]
    for k in range(row.shape[0]):
        j = np.uint32(row[k])  # unsigned: no negative-index wraparound in the gathers
        mj = P[j, _M]
        r0, r1, r2 = pair_sep(P, i, j, dim, pp, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        if d2 >= R2 or d2 == 0.0 or mj == 0.0:
            continue
        F = grad_factor(np.sqrt(d2), R, fac2, kernel_code)
        rj = P[j, _RHO]
        fj = P[j, _ISF]
        # pressure, eq. 2.85: -m_j (p_i/rho_i^2 + p_j/rho_j^2) grad_i W
        cp = -mj * (pri + P[j, _PR]) * F
        # viscosity, eq. 2.86 (a wall neighbour takes the fluid's mu, ghost velocity);
        # one division: 1 / ((r^2 + eps2) (rho_i + rho_j)^2)
        muj = fj * P[j, _MU] + (1.0 - fj) * mui
        rs = ri + rj
        mF = mj * F
        inv = 1.0 / ((d2 + eps2) * (rs * rs))
        cv = 4.0 * (mui + muj) * mF * d2 * inv
        u0 = P[j, _VG] - vi0
        u1 = P[j, _VG + 1] - vi1 if dim > 1 else 0.0
        u2 = P[j, _VG + 2] - vi2 if dim > 2 else 0.0
        cp += 2.0 * art_coef * mF * (u0 * r0 + u1 * r1 + u2 * r2) * rs * inv
        a0 += cp * r0 + cv * u0
        a1 += cp * r1 + cv * u1
        a2 += cp * r2 + cv * u2
        # continuity, eq. 2.87: rho_i sum V_j (v_i - v_j) . grad_i W (wall: its own v)
        VF = P[j, _VOL] * F
        w0 = P[j, _V] - vi0
        w1 = P[j, _V + 1] - vi1 if dim > 1 else 0.0
        w2 = P[j, _V + 2] - vi2 if dim > 2 else 0.0
        cont -= VF * (w0 * r0 + w1 * r1 + w2 * r2)
        # eqs. 2.88-2.89, fluid-fluid pairs (used when delta_coef != 0)
        gs = (gi0 + P[j, _G]) * r0
        if dim > 1:
            gs += (gi1 + P[j, _G + 1]) * r1
        if dim > 2:
            gs += (gi2 + P[j, _G + 2]) * r2
        diff += fj * ((rj - ri) - 0.5 * gs) * VF
    return a0, a1, a2, cont, diff


@njit(cache=True, inline="always")
def _wall_row_sums(P, i, row, R2, R, fac2, kernel_code, dim, pp, periodic, eps2, art_coef):
    """Pair sums of wall row i (the pair terms of :func:`_fluid_row_sums` with i and j
    swapped; rows hold fluid neighbours only, others are skipped): its acceleration."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    ri = P[i, _RHO]
    pri = P[i, _PR]
    wi0 = P[i, _VG]
    wi1 = P[i, _VG + 1]
    wi2 = P[i, _VG + 2]
    for k in range(row.shape[0]):
        j = np.uint32(row[k])
        mj = P[j, _M]
        r0, r1, r2 = pair_sep(P, i, j, dim, pp, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        if d2 >= R2 or d2 == 0.0 or P[j, _ISF] == 0.0:
            continue
        F = grad_factor(np.sqrt(d2), R, fac2, kernel_code)
        rs = ri + P[j, _RHO]
        mF = mj * F
        cp = -mF * (pri + P[j, _PR])
        inv = 1.0 / ((d2 + eps2) * (rs * rs))
        cv = 8.0 * P[j, _MU] * mF * d2 * inv
        u0 = P[j, _V] - wi0
        u1 = P[j, _V + 1] - wi1 if dim > 1 else 0.0
        u2 = P[j, _V + 2] - wi2 if dim > 2 else 0.0
        cp += 2.0 * art_coef * mF * (u0 * r0 + u1 * r1 + u2 * r2) * rs * inv
        a0 += cp * r0 + cv * u0
        a1 += cp * r1 + cv * u1
        a2 += cp * r2 + cv * u2
    return a0, a1, a2


@njit(cache=True, parallel=True, fastmath=FASTMATH, error_model="numpy")
def fluid_forces(P, kind, offsets, cnt, nb, R, sigma, kernel_code, period, gravity, eps2,
                 delta_coef, art_coef, acc, drho, f_wall):
    """Accelerations and density rates of fluid particles; fluid forces on wall particles.

    ``P`` holds the packed rows of :func:`pack_rows`; row i's neighbours are
    ``nb[offsets[i] : offsets[i] + cnt[i]]`` (the compacted rows of :func:`compact_rows` /
    :func:`density_gradient` in either form, or a full list's indices with ``cnt =
    diff(offsets)``: pairs beyond R are skipped either way).  ``eps2`` is the viscous
    regulariser (eps_visc h^2), ``delta_coef = delta h c0`` (0: no diffusive term),
    ``art_coef = alpha h c0`` (0: no artificial viscosity; Monaghan 1992 in the always-on
    form of Marrone et al. 2011, symmetrised: pair acceleration 2 m_j alpha h c0 /
    (rho_i + rho_j) (u_ji . r) r F / (r^2 + eps2)).  Fluid rows of ``acc`` (m/s^2) and
    ``drho`` (kg/m^3/s) and wall rows of ``f_wall`` (N) are written; other rows are zeroed
    (a wall's ``acc``, its prescribed acceleration, is left alone).
    """
    dim = acc.shape[1]
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    pp = np.zeros(3)
    for k in range(dim):
        periodic |= period[k] > 0.0
        pp[k] = period[k]
    fast = _fast_case(dim, periodic, kernel_code)
    use_delta = delta_coef != 0.0
    for b in prange(NBLOCKS):  # blocks of equal list length (balanced threads)
        lo, hi = _block(b, offsets)
        tmp = _row_tmp(nb, offsets, lo, hi)
        for i in range(lo, hi):
            ki = kind[i]
            if ki != FLUID and ki != WALL:
                for k in range(dim):
                    acc[i, k] = 0.0
                    f_wall[i, k] = 0.0
                drho[i] = 0.0
                continue
            row = _kept_row(nb, offsets[i], cnt[i], tmp)
            if ki == FLUID:
                if fast == 3:
                    a0, a1, a2, cont, diff = _fluid_row_sums(
                        P, i, row, R2, R, fac2, WENDLAND_C2, 3, pp, False, eps2, art_coef)
                elif fast == 2:
                    a0, a1, a2, cont, diff = _fluid_row_sums(
                        P, i, row, R2, R, fac2, WENDLAND_C2, 2, pp, False, eps2, art_coef)
                else:
                    a0, a1, a2, cont, diff = _fluid_row_sums(
                        P, i, row, R2, R, fac2, kernel_code, 3, pp, periodic, eps2, art_coef)
                acc[i, 0] = a0 + gravity[0]
                if dim > 1:
                    acc[i, 1] = a1 + gravity[1]
                if dim > 2:
                    acc[i, 2] = a2 + gravity[2]
                drho[i] = P[i, _RHO] * cont + (delta_coef * 2.0 * diff if use_delta else 0.0)
                for k in range(dim):
                    f_wall[i, k] = 0.0
            else:  # wall row: the same pair terms with i and j swapped (rows hold fluid only)
                if fast == 3:
                    a0, a1, a2 = _wall_row_sums(
                        P, i, row, R2, R, fac2, WENDLAND_C2, 3, pp, False, eps2, art_coef)
                elif fast == 2:
                    a0, a1, a2 = _wall_row_sums(
                        P, i, row, R2, R, fac2, WENDLAND_C2, 2, pp, False, eps2, art_coef)
                else:
                    a0, a1, a2 = _wall_row_sums(
                        P, i, row, R2, R, fac2, kernel_code, 3, pp, periodic, eps2, art_coef)
                mi = P[i, _M]
                f_wall[i, 0] = mi * a0
                if dim > 1:
                    f_wall[i, 1] = mi * a1
                if dim > 2:
                    f_wall[i, 2] = mi * a2
                drho[i] = 0.0
