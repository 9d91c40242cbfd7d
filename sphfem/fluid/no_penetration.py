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
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


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
        self.xw = xw[keep]
        self.nw = nw[keep] / np.linalg.norm(nw[keep], axis=1)[:, None]
        d = xw.shape[1]
        self.half = 0.5 * np.broadcast_to(np.asarray(vol, float), (xw.shape[0],))[keep] ** (1.0 / d)
        self.k = min(int(k), max(int(keep.sum()), 1))
        self.reach = 4.0 * float(self.half.max()) * 2.0 if keep.any() else 0.0
        self.tree = cKDTree(self.xw) if keep.any() else None

    def distance(self, x):
        """Signed distance phi (n,) of the points ``x`` to the wall surface (+inf where no
        tile covers the point within the search reach) and the normal (n, d) of the tile."""
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
        bad = np.flatnonzero(phi < 0.0)
        if bad.size == 0:
            return 0
        x[bad] -= phi[bad, None] * nrm[bad]
        vn = (v[bad] * nrm[bad]).sum(axis=1)
        v[bad] -= np.minimum(vn, 0.0)[:, None] * nrm[bad]
        return int(bad.size)
