"""Debris of an axisymmetric fluid: free-flying clusters too small to be resolved.

In an (r, z) run every particle is a ring, so a drop shed from a rim is a torus.  A torus of
a few rings cannot do what a resolved one does when it moves towards the axis (thicken in
the meridian plane as its volume 2 pi r A is kept): its rings' meridian areas A = M / (2 pi
r rho) grow as 1 / r at fixed spacing, the pair forces they exert grow with them past the
acoustic step's reach, and when the cluster meets its own mirror at the axis the hoop
compression -rho v_r / r of a ring at r ~ dx drives its density up by tens of per cent per
step.  Measured (10 m/s droplet impact at D/dx 181, docs/validation/droplet_impact, session
28): a two-ring cluster thrown backwards off the rim at 1 t_c reached the axis at 2.58 t_c,
went to 5 rho0 and 1.7e4 m/s and collapsed the time step to 1e-11 s.  In three dimensions
the same fluid is a ring of droplets that the axisymmetric model cannot represent.

:func:`free_debris` finds such clusters: connected sets of fluid rings (links shorter than
``link``) with at most ``max_rings`` rings, none within ``clearance`` of a wall ring or below
the wall plane.  The fluid makes them inert (:class:`~sphfem.fluid.axisymmetric.
AxisymmetricFluid`, ``debris_rings``): they leave every pair sum, keep their mass, momentum
and temperature and fly ballistically; their number and mass are reported.  A cluster that
touches a wall (a stray ring sliding on it) is never debris: it carries heat into the
substrate.
"""

from __future__ import annotations

import numpy as np


def free_debris(x, rows, link: float, max_rings: int, wall_x=None, clearance: float = 0.0,
                wall_z: float | None = None) -> np.ndarray:
    """The rows (a subset of ``rows``, indices into ``x`` (n, 2)) of the clusters of at most
    ``max_rings`` rings, clusters being the connected components of the graph of ``rows``
    whose edges are pairs closer than ``link``; a cluster is kept only when all its rings lie
    farther than ``clearance`` from every point of ``wall_x`` (k, 2) and, with ``wall_z``,
    above z = wall_z + clearance.  Returns a sorted int64 array (empty: none)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    rows = np.asarray(rows, np.int64)
    if max_rings <= 0 or rows.size == 0:
        return np.zeros(0, np.int64)
    p = np.asarray(x, float)[rows]
    pairs = cKDTree(p).query_pairs(link, output_type="ndarray")
    m = rows.size
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    _, lab = connected_components(g, directed=False)
    small = np.bincount(lab)[lab] <= max_rings
    if not small.any():
        return np.zeros(0, np.int64)
    near = np.zeros(m, bool)
    if wall_x is not None and len(wall_x):
        d, _ = cKDTree(np.asarray(wall_x, float)).query(p[small])
        near[small] = d <= clearance
    if wall_z is not None:
        near |= small & (p[:, 1] <= wall_z + clearance)
    touching = np.zeros(lab.max() + 1, bool)
    touching[lab[near]] = True
    keep = small & ~touching[lab]
    return np.sort(rows[keep])
