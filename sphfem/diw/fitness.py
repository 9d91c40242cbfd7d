"""How well a deposit follows the desired path: the thesis' fitness and what a practitioner
reads off a print.

All figures use the deposited particles projected on the substrate plane (their x, y):

* ``thesis``: f = sum_a (dist(r_a) / h)^3 (thesis eq. 3.47), dist = distance to the
  desired path, h = the deposit's smoothing length / spacing.
* ``max_dev_D``, ``mean_dev_D``: the largest and mean dist in nozzle diameters (the thesis
  reports the naive 90-degree bend at 2.86 D).
* ``width_mean_D``, ``width_max_D``: bead width in nozzle diameters, measured in bins one
  nozzle diameter long along the path: (largest - smallest signed offset) + h in each bin
  (the particles' centres plus one spacing).
* ``gap_D``, ``n_gaps``: continuity along the path.  A particle within one nozzle diameter
  of the path covers the stretch s_a +- h of it (s_a: the foot of its projection); the
  uncovered stretches of the whole path are the gaps (total length in D, and their count).
  The thesis' optimum of the small 180-degree bend had such a gap: eq. 3.47 does not see it.
* ``pieces``: connected pieces of the deposit, particles linked within 2 h.
* ``objective``: what the optimiser minimises,
  ``thesis + gap_weight * sum_g (l_g / h)^3`` over the gaps l_g (gap_weight = 0: eq. 3.47).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from sphfem.diw.toolpath import DesiredPath

__all__ = ["deposit_fitness", "uncovered_stretches"]


def uncovered_stretches(s_len: np.ndarray, radius: float, total: float) -> np.ndarray:
    """Lengths of the parts of [0, total] not covered by the intervals s_len +- radius."""
    if len(s_len) == 0:
        return np.array([total])
    s = np.sort(s_len)
    lo = np.concatenate([[0.0], s + radius])         # start of each candidate gap
    hi = np.concatenate([s - radius, [total]])       # its end
    gaps = hi - lo
    return gaps[gaps > 0]


def deposit_fitness(positions, h: float, nozzle_diameter: float, path: DesiredPath,
                    gap_weight: float = 0.0) -> dict:
    """Fitness and deposit metrics (module docstring) of particles ``positions`` (n, 2 or 3)
    [m] deposited for the desired ``path``."""
    xy = np.asarray(positions, dtype=float)
    if xy.ndim != 2 or xy.shape[1] < 2:
        raise ValueError(f"positions must be (n, 2) or (n, 3), got shape {xy.shape}")
    xy = xy[:, :2]
    if len(xy) == 0:
        raise ValueError("empty deposit: no particle reached the substrate")
    if not np.all(np.isfinite(xy)):
        raise ValueError("deposit positions contain NaN or inf")
    if not (h > 0 and nozzle_diameter > 0):
        raise ValueError(f"h and nozzle_diameter must be positive, got {h}, {nozzle_diameter}")
    D = float(nozzle_diameter)
    dist, s, offset = path.project(xy)
    thesis = float(np.sum((dist / h) ** 3))

    # width in bins one nozzle diameter long along the path
    arc = s * path.length
    nbins = max(1, int(np.ceil(path.length / D)))
    b = np.minimum((arc / path.length * nbins).astype(int), nbins - 1)
    lo = np.full(nbins, np.inf)
    hi = np.full(nbins, -np.inf)
    np.minimum.at(lo, b, offset)
    np.maximum.at(hi, b, offset)
    filled = np.isfinite(lo)
    width = hi[filled] - lo[filled] + h

    # continuity: stretches of the path no particle near it covers
    near = dist <= D
    gaps = uncovered_stretches(arc[near], h, path.length)

    # connected pieces (particles linked within 2 h)
    pairs = cKDTree(xy).query_pairs(2.0 * h, output_type="ndarray")
    n = len(xy)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    pieces = int(connected_components(graph, directed=False)[0])

    gap_term = float(np.sum((gaps / h) ** 3))
    return {
        "objective": thesis + gap_weight * gap_term,
        "thesis": thesis,
        "max_dev_D": float(dist.max() / D),
        "mean_dev_D": float(dist.mean() / D),
        "width_mean_D": float(width.mean() / D),
        "width_max_D": float(width.max() / D),
        "gap_D": float(gaps.sum() / D),
        "n_gaps": int(len(gaps)),
        "pieces": pieces,
        "n_particles": int(n),
        "h": float(h),
        "nozzle_diameter": D,
    }
