"""Fixed-radius neighbour search: a cell-linked list in CSR form, in numba.

One code path serves 1D, 2D and 3D (positions ``x`` of shape ``(n, dim)``).  The grid is
padded to three axes internally (leading axes of one cell), so the last real axis is the
fastest-varying cell axis and the cells ``(a, b, c - s .. c + s)`` of a row are one
contiguous block of the cell-sorted particle copy.

Algorithm (CompactNSearch / PySPH ``LinkedListNNPS`` style, cell size = radius):

1. cell ids of every particle (periodic axes wrapped into the box, others clamped to the
   grid, so particles slightly outside ``[lo, hi]`` are fine);
2. counting sort of the cell ids -> ``cell_start`` (exclusive cumsum) and ``order``;
   positions are gathered into cell order, one contiguous row per axis;
3. *mask pass*, per cell (``prange`` over chunks of cells): the candidates of its 3^dim
   stencil are gathered once into contiguous scratch arrays, with the periodic image shift
   applied, pruned to those within ``radius`` of the cell's bounding box (and, with a pair
   filter, to the kinds some particle of the cell keeps), and sorted by id (insertion sort:
   on a cell-sorted set they already ascend, or nearly).  Their ids are kept per cell; every
   particle of the cell scans them with a vectorised loop into a 0/1 hit mask, packed into a
   bit mask per particle (one multiply per 8 candidates) whose popcount is its count;
4. ``offsets`` (cumsum); *fill pass*: every particle writes the ids of its set bits
   (trailing-zero count) into its own CSR segment -- no second distance test, race free.

Every particle's neighbours are returned sorted by index, so the list does not depend on
the thread count.  Pairs at distance exactly ``radius`` are included (``r^2 <= R^2``, no
square root, strict IEEE arithmetic).  Periodic axes use the minimum-image convention; this
needs ``radius < period / 2`` (checked), so that at most one image of a particle is a
neighbour.  Boxes only two cells across are fine: each (cell, image) pair is visited once.

For cache locality, sort the particles every few steps with :func:`cell_sort_permutation`
(``particles.reorder(perm)``) using the same radius; the search is correct for any order,
but on an unsorted set it is several times slower (scattered candidates, and every
neighbour segment must be sorted).
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from numba.cpython.unsafe.numbers import trailing_zeros

from sphfem.kernels import FASTMATH  # noqa: F401  (re-exported for sphfem.density)

# relative slack on cell widths: a pair at distance exactly ``radius`` never spans more
# than ``reach`` cells, whatever the rounding of (x - origin) / width.
_SLACK = 1e-9


@dataclass
class NeighborList:
    """CSR neighbour list: the neighbours of ``i`` are ``indices[offsets[i]:offsets[i+1]]``.

    Self is excluded, pairs with ``r <= radius`` are included, and each segment is sorted
    by ascending index.  ``period`` is the periodic length per axis (0: not periodic); use
    :func:`min_image` with it when computing separations.
    """

    offsets: np.ndarray  # (n + 1,) int64
    indices: np.ndarray  # (n_pairs,) int32
    radius: float
    period: np.ndarray  # (dim,) float64

    @property
    def n(self) -> int:
        return self.offsets.shape[0] - 1

    @property
    def n_pairs(self) -> int:
        """Number of directed pairs (i, j), i.e. twice the number of unordered pairs."""
        return int(self.indices.shape[0])

    def counts(self) -> np.ndarray:
        """Number of neighbours of every particle."""
        return np.diff(self.offsets)

    def neighbors(self, i: int) -> np.ndarray:
        return self.indices[self.offsets[i] : self.offsets[i + 1]]


@njit(cache=True, inline="always")
def min_image(d, L):
    """Separation ``d`` wrapped into [-L/2, L/2) when ``L > 0`` (periodic axis), else ``d``."""
    if L > 0.0:
        return d - L * np.floor(d / L + 0.5)
    return d


# ----------------------------------------------------------------------------- grid setup


@dataclass
class _Grid:
    origin: np.ndarray  # (3,) float64, padded
    width: np.ndarray  # (3,)
    ncell: np.ndarray  # (3,) int64
    reach: np.ndarray  # (3,) int64: cells to visit on each side
    period: np.ndarray  # (3,) float64, 0 on non-periodic (and padded) axes


def _as_vector(a, dim, name):
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    if a.shape[0] == 1 and dim != 1:
        a = np.full(dim, a[0])
    if a.shape[0] != dim:
        raise ValueError(f"{name} must have {dim} entries, got {a.shape[0]}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite, got {a}")
    return a


def _check_positions(x) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    if x.ndim != 2 or not 1 <= x.shape[1] <= 3:
        raise ValueError(f"positions must have shape (n, dim) with dim in 1..3, got {x.shape}")
    x = np.ascontiguousarray(x)
    if x.size and not np.isfinite(x).all():
        bad = np.flatnonzero(~np.isfinite(x).all(axis=1))
        raise ValueError(f"non-finite positions for {bad.size} particle(s), first index {bad[0]}")
    return x


def _make_grid(n, radius, lo, hi, period, cells_per_radius) -> _Grid:
    """Cells of width >= radius / cells_per_radius over [lo, hi] (periodic: [lo, lo + L))."""
    dim = lo.shape[0]
    cw = radius / cells_per_radius * (1.0 + _SLACK)
    origin = np.zeros(3)
    width = np.ones(3)
    ncell = np.ones(3, dtype=np.int64)
    per = np.zeros(3)
    span = np.zeros(3)
    for k in range(dim):
        K = 3 - dim + k
        origin[K] = lo[k]
        if period[k] > 0:
            per[K] = period[k]
            ncell[K] = max(1, int(np.floor(per[K] / cw)))
            width[K] = per[K] / ncell[K]
        else:  # particles outside [lo, hi] are clamped into the edge cells
            with np.errstate(over="ignore"):  # an overflow is reported just below
                span[K] = max(hi[k] - lo[k], 0.0)
            if not np.isfinite(span[K]):
                raise ValueError(f"the bounds of axis {k} span an infinite range "
                                 f"(lo {lo[k]:g}, hi {hi[k]:g}): positions that far apart "
                                 "mean a particle was thrown out (a blow-up)")
            width[K] = cw
            ncell[K] = int(min(np.floor(span[K] / cw), 2**40)) + 1
    # cap the cell count (a huge domain with few particles): widen the busiest axis
    max_cells = max(4 * n, 1 << 16)
    while np.prod(ncell.astype(np.float64)) > max_cells:
        K = int(np.argmax(ncell))
        if per[K] > 0:
            ncell[K] = max(1, ncell[K] // 2)
            width[K] = per[K] / ncell[K]
        else:
            width[K] *= 2.0
            ncell[K] = int(np.floor(span[K] / width[K])) + 1
    reach = np.zeros(3, dtype=np.int64)
    for K in range(3 - dim, 3):
        reach[K] = int(np.ceil(radius * (1.0 + 0.5 * _SLACK) / width[K]))
    return _Grid(origin, width, ncell, reach, per)


# ----------------------------------------------------------------------------- numba kernels


@njit(cache=True)  # serial: memory bound, cheaper than a parallel region
def _cell_coords(x, origin, width, ncell, period):
    """Row-major cell id of every particle (last axis fastest) and the positions ``xw``
    (3, n), wrapped into the box on periodic axes, zero on the padded leading axes."""
    n, dim = x.shape
    off = 3 - dim
    xw = np.zeros((3, n))
    cid = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for K in range(3):
            ck = 0
            if K >= off:
                y = x[i, K - off] - origin[K]
                L = period[K]
                if L > 0.0:
                    y -= L * np.floor(y / L)
                    if y >= L:  # rounding of a tiny negative y
                        y = 0.0
                    xw[K, i] = origin[K] + y
                else:
                    xw[K, i] = x[i, K - off]
                f = min(max(np.floor(y / width[K]), 0.0), ncell[K] - 1.0)
                ck = np.int64(f)
            c = c * ncell[K] + ck
        cid[i] = c
    return xw, cid


@njit(cache=True)
def _counting_sort(cid, ncells):
    """Stable counting sort: ``order`` (particles by cell) and ``cell_start`` (ncells + 1)."""
    n = cid.shape[0]
    cell_start = np.zeros(ncells + 1, dtype=np.int64)
    for i in range(n):
        cell_start[cid[i] + 1] += 1
    for c in range(ncells):
        cell_start[c + 1] += cell_start[c]
    fillp = cell_start[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = cid[i]
        order[fillp[c]] = i
        fillp[c] += 1
    return order, cell_start


@njit(cache=True)  # serial: memory bound, cheaper than a parallel region
def _gather_columns(xw, order):
    """Positions in cell order, one contiguous row per axis (3, n)."""
    n = order.shape[0]
    xs = np.empty((3, n))
    for p in range(n):
        j = order[p]
        xs[0, p] = xw[0, j]
        xs[1, p] = xw[1, j]
        xs[2, p] = xw[2, j]
    return xs


@njit(cache=True, inline="always")
def _axis_parts(c, s, nc, L):
    """Cells visited on one axis around cell ``c``: two unwrapped ranges ``[u0, u1]``,
    ``[v0, v1]`` (the second possibly empty), ordered so that their wrapped cells ascend.

    Open axes are clamped to the grid.  A periodic axis too short for ``2 s + 1`` distinct
    cells visits every (cell, image) pair once, in one range, not in ascending order.
    """
    if L > 0.0:
        if 2 * s + 1 > nc:
            return c - s, c + s, 0, -1
        if c - s < 0:
            return 0, c + s, c - s, -1
        if c + s >= nc:
            return nc, c + s, c - s, nc - 1
        return c - s, c + s, 0, -1
    return max(c - s, 0), min(c + s, nc - 1), 0, -1


@njit(cache=True, inline="always")
def _image(a, nc, L):
    """Wrapped cell ``aa`` of unwrapped cell ``a`` and the image shift ``kk * L``."""
    if L > 0.0:
        kk = a // nc
        return a - kk * nc, kk * L
    return a, 0.0


# The passes work cell by cell: the candidates of a cell (its stencil cells, pruned to those
# within the radius of the cell's particle bounding box) are gathered once into contiguous
# scratch arrays, then every particle of the cell scans them with a branch-free loop.
# Hot loops index with unsigned integers: numba then skips its negative-index wraparound
# code, which otherwise blocks vectorisation (4-7x slower candidate loops).
# Strict IEEE maths here (no fastmath): r^2 <= R^2 must not depend on the vectorisation
# (the same pair tested from both ends must agree: symmetric lists).


@njit(cache=True, inline="always")
def _cell_xyz(c, ncell):
    c2 = c % ncell[2]
    c01 = c // ncell[2]
    return c01 // ncell[1], c01 % ncell[1], c2


@njit(cache=True)
def _stencil_counts(cell_start, ncell, reach, period):
    """Number of (unpruned) stencil candidates of every cell (0 for empty cells)."""
    ncells = cell_start.shape[0] - 1
    best = np.zeros(ncells, dtype=np.int64)
    for c in range(ncells):
        if cell_start[c + 1] == cell_start[c]:
            continue
        c0, c1, c2 = _cell_xyz(c, ncell)
        A = _axis_parts(c0, reach[0], ncell[0], period[0])
        B = _axis_parts(c1, reach[1], ncell[1], period[1])
        E = _axis_parts(c2, reach[2], ncell[2], period[2])
        m = 0
        for ia in range(2):
            for a in range(A[2 * ia], A[2 * ia + 1] + 1):
                aa, _ = _image(a, ncell[0], period[0])
                for ib in range(2):
                    for b in range(B[2 * ib], B[2 * ib + 1] + 1):
                        bb, _ = _image(b, ncell[1], period[1])
                        row = (aa * ncell[1] + bb) * ncell[2]
                        for ie in range(2):
                            e = E[2 * ie]
                            while e <= E[2 * ie + 1]:
                                ee, _ = _image(e, ncell[2], period[2])
                                run = min(E[2 * ie + 1] - e, ncell[2] - 1 - ee)
                                m += cell_start[row + ee + run + 1] - cell_start[row + ee]
                                e += run + 1
        best[c] = m
    return best


@njit(cache=True, inline="always")
def _gather_run(xs, order, kb, um, ps, pe, sh0, sh1, sh2, bbox, r2max, cx, cj, cb, m):
    """Append the particles ``ps:pe`` (shifted by the image) within ``radius`` of the box
    whose kind bit ``kb`` is in the mask ``um``."""
    x0 = xs[0]
    x1 = xs[1]
    x2 = xs[2]
    lo0, hi0, lo1, hi1, lo2, hi2 = bbox
    for p in range(ps, pe):
        y0 = x0[p] + sh0
        y1 = x1[p] + sh1
        y2 = x2[p] + sh2
        d0 = max(lo0 - y0, 0.0, y0 - hi0)
        d1 = max(lo1 - y1, 0.0, y1 - hi1)
        d2 = max(lo2 - y2, 0.0, y2 - hi2)
        q = np.uint64(m)
        cx[0, q] = y0
        cx[1, q] = y1
        cx[2, q] = y2
        cj[q] = order[p]
        cb[q] = kb[p]
        m += (d0 * d0 + d1 * d1 + d2 * d2 <= r2max) & ((kb[p] & um) != 0)
    return m


@njit(cache=True, inline="always")
def _sort_candidates(cx, cj, cb, m):
    """Sort the candidates by id (``cx``, ``cb`` moved along): insertion sort (nearly sorted
    on a cell-sorted set), a merge sort after a budget of moves proportional to ``m``.
    Returns whether ``cj[:m]`` strictly ascends (every particle's neighbours then come out
    sorted; not in a tiny periodic box, where a particle can be a candidate twice)."""
    budget = 4 * m + 64
    for q in range(1, m):
        v = cj[q]
        if v > cj[q - 1]:
            continue
        y0 = cx[0, q]
        y1 = cx[1, q]
        y2 = cx[2, q]
        b = cb[q]
        r = q
        while r > 0 and cj[r - 1] > v:
            cj[r] = cj[r - 1]
            cx[0, r] = cx[0, r - 1]
            cx[1, r] = cx[1, r - 1]
            cx[2, r] = cx[2, r - 1]
            cb[r] = cb[r - 1]
            r -= 1
        cj[r] = v
        cx[0, r] = y0
        cx[1, r] = y1
        cx[2, r] = y2
        cb[r] = b
        budget -= q - r
        if budget < 0:  # far from sorted: a merge sort of the ids, then permute
            perm = np.argsort(cj[:m], kind="mergesort")
            tj = cj[:m].copy()
            tx = cx[:, :m].copy()
            tb = cb[:m].copy()
            for r in range(m):
                s = perm[r]
                cj[r] = tj[s]
                cx[0, r] = tx[0, s]
                cx[1, r] = tx[1, s]
                cx[2, r] = tx[2, s]
                cb[r] = tb[s]
            break
    ascending = True
    for q in range(1, m):
        ascending &= cj[q] > cj[q - 1]
    return ascending


@njit(cache=True, inline="always")
def _gather_candidates(c, xs, order, kb, um, cell_start, ncell, reach, period, r2max, cx, cj,
                       cb):
    """Gather the candidates of cell ``c`` (those whose kind bit is in ``um``) into ``cx``
    (positions, periodic image shift applied), ``cj`` (ids) and ``cb`` (kind bits), sorted
    by id when that is cheap.  Returns their number and whether ``cj`` ascends."""
    x0 = xs[0]
    x1 = xs[1]
    x2 = xs[2]
    p0 = cell_start[c]
    p1 = cell_start[c + 1]
    lo0 = hi0 = x0[p0]
    lo1 = hi1 = x1[p0]
    lo2 = hi2 = x2[p0]
    for p in range(np.uint64(p0 + 1), np.uint64(p1)):
        lo0 = min(lo0, x0[p])
        hi0 = max(hi0, x0[p])
        lo1 = min(lo1, x1[p])
        hi1 = max(hi1, x1[p])
        lo2 = min(lo2, x2[p])
        hi2 = max(hi2, x2[p])
    bbox = (lo0, hi0, lo1, hi1, lo2, hi2)
    c0, c1, c2 = _cell_xyz(c, ncell)
    A = _axis_parts(c0, reach[0], ncell[0], period[0])
    B = _axis_parts(c1, reach[1], ncell[1], period[1])
    E = _axis_parts(c2, reach[2], ncell[2], period[2])
    m = 0
    for ia in range(2):
        for a in range(A[2 * ia], A[2 * ia + 1] + 1):
            aa, sh0 = _image(a, ncell[0], period[0])
            for ib in range(2):
                for b in range(B[2 * ib], B[2 * ib + 1] + 1):
                    bb, sh1 = _image(b, ncell[1], period[1])
                    row = (aa * ncell[1] + bb) * ncell[2]
                    for ie in range(2):
                        e = E[2 * ie]
                        while e <= E[2 * ie + 1]:  # runs of last-axis cells with one image
                            ee, sh2 = _image(e, ncell[2], period[2])
                            run = min(E[2 * ie + 1] - e, ncell[2] - 1 - ee)
                            ps = np.uint64(cell_start[row + ee])
                            pe = np.uint64(cell_start[row + ee + run + 1])
                            m = _gather_run(xs, order, kb, um, ps, pe, sh0, sh1, sh2, bbox,
                                            r2max, cx, cj, cb, m)
                            e += run + 1
    return m, _sort_candidates(cx, cj, cb, m)


@njit(cache=True, inline="always")
def _kind_hits(xi0, xi1, xi2, cx0, cx1, cx2, cb, rm, m, r2max, hit):
    """Hit mask of the candidates within r2max whose kind bit is in ``rm``."""
    for q in range(np.uint64(m)):
        d0 = xi0 - cx0[q]
        d1 = xi1 - cx1[q]
        d2 = xi2 - cx2[q]
        hit[q] = (d0 * d0 + d1 * d1 + d2 * d2 <= r2max) & ((cb[q] & rm) != 0)


@njit(cache=True, inline="always")
def _kind_count(xi0, xi1, xi2, cx0, cx1, cx2, cb, rm, m, r2max):
    """Number of candidates within r2max whose kind bit is in ``rm`` (self included)."""
    k = 0
    for q in range(np.uint64(m)):
        d0 = xi0 - cx0[q]
        d1 = xi1 - cx1[q]
        d2 = xi2 - cx2[q]
        k += (d0 * d0 + d1 * d1 + d2 * d2 <= r2max) & ((cb[q] & rm) != 0)
    return k


@njit(cache=True, inline="always")
def _clear_self(hit, cj, m, i, ascending):
    """Clear the hit of particle ``i`` itself (binary search when ``cj`` ascends; else every
    occurrence: in a tiny periodic box its other images are candidates too, never hits)."""
    if ascending:
        a = 0
        b = m
        while a < b:
            h = (a + b) >> 1
            if cj[h] < i:
                a = h + 1
            else:
                b = h
        hit[a] = 0
    else:
        for q in range(m):
            if cj[q] == i:
                hit[q] = 0


@njit(cache=True, inline="always")
def _popcount(w):
    w = w - ((w >> np.uint64(1)) & np.uint64(0x5555555555555555))
    w = (w & np.uint64(0x3333333333333333)) + ((w >> np.uint64(2)) & np.uint64(0x3333333333333333))
    w = (w + (w >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return np.int64((w * np.uint64(0x0101010101010101)) >> np.uint64(56))


@njit(cache=True)
def _chunks(cell_start, n):
    """Bounds of chunks of consecutive cells holding about equal numbers of particles
    (empty regions of the grid cost nothing), split statically between the threads."""
    ncells = cell_start.shape[0] - 1
    nchunk = max(1, min(ncells, n, 1024))
    targets = (np.arange(nchunk + 1) * n) // nchunk
    bounds = np.searchsorted(cell_start[1:], targets, side="right")
    bounds[0] = 0
    bounds[nchunk] = ncells
    return bounds


@njit(cache=True, parallel=True)
def _mask_pass(xs, order, kb, rmask, cell_start, ncell, reach, period, r2max, maxcand,
               cand_start, cand, cand_m, cand_asc, bits):
    """Per cell: gather the candidates (ids into ``cand[cand_start[c]:]``, their number in
    ``cand_m``, ``cand_asc`` whether they ascend); per particle (cell order): its hit bit
    mask over them into ``bits``.  Returns the counts (self excluded).

    ``kb`` (cell order) is the kind bit of every particle and ``rmask`` the kind bits its
    row keeps (all ones and 0xFF without a pair filter).  A cell gathers only candidates
    whose kind some of its particles keep; when all its particles keep the same kinds the
    distance loop needs no kind test.  Each particle writes only its own mask, so the pass
    is race free, and the result does not depend on the thread count.
    """
    n = order.shape[0]
    counts = np.zeros(n, dtype=np.int64)
    magic = np.uint64(0x0102040810204080)
    bounds = _chunks(cell_start, n)
    for t in prange(bounds.shape[0] - 1):
        cx = np.empty((3, maxcand + 1))
        cb = np.zeros(maxcand + 64, dtype=np.uint8)
        hit = np.zeros(maxcand + 64, dtype=np.uint8)
        hit8 = hit[: 8 * (hit.shape[0] // 8)].view(np.uint64)
        cx0 = cx[0]
        cx1 = cx[1]
        cx2 = cx[2]
        for c in range(bounds[t], bounds[t + 1]):
            p0 = cell_start[c]
            p1 = cell_start[c + 1]
            cand_m[c] = 0
            if p1 == p0:
                continue
            um = rmask[p0]  # kinds kept by some particle of the cell
            uniform = True
            for p in range(p0 + 1, p1):
                uniform &= rmask[p] == um
                um |= rmask[p]
            if um == 0:
                continue  # counts stay 0
            cj = cand[cand_start[c] : cand_start[c + 1]]
            m, ascending = _gather_candidates(
                c, xs, order, kb, um, cell_start, ncell, reach, period, r2max, cx, cj, cb
            )
            cand_m[c] = m
            cand_asc[c] = ascending
            if m == 0:
                continue
            nw = np.uint64((m + 63) // 64)
            hit[m : m + 64] = 0  # padding of the last 64-candidate word
            for p in range(p0, p1):
                rm = rmask[p]
                if rm == 0:
                    continue
                xi0 = xs[0, p]
                xi1 = xs[1, p]
                xi2 = xs[2, p]
                if uniform:
                    for q in range(np.uint64(m)):
                        d0 = xi0 - cx0[q]
                        d1 = xi1 - cx1[q]
                        d2 = xi2 - cx2[q]
                        hit[q] = d0 * d0 + d1 * d1 + d2 * d2 <= r2max
                else:
                    _kind_hits(xi0, xi1, xi2, cx0, cx1, cx2, cb, rm, m, r2max, hit)
                if (kb[p] & rm) != 0:  # itself among the kept candidates
                    _clear_self(hit, cj, m, order[p], ascending)
                # bytes -> bits: one multiply gathers the 8 bytes of a word (byte t -> bit t)
                row = bits[p]
                k = 0
                for w in range(nw):
                    word = np.uint64(0)
                    for b in range(np.uint64(8)):
                        v = hit8[np.uint64(8) * w + b]
                        word |= ((v * magic) >> np.uint64(56)) << (np.uint64(8) * b)
                    row[w] = word
                    k += _popcount(word)
                counts[order[p]] = k
    return counts


@njit(cache=True, parallel=True)
def _fill_pass(order, rmask, cell_start, cand_start, cand, cand_m, cand_asc, bits, offsets,
               out):
    """Every particle writes the candidates of its set bits to its own CSR segment (sorted
    when its cell's candidates do not ascend); race free."""
    n = order.shape[0]
    bounds = _chunks(cell_start, n)
    for t in prange(bounds.shape[0] - 1):
        for c in range(bounds[t], bounds[t + 1]):
            m = cand_m[c]
            if m == 0:
                continue
            cj = cand[cand_start[c] : cand_start[c + 1]]
            ascending = cand_asc[c]
            nw = np.uint64((m + 63) // 64)
            for p in range(cell_start[c], cell_start[c + 1]):
                if rmask[p] == 0:
                    continue
                row = bits[p]
                base = np.uint64(offsets[order[p]])
                k = base
                for w in range(nw):
                    word = row[w]
                    q0 = np.uint64(64) * w
                    while word:
                        out[k] = cj[q0 + np.uint64(trailing_zeros(word))]
                        k += np.uint64(1)
                        word &= word - np.uint64(1)
                # a subsequence of ascending candidates ascends; otherwise (particles far
                # from cell-sorted, or a tiny periodic box) sort the segment
                if not ascending:
                    out[base:k].sort()


# ----------------------------------------------------------------------------- public API


def build_neighbor_list(
    x, radius, lo, hi, period=None, *, cells_per_radius: int = 1, kind=None, keep=None
) -> NeighborList:
    """All pairs with ``|x_i - x_j| <= radius`` (minimum image on periodic axes), in CSR form.

    Parameters
    ----------
    x : (n, dim) float64 positions, dim in 1..3.
    radius : search radius (the kernel support radius R); must be positive.
    lo, hi : (dim,) domain bounds.  On periodic axes positions are wrapped into
        ``[lo, lo + period)`` for binning; on other axes particles may lie outside
        ``[lo, hi]`` (they are binned in the edge cells).
    period : (dim,) periodic length per axis, 0 for non-periodic (``Domain.period``).
        Requires ``radius < period / 2`` on every periodic axis.
    cells_per_radius : cells per search radius (1: cell = R, 27 cells visited in 3D,
        the fastest here; 2: cell = R/2, 125 smaller cells, about 2x slower).

    kind, keep : optional pair filter applied while the list is built (no second pass):
        ``kind`` (n,) integer kinds in 0..7, ``keep`` a sequence of bit masks indexed by
        kind -- row i keeps neighbour j only if bit ``kind[j]`` of ``keep[kind[i]]`` is set
        (rows of kinds beyond ``keep`` or with mask 0 are empty).

    Returns a :class:`NeighborList` (self excluded, ``r <= radius`` included, segments
    ascending).  Fastest on a set sorted with :func:`cell_sort_permutation` (same
    ``radius``); any order gives the same list.  Separations must then be taken with
    :func:`min_image` on periodic axes (positions themselves are not wrapped).
    """
    x = _check_positions(x)
    n, dim = x.shape
    if sys.byteorder != "little":  # _mask_pass reads a byte mask as little-endian words
        raise NotImplementedError("the neighbour search assumes a little-endian machine")
    radius = float(radius)
    if not (np.isfinite(radius) and radius > 0.0):
        raise ValueError(f"search radius must be positive and finite, got {radius}")
    lo = _as_vector(lo, dim, "lo")
    hi = _as_vector(hi, dim, "hi")
    period = np.zeros(dim) if period is None else _as_vector(period, dim, "period")
    if np.any(period < 0):
        raise ValueError(f"periods must be >= 0 (0: not periodic), got {period}")
    for k in range(dim):
        if period[k] > 0 and not radius < 0.5 * period[k]:
            raise ValueError(
                f"radius {radius} must be smaller than half the period {period[k]} of axis {k}"
            )
    if cells_per_radius not in (1, 2, 3):
        raise ValueError("cells_per_radius must be 1, 2 or 3")
    if n == 0:
        return NeighborList(np.zeros(1, np.int64), np.zeros(0, np.int32), radius, period)
    if n >= np.iinfo(np.int32).max:
        raise ValueError("too many particles for int32 neighbour indices")

    g = _make_grid(n, radius, lo, hi, period, cells_per_radius)
    xw, cid = _cell_coords(x, g.origin, g.width, g.ncell, g.period)
    order, cell_start = _counting_sort(cid, int(np.prod(g.ncell)))
    xs = _gather_columns(xw, order)
    order32 = order.astype(np.int32)
    r2max = radius * radius
    ub = _stencil_counts(cell_start, g.ncell, g.reach, g.period)
    maxcand = int(ub.max())
    cand_start = np.zeros(ub.shape[0] + 1, dtype=np.int64)
    np.cumsum(ub, out=cand_start[1:])
    cand_m = np.empty(ub.shape[0], dtype=np.int64)
    cand_asc = np.empty(ub.shape[0], dtype=np.bool_)
    # hit bit masks of the mask pass, read by the fill pass (no second distance test), and
    # every cell's candidate ids: both in the thread's work buffer
    words = (maxcand + 63) // 64
    nbits = n * words * 8
    ncand = int(cand_start[-1])
    work = work_buffer(nbits + 4 * ncand)
    bits = work[:nbits].view(np.uint64).reshape(n, words)
    cand = work[nbits:nbits + 4 * ncand].view(np.int32)
    kb, rmask = _kind_bits(order, *_pair_filter(kind, keep, n))
    counts = _mask_pass(xs, order32, kb, rmask, cell_start, g.ncell, g.reach, g.period, r2max,
                        maxcand, cand_start, cand, cand_m, cand_asc, bits)
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    indices = np.empty(int(offsets[-1]), dtype=np.int32)
    if indices.shape[0]:
        _fill_pass(order32, rmask, cell_start, cand_start, cand, cand_m, cand_asc, bits,
                   offsets, indices)
    return NeighborList(offsets, indices, radius, period)


@njit(cache=True)  # serial: memory bound
def _kind_bits(order, kind, keep):
    """Kind bit and kept-kinds mask of every particle in cell order (all ones / 0xFF
    without a filter, ``kind`` empty)."""
    n = order.shape[0]
    kb = np.ones(n, dtype=np.uint8)
    rmask = np.full(n, 0xFF, dtype=np.uint8)
    if kind.shape[0]:
        for p in range(n):
            k = kind[order[p]]
            kb[p] = np.uint8(1) << k
            rmask[p] = keep[k]
    return kb, rmask


_SCRATCH = threading.local()


def work_buffer(nbytes: int) -> np.ndarray:
    """The calling thread's work buffer: ``nbytes`` bytes (uint8, 8-byte aligned), kept
    between calls and grown by 1/8 when too small.

    Shared by work that never overlaps in time: :func:`build_neighbor_list` keeps its
    candidate ids and hit masks here (4 B per stencil candidate of every cell, 1 bit per
    particle and candidate of its cell: ~290 B per particle for the 3D dam break), and a
    caller may keep per-evaluation data here between two builds (the fluid's compacted
    rows, :meth:`sphfem.fluid.wcsph.FluidSolver.evaluate`).  Its contents are undefined
    after the next call by anyone, so take a view, use it and drop it; never hold one
    across a list build.  At 1e6 particles one buffer instead of two saves ~0.4 GB, and a
    kept buffer spares the page faults of a fresh one at every build (which doubled the
    first rebuilds of a fluid run).
    """
    nbytes = int(nbytes)
    buf = getattr(_SCRATCH, "work", None)
    if buf is None or buf.shape[0] < nbytes:
        buf = None
        _SCRATCH.work = None  # the old buffer goes before the new one is allocated
        buf = np.empty((nbytes + nbytes // 8 + 7) // 8, dtype=np.uint64).view(np.uint8)
        _SCRATCH.work = buf
    return buf[:nbytes]


def _pair_filter(kind, keep, n):
    """(kind as int64 or empty, 8 uint8 masks) for :func:`_cell_pass`."""
    if kind is None:
        return np.zeros(0, np.int64), np.zeros(8, np.uint8)
    kind = np.ascontiguousarray(kind, dtype=np.int64)
    if kind.shape != (n,):
        raise ValueError(f"kind must have shape ({n},), got {kind.shape}")
    if n and (kind.min() < 0 or kind.max() > 7):
        raise ValueError("pair filter: kinds must lie in 0..7")
    masks = np.zeros(8, np.uint8)
    if keep is None or len(keep) > 8:
        raise ValueError("pair filter: give keep, at most 8 bit masks (one per kind)")
    masks[: len(keep)] = np.asarray(keep, dtype=np.uint8)
    return kind, masks


@njit(cache=True)
def _sub_cell_ids(xw, origin, width, ncell, nsub):
    """Row-major index of the sub-cell (``nsub`` per axis) holding each particle."""
    n = xw.shape[1]
    sid = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for K in range(3):
            f = (xw[K, i] - origin[K]) / width[K]
            cell = min(max(np.floor(f), 0.0), ncell[K] - 1.0)
            sub = min(max(np.floor((f - cell) * nsub), 0.0), nsub - 1.0)
            c = c * nsub + np.int64(sub)
        sid[i] = c
    return sid


def cell_sort_permutation(x, cell_size, lo, hi, period=None, *, sub_cells: int = 3):
    """Permutation (int64) ordering particles by row-major cell, last axis fastest.

    The cells are those :func:`build_neighbor_list` uses for ``radius = cell_size`` (with
    ``cells_per_radius=1``; pass ``radius / c`` for ``cells_per_radius=c``), so after
    ``particles.reorder(perm)`` the search reads candidates contiguously and finds every
    neighbour segment already sorted.  Within a cell, particles are ordered by sub-cells
    (``sub_cells`` per axis, row-major), which keeps the hit masks of the search clustered
    (about 1.5x faster than a random order inside the cells).  Stable: particles in one
    sub-cell keep their order, so a sorted set gives the identity.  Positions outside
    ``[lo, hi]`` go to the edge cells (wrapped on periodic axes).
    """
    x = _check_positions(x)
    n, dim = x.shape
    cell_size = float(cell_size)
    if not (np.isfinite(cell_size) and cell_size > 0):
        raise ValueError(f"cell size must be positive and finite, got {cell_size}")
    if not 1 <= int(sub_cells) <= 8:
        raise ValueError(f"sub_cells must be in 1..8, got {sub_cells}")
    lo = _as_vector(lo, dim, "lo")
    hi = _as_vector(hi, dim, "hi")
    period = np.zeros(dim) if period is None else _as_vector(period, dim, "period")
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    g = _make_grid(n, cell_size, lo, hi, period, 1)
    xw, cid = _cell_coords(x, g.origin, g.width, g.ncell, g.period)
    if sub_cells == 1:
        order, _ = _counting_sort(cid, int(np.prod(g.ncell)))
        return order
    # two stable counting sorts (LSD radix): by sub-cell, then by cell
    sid = _sub_cell_ids(xw, g.origin, g.width, g.ncell, int(sub_cells))
    by_sub, _ = _counting_sort(sid, int(sub_cells) ** 3)
    by_cell, _ = _counting_sort(cid[by_sub], int(np.prod(g.ncell)))
    return by_sub[by_cell]
