"""coupling.transfer._in_cells: the covered targets, and work that follows the true overlaps."""

import tracemalloc

import numpy as np

from coupling.transfer import _in_cells, particle_cells


def _brute(Xt, Xs, h):
    half = 0.5 * h * (1 + 1e-6)
    return np.array([np.any(np.all(np.abs(x - Xs) <= half, axis=1)) for x in Xt])


def test_in_cells_matches_brute_force():
    rng = np.random.default_rng(3)
    for dim in (1, 2, 3):
        Xs = rng.random((300, dim))
        h = particle_cells(Xs, rng.uniform(0.5, 2.0, 300) / 300)
        Xt = rng.random((400, dim)) * 1.4 - 0.2
        assert (_in_cells(Xt, Xs, h) == _brute(Xt, Xs, h)).all()


def test_one_large_cell_does_not_widen_every_search():
    """A lattice of 3600 particles plus one isolated particle whose cell spans the whole
    domain: the search of each particle uses its own cell, so memory stays ~ the number of
    true overlaps (the old search used the largest cell for all: 3600 x 3600 candidate
    pairs, ~0.5 GB)."""
    n = 60
    g = (np.arange(n) + 0.5) / n
    Xs = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    h = np.full_like(Xs, 1.0 / n)
    Xs = np.vstack([Xs, [[0.5, 0.5]]])
    h = np.vstack([h, [[4.0, 4.0]]])
    Xt = Xs[:-1] + 0.3 / n
    tracemalloc.start()
    got = _in_cells(Xt, Xs, h)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert got.all()
    assert peak < 20e6, f"peak {peak / 1e6:.0f} MB"
