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
* ``objective``: what the optimiser minimises: ``thesis`` (eq. 3.47), ``edge`` or
  ``centre`` (below), plus ``gap_weight * sum_g (l_g / h)^3`` over the gaps l_g
  (gap_weight = 0: the objective alone).

The thesis' distance counts the bead's own half-width: a bead 2 D wide centred on the path
already scores max dev ~1 D.  What a practitioner reads off a print is where the bead's
centre and edges lie against where they should, whatever its width.  In stations one D
long along the path (particles binned by the foot s of their projection), with lo, hi the
smallest and largest signed offset of the station's particles:

* ``width_nominal_D``: the bead's own width w = median over the stations of (hi - lo)
  (particle centres; robust to the corner and end stations).
* ``centre_dev_max_D``, ``centre_dev_mean_D``: the station's centreline |lo + hi| / 2.
* ``edge_dev_max_D``: the Hausdorff distance between the deposit and the desired bead (the
  path widened to w):  max over particles of the excess dist - w/2 beyond the desired edge
  (corner overshoot, end pile-up, blobs: ``edge_excess_max_D``) and over points q of the
  desired bead's edges and centreline (each piece's offset curves +-w/2 and 0, spaced
  h/2) of the shortfall d(q, nearest particle) - h (cut corners, gaps:
  ``edge_short_max_D``), the coverage h as in ``gap_D``; ``edge_dev_s``: the s where
  it is largest.  The desired bead has round ends
  for the excess and square ends for the shortfall: neither counts a cap of w/2.
* ``edge_dev_mean_D``: mean over the stations of max(|hi - w/2|, |lo + w/2|), the farther
  edge's distance from its desired place.
* objective ``edge``: eq. 3.47's form applied to these distances,
  sum_a (excess_a / h)^3 + sum_q (shortfall_q / h)^3.
* objective ``centre``: a smooth stand-in for ``centre_dev_max_D``, the power mean of the
  stations' centreline deviations c_k = |lo_k + hi_k| / 2 over the N filled stations,
  M_p = (1/N sum_k (c_k / h)^p)^(1/p) (Hardy, Littlewood & Polya 1934, ch. II): for
  p >= 1 it lies between N^(-1/p) max_k c_k / h and max_k c_k / h and tends to the
  maximum as p -> inf; a bead offset by e everywhere scores e / h for every p.  Unlike a
  bare maximum it still ranks two toolpaths with the same worst station by the others
  (with p = 8 a station half as far off weighs 2^-8 = 0.4 % of the worst).  Empty
  stations (gaps) do not count: ``gap_weight`` adds them.

A bead of any width that follows the path scores ~0 on all of them (the particle lattice's
roughness: about one spacing at the edges); the thesis' figures are kept beside them.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from sphfem.diw.toolpath import DesiredPath

__all__ = ["OBJECTIVES", "deposit_fitness", "edge_samples", "uncovered_stretches"]

#: what the optimiser can minimise (module docstring)
OBJECTIVES = ("thesis", "edge", "centre")


def uncovered_stretches(s_len: np.ndarray, radius: float, total: float) -> np.ndarray:
    """Lengths of the parts of [0, total] not covered by the intervals s_len +- radius."""
    if len(s_len) == 0:
        return np.array([total])
    s = np.sort(s_len)
    lo = np.concatenate([[0.0], s + radius])         # start of each candidate gap
    hi = np.concatenate([s - radius, [total]])       # its end
    gaps = hi - lo
    return gaps[gaps > 0]


def edge_samples(path: DesiredPath, half: float, spacing: float) -> np.ndarray:
    """Points (m, 2) of the desired bead's edges (offsets +-``half`` along each piece's
    normal) and centreline, at most ``spacing`` apart along every piece."""
    out = []
    for piece in path.pieces:
        u = np.linspace(0.0, 1.0, max(2, int(np.ceil(piece.length / spacing)) + 1))
        p, t = piece.point(u), piece.tangent(u)
        n = np.stack([t[:, 1], -t[:, 0]], axis=1)
        out += [p + k * n for k in (-half, 0.0, half)]
    return np.concatenate(out)


def deposit_fitness(positions, h: float, nozzle_diameter: float, path: DesiredPath,
                    gap_weight: float = 0.0, objective: str = "thesis",
                    centre_p: float = 8.0) -> dict:
    """Fitness and deposit metrics (module docstring) of particles ``positions`` (n, 2 or 3)
    [m] deposited for the desired ``path``; ``objective``: one of :data:`OBJECTIVES`;
    ``centre_p``: the exponent p of the ``centre`` objective's power mean."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if not centre_p >= 1.0:
        raise ValueError(f"centre_p must be >= 1, got {centre_p}")
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

    # the bead's centreline and edges against the desired bead of its own width
    lo_f, hi_f = lo[filled], hi[filled]
    half = 0.5 * float(np.median(hi_f - lo_f))
    centre = np.abs(0.5 * (lo_f + hi_f))
    edge_station = np.maximum(np.abs(hi_f - half), np.abs(lo_f + half))
    excess = np.maximum(dist - half, 0.0)
    tree = cKDTree(xy)
    q = edge_samples(path, half, 0.5 * h)
    d_q, _ = tree.query(q)
    short = np.maximum(d_q - h, 0.0)
    if excess.max() >= short.max():  # where along the path the edge deviation is largest
        edge_s = float(s[np.argmax(excess)])
    else:
        edge_s = float(path.project(q[np.argmax(short)])[1][0])
    edge_term = float(np.sum((excess / h) ** 3) + np.sum((short / h) ** 3))
    c_h = centre / h
    c_top = c_h.max()  # scaled out of the power so a large p cannot overflow
    centre_term = float(c_top * np.mean((c_h / c_top) ** centre_p) ** (1.0 / centre_p)
                        if c_top > 0 else 0.0)

    # continuity: stretches of the path no particle near it covers
    near = dist <= D
    gaps = uncovered_stretches(arc[near], h, path.length)

    # connected pieces (particles linked within 2 h)
    pairs = tree.query_pairs(2.0 * h, output_type="ndarray")
    n = len(xy)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    pieces = int(connected_components(graph, directed=False)[0])

    gap_term = float(np.sum((gaps / h) ** 3))
    return {
        "objective": {"thesis": thesis, "edge": edge_term, "centre": centre_term}[objective]
        + gap_weight * gap_term,
        "thesis": thesis,
        "max_dev_D": float(dist.max() / D),
        "mean_dev_D": float(dist.mean() / D),
        "width_mean_D": float(width.mean() / D),
        "width_max_D": float(width.max() / D),
        "width_nominal_D": float(2 * half / D),
        "centre_dev_max_D": float(centre.max() / D),
        "centre_dev_mean_D": float(centre.mean() / D),
        "edge_dev_max_D": float(max(excess.max(), short.max()) / D),
        "edge_dev_mean_D": float(edge_station.mean() / D),
        "edge_excess_max_D": float(excess.max() / D),
        "edge_short_max_D": float(short.max() / D),
        "edge_dev_s": edge_s,
        "edge": edge_term,
        "centre": centre_term,
        "gap_D": float(gaps.sum() / D),
        "n_gaps": int(len(gaps)),
        "pieces": pieces,
        "n_particles": int(n),
        "h": float(h),
        "nozzle_diameter": D,
    }
