"""Fixed-radius neighbour search: a cell-linked list in CSR form, in numba.

One code path serves 1D, 2D and 3D (positions ``x`` of shape ``(n, dim)``).  The grid is
padded to three axes internally (leading axes of one cell), so the last real axis is the
fastest-varying cell axis and the cells ``(a, b, c - s .. c + s)`` of a row are one
contiguous block of the cell-sorted particle copy.

Algorithm (CompactNSearch / PySPH ``LinkedListNNPS`` style):

1. cell coordinates of every particle (periodic axes wrapped, others clamped to the grid);
2. counting sort of the linear cell ids -> ``cell_start`` (exclusive cumsum) and ``order``;
   positions are gathered into cell order so that candidate loops read contiguous memory;
3. a parallel *count* pass over particles (``prange``, gather only) -> ``offsets``;
4. a parallel *fill* pass writing each particle's own CSR segment -> ``indices``.

Every particle's neighbours are returned sorted by index, so the list does not depend on
the thread count.  Pairs at distance exactly ``radius`` are included (``r^2 <= R^2``, no
square root).  Periodic axes use the minimum-image convention; this needs
``radius < period / 2`` (checked), so that at most one image of a particle is a neighbour.

For cache locality, sort the particles once in a while with :func:`cell_sort_permutation`
(``particles.reorder(perm)``); the search is correct for any order, but the sorted case is
several times faster (contiguous candidate rows, and the per-particle sort is a no-op).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange

FASTMATH = {"reassoc", "contract", "arcp", "afn"}

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


def _make_grid(x, radius, lo, hi, period, cells_per_radius, max_cells) -> _Grid:
    n, dim = x.shape
    cw = radius / cells_per_radius * (1.0 + _SLACK)
    origin = np.zeros(3)
    width = np.ones(3)
    ncell = np.ones(3, dtype=np.int64)
    per = np.zeros(3)
    span = np.zeros(3)
    xmin = x.min(axis=0) if n else lo.copy()
    xmax = x.max(axis=0) if n else lo.copy()
    for k in range(dim):
        K = 3 - dim + k
        if period[k] > 0:
            L = float(period[k])
            per[K] = L
            origin[K] = lo[k]
            ncell[K] = max(1, int(np.floor(L / cw)))
            width[K] = L / ncell[K]
        else:
            # grid over the part of [lo, hi] that holds particles; outliers are clamped
            g0 = min(max(lo[k], xmin[k]), hi[k])
            g1 = max(min(hi[k], xmax[k]), g0)
            origin[K] = g0
            span[K] = g1 - g0
            width[K] = cw
            ncell[K] = int(np.floor(span[K] / cw)) + 1
    # cap the cell count (a huge domain with few particles): widen the busiest axis
    while np.prod(ncell) > max_cells:
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


@njit(cache=True, parallel=True)
def _cell_coords(x, origin, width, ncell, period, cc):
    """Padded 3-axis cell coordinates ``cc`` (n, 3) and linear row-major cell ids."""
    n, dim = x.shape
    off = 3 - dim
    cid = np.empty(n, dtype=np.int64)
    for i in prange(n):
        for K in range(off):
            cc[i, K] = 0
        for k in range(dim):
            K = off + k
            y = x[i, k] - origin[K]
            L = period[K]
            if L > 0.0:
                y -= L * np.floor(y / L)
            c = np.floor(y / width[K])
            if c < 0.0:
                c = 0.0
            top = ncell[K] - 1
            if c > top:
                c = top
            cc[i, K] = np.int64(c)
        cid[i] = (cc[i, 0] * ncell[1] + cc[i, 1]) * ncell[2] + cc[i, 2]
    return cid


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


@njit(cache=True, parallel=True)
def _gather_rows(x, order):
    n, dim = x.shape
    xs = np.empty((n, dim))
    for p in prange(n):
        j = order[p]
        for k in range(dim):
            xs[p, k] = x[j, k]
    return xs


@njit(cache=True, inline="always")
def _axis_range(c, s, nc, L):
    """First and last (unwrapped) cell on one axis, and whether indices must be wrapped."""
    if L > 0.0:
        if 2 * s + 1 >= nc:
            return 0, nc - 1, False
        return c - s, c + s, True
    a = c - s
    b = c + s
    if a < 0:
        a = 0
    if b > nc - 1:
        b = nc - 1
    return a, b, False


@njit(cache=True, inline="always")
def _row_ranges(c, s, nc, L):
    """Up to two ascending, wrapped cell ranges [b0, e0], [b1, e1] on the last axis."""
    a, b, wrap = _axis_range(c, s, nc, L)
    if wrap:
        if a < 0:
            return 0, b, a + nc, nc - 1
        if b >= nc:
            return 0, b - nc, a, nc - 1
    return a, b, 0, -1


@njit(cache=True, inline="always")
def _dist2(xs, p, xi0, xi1, xi2, L0, L1, L2, dim):
    d = min_image(xi0 - xs[p, 0], L0)
    r2 = d * d
    if dim > 1:
        d = min_image(xi1 - xs[p, 1], L1)
        r2 += d * d
    if dim > 2:
        d = min_image(xi2 - xs[p, 2], L2)
        r2 += d * d
    return r2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _neighbor_pass(x, xs, order, rank, cc, cell_start, ncell, reach, period, r2max, offsets, out):
    """Count (``out`` empty) or fill (``out`` sized by ``offsets``) every particle's segment.

    Returns the per-particle neighbour counts.  Particles are processed independently, each
    writing only its own segment, so the pass is race free.
    """
    n, dim = x.shape
    off = 3 - dim
    fill = out.shape[0] > 0
    n0, n1, n2 = ncell[0], ncell[1], ncell[2]
    s0, s1, s2 = reach[0], reach[1], reach[2]
    P0, P1, P2 = period[0], period[1], period[2]
    L0 = period[off]
    L1 = period[off + 1] if dim > 1 else 0.0
    L2 = period[off + 2] if dim > 2 else 0.0
    counts = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        xi0 = x[i, 0]
        xi1 = x[i, 1] if dim > 1 else 0.0
        xi2 = x[i, 2] if dim > 2 else 0.0
        ri = rank[i]
        a0, a1, w0 = _axis_range(cc[i, 0], s0, n0, P0)
        b0, b1, w1 = _axis_range(cc[i, 1], s1, n1, P1)
        e0, e1, f0, f1 = _row_ranges(cc[i, 2], s2, n2, P2)
        k = 0
        base = offsets[i] if fill else 0
        for a in range(a0, a1 + 1):
            aa = a % n0 if w0 else a
            for b in range(b0, b1 + 1):
                bb = b % n1 if w1 else b
                row = (aa * n1 + bb) * n2
                for r in range(2):
                    lo_c = e0 if r == 0 else f0
                    hi_c = e1 if r == 0 else f1
                    if hi_c < lo_c:
                        continue
                    pstart = cell_start[row + lo_c]
                    pend = cell_start[row + hi_c + 1]
                    for p in range(pstart, pend):
                        r2 = _dist2(xs, p, xi0, xi1, xi2, L0, L1, L2, dim)
                        if r2 <= r2max and p != ri:
                            if fill:
                                out[base + k] = order[p]
                            k += 1
        counts[i] = k
    return counts


@njit(cache=True, parallel=True)
def _sort_segments(offsets, indices):
    """Sort every particle's segment ascending (a check only, when particles are cell-sorted)."""
    n = offsets.shape[0] - 1
    for i in prange(n):
        s = offsets[i]
        e = offsets[i + 1]
        for q in range(s + 1, e):
            if indices[q] < indices[q - 1]:
                indices[s:e].sort()
                break


