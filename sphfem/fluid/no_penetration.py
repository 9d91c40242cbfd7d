"""No-penetration correction of the fluid's position update at particle walls at rest.

Particle walls (Adami et al. 2012) stop fluid particles only through the pressure that their
compression builds.  A fluid particle that has entered the wall layers sees wall particles
above and below it: the Adami extrapolation hands them its own pressure and the wall ghost
velocities of the continuity cancel above and below, so nothing pushes it back out (measured
in the axisymmetric droplet impact at D/dx = 32: rings at the contact line pulled in by the
negative pressure of the lamella's tip, then sinking at 0.1-0.3 V to 2.6 dx under the wall
top with net accelerations of 0.05-0.2 V^2/dx; ``examples/axisymmetric/impact_robustness.py``).

The kinematic wall condition u . n >= 0 (impermeable wall at rest; the free-slip /
no-penetration condition of Marrone et al. 2011, CMAME 200, 1526, sec. 3) is imposed on the
position update instead: a wall particle j with outward unit normal n_j and meridian (or
planar) area vol_j covers the tile of half-width s_j / 2 = sqrt(vol_j) / 2 along its wall, and
its outer face lies s_j / 2 along n_j.  The signed distance of a fluid particle i to the wall
surface is

    phi_i = min_j [(x_i - x_j) . n_j - s_j / 2]   over the wall particles j whose tile holds
                                                  the projection of x_i, |t_ij| <= s_j / 2,

(for a layered wall the outermost layer gives the minimum).  A particle with phi_i < 0 is
moved back to the surface along n_j, x_i -= phi_i n_j, and the inward normal component of
its velocity is removed, v_i -= min(v_i . n_j, 0) n_j (an inelastic contact with the rigid
wall: the wall takes the normal momentum, as a wall does).  Masses are untouched, so mass
is conserved exactly; tangential velocity is untouched.  Wall particles without a normal
(a zero row) take no part.

The candidates j are the ``k`` wall particles nearest to x_i within the search reach (as a
k-d tree query returns them, nearest first; ties in phi go to the nearer tile).  The walls
are at rest, so :class:`NoPenetration` bins them once on a uniform grid of cell size =
reach and :func:`signed_distance` (numba, parallel over the points) scans the 3^d cells
around each point; :meth:`NoPenetration.distance_reference` is the k-d tree / numpy form it
replaces (the same figures to the bit, tests/test_no_penetration.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree


@njit(cache=True)
def _bin_walls(xw, origin, width, ncell):
    """Counting sort of the wall particles into the cells of a uniform grid: ``start``
    (cells + 1,) and ``items`` (wall indices, ascending within a cell)."""
    m, d = xw.shape
    ncells = 1
    for a in range(d):
        ncells *= ncell[a]
    cid = np.empty(m, np.int64)
    for j in range(m):
        c = 0
        for a in range(d):
            c = c * ncell[a] + int(math.floor((xw[j, a] - origin[a]) / width))
        cid[j] = c
    start = np.zeros(ncells + 1, np.int64)
    for j in range(m):
        start[cid[j] + 1] += 1
    for c in range(ncells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    items = np.empty(m, np.int64)
    for j in range(m):
        items[fill[cid[j]]] = j
        fill[cid[j]] += 1
    return start, items


@njit(cache=True, parallel=True)
def signed_distance(x, xw, nw, half, reach, k, origin, width, ncell, start, items, stencil,
                    cd2, cj, phi, nrm):
    """phi_i and n_i of the module docstring for the points ``x`` (n, d): over the ``k``
    wall particles nearest to x_i with |x_i - x_j| < ``reach`` (nearest first; equal
    distances by index), the tile with the smallest (x_i - x_j) . n_j - s_j / 2 among those
    with |t_ij| <= s_j / 2 (1 + 1e-9), the nearer one on a tie.  Walls binned by
    :func:`_bin_walls` (cell size ``width`` >= ``reach``; ``stencil`` the 3^d cell
    offsets); ``cd2``, ``cj`` (n, k) work arrays.  phi = inf and n = 0 where no tile
    covers the point (and at non-finite points)."""
    n, d = x.shape
    r2 = reach * reach
    for i in prange(n):
        phi[i] = np.inf
        for a in range(d):
            nrm[i, a] = 0.0
        fin = True
        for a in range(d):
            if not math.isfinite(x[i, a]):
                fin = False
        if not fin:
            continue
        cnt = 0
        for s in range(stencil.shape[0]):
            c = 0
            inside = True
            for a in range(d):
                ca = int(math.floor((x[i, a] - origin[a]) / width)) + stencil[s, a]
                if ca < 0 or ca >= ncell[a]:
                    inside = False
                    break
                c = c * ncell[a] + ca
            if not inside:
                continue
            for q in range(start[c], start[c + 1]):
                j = items[q]
                d2 = 0.0
                for a in range(d):
                    e = x[i, a] - xw[j, a]
                    d2 += e * e
                if not d2 < r2:
                    continue
                # insert (d2, j) into the sorted list of the k nearest
                if cnt == k and (d2 > cd2[i, k - 1] or (d2 == cd2[i, k - 1]
                                                        and j > cj[i, k - 1])):
                    continue
                p = cnt if cnt < k else k - 1
                while p > 0 and (cd2[i, p - 1] > d2 or (cd2[i, p - 1] == d2
                                                        and cj[i, p - 1] > j)):
                    cd2[i, p] = cd2[i, p - 1]
                    cj[i, p] = cj[i, p - 1]
                    p -= 1
                cd2[i, p] = d2
                cj[i, p] = j
                if cnt < k:
                    cnt += 1
        best = np.inf
        bj = -1
        for q in range(cnt):
            j = cj[i, q]
            dn = 0.0
            for a in range(d):
                dn += (x[i, a] - xw[j, a]) * nw[j, a]
            t2 = 0.0
            for a in range(d):
                e = (x[i, a] - xw[j, a]) - dn * nw[j, a]
                t2 += e * e
            h = half[j]
            if math.sqrt(t2) <= h * (1 + 1e-9):
                ph = dn - h
                if ph < best:
                    best = ph
                    bj = j
        if bj >= 0:
            phi[i] = best
            for a in range(d):
                nrm[i, a] = nw[bj, a]


@njit(cache=True)
def _project(x, v, phi, nrm):
    """x_i -= phi_i n_i and v_i -= min(v_i . n_i, 0) n_i where phi_i < 0 (in place);
    returns how many points were moved."""
    n, d = x.shape
    moved = 0
    for i in range(n):
        if not phi[i] < 0.0:
            continue
        moved += 1
        vn = 0.0
        for a in range(d):
            x[i, a] -= phi[i] * nrm[i, a]
            vn += v[i, a] * nrm[i, a]
        vn = min(vn, 0.0)
        for a in range(d):
            v[i, a] -= vn * nrm[i, a]
    return moved


class NoPenetration:
    """Signed distances to, and projection onto, the surface of a wall at rest.

    ``xw`` (m, d) wall positions, ``nw`` (m, d) outward unit normals (zero rows: ignored),
    ``vol`` (m,) the wall particles' areas (2D / meridian plane) or volumes (3D), so that
    the spacing is s = vol^(1/d).  ``k`` wall neighbours are searched per fluid particle.
    """

    def __init__(self, xw, nw, vol, k: int = 16):
        xw = np.asarray(xw, float)
        nw = np.asarray(nw, float).reshape(xw.shape)
        keep = np.linalg.norm(nw, axis=1) > 0
        self.xw = np.ascontiguousarray(xw[keep])
        self.nw = np.ascontiguousarray(nw[keep] / np.linalg.norm(nw[keep], axis=1)[:, None])
        d = xw.shape[1]
        self.half = np.ascontiguousarray(
            0.5 * np.broadcast_to(np.asarray(vol, float), (xw.shape[0],))[keep] ** (1.0 / d))
        self.k = min(int(k), max(int(keep.sum()), 1))
        self.reach = 4.0 * float(self.half.max()) * 2.0 if keep.any() else 0.0
        self._tree = None
        self._grid = None
        self._work = None
        if keep.any():
            # cells of size reach (a point's candidates lie in the 3^d cells around it)
            origin = self.xw.min(axis=0) - self.reach
            ncell = (np.floor((self.xw.max(axis=0) + self.reach - origin) / self.reach)
                     .astype(np.int64) + 1)
            start, items = _bin_walls(self.xw, origin, self.reach, ncell)
            stencil = np.array(np.meshgrid(*([[-1, 0, 1]] * d), indexing="ij"),
                               np.int64).reshape(d, -1).T.copy()
            self._grid = (origin, ncell, start, items, stencil)

    @property
    def tree(self):
        """k-d tree of the walls (built on first use: :meth:`distance_reference` only)."""
        if self._tree is None and self.xw.shape[0]:
            self._tree = cKDTree(self.xw)
        return self._tree

    def distance(self, x):
        """Signed distance phi (n,) of the points ``x`` to the wall surface (+inf where no
        tile covers the point within the search reach) and the normal (n, d) of the tile
        (zero where phi = inf)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        n, d = x.shape
        phi = np.full(n, np.inf)
        nrm = np.zeros((n, d))
        if self._grid is None or n == 0:
            return phi, nrm
        origin, ncell, start, items, stencil = self._grid
        w = self._work  # the (n, k) candidate arrays, kept for the next call of this size
        if w is None or w[0].shape[0] != n:
            w = self._work = (np.empty((n, self.k)), np.empty((n, self.k), np.int64))
        cd2, cj = w
        signed_distance(x, self.xw, self.nw, self.half, self.reach, self.k, origin,
                        self.reach, ncell, start, items, stencil, cd2, cj, phi, nrm)
        return phi, nrm

    def distance_reference(self, x):
        """:meth:`distance` by a k-d tree query and numpy (the original form, kept as the
        reference of the tests; its normal where phi = inf is that of the nearest wall)."""
        n, d = x.shape
        phi = np.full(n, np.inf)
        nrm = np.zeros((n, d))
        if self.tree is None or n == 0:
            return phi, nrm
        dist, j = self.tree.query(x, k=self.k, distance_upper_bound=self.reach)
        dist, j = dist.reshape(n, -1), j.reshape(n, -1)
        ok = np.isfinite(dist)
        jj = np.where(ok, j, 0)
        rel = x[:, None, :] - self.xw[jj]
        nn = self.nw[jj]
        dn = (rel * nn).sum(axis=2)
        t = np.linalg.norm(rel - dn[..., None] * nn, axis=2)
        h = self.half[jj]
        ph = np.where(ok & (t <= h * (1 + 1e-9)), dn - h, np.inf)
        best = np.argmin(ph, axis=1)
        rows = np.arange(n)
        phi = ph[rows, best]
        nrm = nn[rows, best]
        return phi, nrm

    def apply(self, x, v) -> int:
        """Project the points with phi < 0 onto the wall surface and remove the inward normal
        velocity (in place); returns how many were corrected."""
        phi, nrm = self.distance(x)
        return int(_project(x, v, phi, nrm))