# ----------------------------------------------------------------------------- public API


def build_neighbor_list(
    x, radius, lo, hi, period=None, *, cells_per_radius: int = 1
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
    cells_per_radius : cells per search radius (1: cell = R, 27 cells visited in 3D;
        2: cell = R/2, 125 smaller cells).
    """
    x = _check_positions(x)
    n, dim = x.shape
    radius = float(radius)
    if not (np.isfinite(radius) and radius > 0.0):
        raise ValueError(f"search radius must be positive and finite, got {radius}")
    lo = _as_vector(lo, dim, "lo")
    hi = _as_vector(hi, dim, "hi")
    period = np.zeros(dim) if period is None else _as_vector(period, dim, "period")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.isfinite(period).all()):
        raise ValueError("domain bounds and periods must be finite")
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
    if n > np.iinfo(np.int32).max:
        raise ValueError("too many particles for int32 neighbour indices")

    g = _make_grid(x, radius, lo, hi, period, cells_per_radius, max(4 * n, 1 << 16))
    cc = np.empty((n, 3), dtype=np.int64)
    cid = _cell_coords(x, g.origin, g.width, g.ncell, g.period, cc)
    order, cell_start = _counting_sort(cid, int(np.prod(g.ncell)))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    xs = _gather_rows(x, order)
    r2max = radius * radius
    args = (x, xs, order, rank, cc, cell_start, g.ncell, g.reach, g.period, r2max)
    counts = _neighbor_pass(*args, np.zeros(1, np.int64), np.zeros(0, np.int32))
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    indices = np.empty(int(offsets[-1]), dtype=np.int32)
    if indices.shape[0]:
        _neighbor_pass(*args, offsets, indices)
        _sort_segments(offsets, indices)
    return NeighborList(offsets, indices, radius, period)


@njit(cache=True, parallel=True)
def _sort_keys(x, lo, cell_size, ncell):
    n, dim = x.shape
    cid = np.empty(n, dtype=np.int64)
    for i in prange(n):
        c = 0
        for k in range(dim):
            f = np.floor((x[i, k] - lo[k]) / cell_size)
            if f < 0.0:
                f = 0.0
            if f > ncell[k] - 1:
                f = ncell[k] - 1
            c = c * ncell[k] + np.int64(f)
        cid[i] = c
    return cid


def cell_sort_permutation(x, cell_size, lo, hi) -> np.ndarray:
    """Permutation (int64) ordering particles by row-major cell, last axis fastest.

    Stable: particles in one cell keep their relative order.  Apply with
    ``particles.reorder(perm)`` (new index k holds old particle ``perm[k]``).  Use the
    neighbour-search radius (or a multiple) as ``cell_size``; positions outside
    ``[lo, hi]`` are clamped to the edge cells.
    """
    x = _check_positions(x)
    n, dim = x.shape
    if not (np.isfinite(cell_size) and cell_size > 0):
        raise ValueError(f"cell size must be positive and finite, got {cell_size}")
    lo = _as_vector(lo, dim, "lo")
    hi = _as_vector(hi, dim, "hi")
    cell_size = float(cell_size)
    cap = max(4 * n, 1 << 16)
    while True:
        ncell = np.maximum(1, np.floor((hi - lo) / cell_size).astype(np.int64) + 1)
        if np.prod(ncell.astype(float)) <= cap:
            break
        cell_size *= 2.0
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    cid = _sort_keys(x, lo, cell_size, ncell)
    order, _ = _counting_sort(cid, int(np.prod(ncell)))
    return order
