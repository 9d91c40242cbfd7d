"""Cell-list neighbour search against scipy's cKDTree, in 1D, 2D and 3D, periodic or not."""

import json

import numba
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sphfem.neighbors import (
    NeighborList,
    build_neighbor_list,
    cell_sort_permutation,
    min_image,
)


def pair_set(nl: NeighborList) -> set[tuple[int, int]]:
    i = np.repeat(np.arange(nl.n), np.diff(nl.offsets))
    j = nl.indices.astype(np.int64)
    return set(zip(i[i < j].tolist(), j[i < j].tolist(), strict=True))


def reference_pairs(x, radius, period=None) -> set[tuple[int, int]]:
    """cKDTree pairs (r <= radius); non-periodic axes get a box far larger than the data."""
    if period is None or not np.any(period > 0):
        return cKDTree(x).query_pairs(radius)
    box = np.where(period > 0, period, 1e6)
    lo = x.min(axis=0)
    y = np.where(period > 0, np.mod(x, np.where(period > 0, period, 1.0)), x - lo)
    y = np.where(period > 0, np.where(y >= box, 0.0, y), y)
    return cKDTree(y, boxsize=box).query_pairs(radius)


def check_structure(nl: NeighborList, n: int):
    assert nl.offsets.dtype == np.int64 and nl.indices.dtype == np.int32
    assert nl.offsets.shape == (n + 1,) and nl.offsets[0] == 0
    assert nl.offsets[-1] == nl.n_pairs
    counts = np.diff(nl.offsets)
    assert np.all(counts >= 0)
    owner = np.repeat(np.arange(n), counts)
    assert not np.any(owner == nl.indices), "self must be excluded"
    for i in range(n):
        seg = nl.neighbors(i)
        assert np.all(np.diff(seg) > 0), f"segment {i} not strictly ascending"
    # symmetry: j in N(i) iff i in N(j)
    fwd = set(zip(owner.tolist(), nl.indices.tolist(), strict=True))
    assert fwd == {(j, i) for i, j in fwd}


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("cells_per_radius", [1, 2])
def test_random_open(dim, cells_per_radius):
    rng = np.random.default_rng(dim)
    n = (300, 800, 1500)[dim - 1]
    radius = (0.01, 0.06, 0.12)[dim - 1]
    x = rng.random((n, dim))
    nl = build_neighbor_list(
        x, radius, np.zeros(dim), np.ones(dim), np.zeros(dim), cells_per_radius=cells_per_radius
    )
    check_structure(nl, n)
    assert pair_set(nl) == reference_pairs(x, radius)
    assert nl.radius == radius


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("axes", ["all", "first", "last"])
def test_random_periodic(dim, axes):
    rng = np.random.default_rng(10 + dim)
    n = (300, 800, 1500)[dim - 1]
    radius = (0.02, 0.08, 0.15)[dim - 1]
    L = np.array([1.0, 1.3, 0.9][:dim])
    lo = np.array([-0.2, 0.0, 0.5][:dim])
    period = L.copy()
    if axes == "first":
        period[1:] = 0.0
    elif axes == "last":
        period[:-1] = 0.0
    x = lo + rng.random((n, dim)) * L
    nl = build_neighbor_list(x, radius, lo, lo + L, period)
    check_structure(nl, n)
    assert pair_set(nl) == reference_pairs(x - lo, radius, period)
    assert np.array_equal(nl.period, period)


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("ratio", [2.05, 2.5, 3.2, 4.7])
@pytest.mark.parametrize("cells_per_radius", [1, 2])
def test_small_periodic_box(dim, ratio, cells_per_radius):
    """Boxes only 2-4 cells across: every (cell, image) pair must be visited exactly once."""
    rng = np.random.default_rng(int(ratio * 10) + dim)
    radius = 0.3
    L = ratio * radius
    n = (40, 120, 300)[dim - 1]
    x = rng.random((n, dim)) * L
    period = np.full(dim, L)
    nl = build_neighbor_list(
        x, radius, np.zeros(dim), period, period, cells_per_radius=cells_per_radius
    )
    check_structure(nl, n)
    assert pair_set(nl) == reference_pairs(x, radius, period)


def test_positions_outside_periodic_box_are_wrapped():
    rng = np.random.default_rng(3)
    x = rng.random((400, 2))
    shifted = x + rng.integers(-3, 4, size=x.shape)  # whole periods away
    period = np.ones(2)
    a = build_neighbor_list(x, 0.1, np.zeros(2), np.ones(2), period)
    b = build_neighbor_list(shifted, 0.1, np.zeros(2), np.ones(2), period)
    assert pair_set(a) == pair_set(b)


def lattice(k, dx, dim):
    g = np.arange(k) * dx
    return np.stack([a.ravel() for a in np.meshgrid(*([g] * dim), indexing="ij")], axis=1)


@pytest.mark.parametrize("dim, interior_count", [(1, 6), (2, 28), (3, 122)])
@pytest.mark.parametrize("periodic", [False, True])
def test_lattice_pairs_exactly_at_radius_are_included(dim, interior_count, periodic):
    """dx = 0.25, R = 0.75 = 3 dx: exactly representable, the pairs at r = R must count."""
    dx, radius = 0.25, 0.75
    k = (40, 16, 9)[dim - 1]
    x = lattice(k, dx, dim)
    L = k * dx
    period = np.full(dim, L if periodic else 0.0)
    nl = build_neighbor_list(x, radius, np.zeros(dim), np.full(dim, L), period)
    check_structure(nl, x.shape[0])
    assert pair_set(nl) == reference_pairs(x, radius, period if periodic else None)
    counts = nl.counts()
    if periodic:
        assert np.all(counts == interior_count)
    else:
        interior = np.all((x >= radius) & (x <= L - dx - radius), axis=1)
        assert interior.any()
        assert np.all(counts[interior] == interior_count)
    # a pair at distance exactly R along the first axis
    i = int(np.flatnonzero(np.all(x == radius, axis=1))[0])
    target = x[i].copy()
    target[0] += radius
    j = int(np.flatnonzero(np.all(x == target, axis=1))[0])
    assert j in nl.neighbors(i) and i in nl.neighbors(j)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_particles_outside_open_domain(dim):
    rng = np.random.default_rng(7)
    x = rng.random((600, dim)) * 1.2 - 0.1  # up to 0.1 outside [0, 1] on each side
    x[0] = -50.0  # a far outlier goes to the edge cell; no crash
    radius = (0.01, 0.07, 0.15)[dim - 1]
    nl = build_neighbor_list(x, radius, np.zeros(dim), np.ones(dim), np.zeros(dim))
    check_structure(nl, x.shape[0])
    assert pair_set(nl) == reference_pairs(x, radius)


def test_empty_and_single():
    nl = build_neighbor_list(np.zeros((0, 3)), 0.1, np.zeros(3), np.ones(3), np.zeros(3))
    assert nl.offsets.tolist() == [0] and nl.n_pairs == 0
    nl = build_neighbor_list(np.full((1, 2), 0.5), 0.1, np.zeros(2), np.ones(2), np.ones(2))
    assert nl.offsets.tolist() == [0, 0] and nl.n_pairs == 0
    assert cell_sort_permutation(np.zeros((0, 2)), 0.1, np.zeros(2), np.ones(2)).shape == (0,)


def test_coincident_particles():
    x = np.vstack([np.full((5, 2), 0.5), [[0.9, 0.9]]])
    nl = build_neighbor_list(x, 0.1, np.zeros(2), np.ones(2), np.zeros(2))
    for i in range(5):
        assert nl.neighbors(i).tolist() == [j for j in range(5) if j != i]
    assert nl.neighbors(5).size == 0


def test_errors():
    x = np.random.default_rng(0).random((10, 2))
    lo, hi = np.zeros(2), np.ones(2)
    with pytest.raises(ValueError, match="positive"):
        build_neighbor_list(x, 0.0, lo, hi, np.zeros(2))
    with pytest.raises(ValueError, match="positive"):
        build_neighbor_list(x, np.nan, lo, hi, np.zeros(2))
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        build_neighbor_list(bad, 0.1, lo, hi, np.zeros(2))
    bad[3, 1] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        build_neighbor_list(bad, 0.1, lo, hi, np.zeros(2))
    with pytest.raises(ValueError, match="half the period"):
        build_neighbor_list(x, 0.5, lo, hi, np.array([1.0, 0.0]))
    with pytest.raises(ValueError):
        build_neighbor_list(x, 0.1, lo, hi, np.zeros(3))


@pytest.mark.parametrize("sub_cells", [1, 3])
def test_unsorted_input_and_cell_sort_permutation(sub_cells):
    rng = np.random.default_rng(5)
    x = rng.random((3000, 3))
    lo, hi, period = np.zeros(3), np.ones(3), np.array([1.0, 0.0, 1.0])
    radius = 0.09
    a = build_neighbor_list(x, radius, lo, hi, period)
    perm = cell_sort_permutation(x, radius, lo, hi, period, sub_cells=sub_cells)
    assert np.array_equal(np.sort(perm), np.arange(x.shape[0]))
    xs = x[perm]
    b = build_neighbor_list(xs, radius, lo, hi, period)
    check_structure(b, x.shape[0])
    # relabel b's pairs to original indices
    relabelled = {tuple(sorted((int(perm[i]), int(perm[j])))) for i, j in pair_set(b)}
    assert relabelled == pair_set(a)
    # a sorted set is already in cell order
    again = cell_sort_permutation(xs, radius, lo, hi, period, sub_cells=sub_cells)
    assert np.array_equal(again, np.arange(x.shape[0]))


def test_deterministic_across_threads():
    rng = np.random.default_rng(9)
    x = rng.random((4000, 3))
    args = (x, 0.08, np.zeros(3), np.ones(3), np.array([1.0, 1.0, 0.0]))
    saved = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = build_neighbor_list(*args)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        b = build_neighbor_list(*args)
        c = build_neighbor_list(*args)
    finally:
        numba.set_num_threads(saved)
    for other in (b, c):
        assert np.array_equal(a.offsets, other.offsets)
        assert np.array_equal(a.indices, other.indices)


def test_min_image():
    assert min_image(0.3, 0.0) == 0.3
    assert min_image(0.7, 1.0) == pytest.approx(-0.3)
    assert min_image(-0.7, 1.0) == pytest.approx(0.3)
    assert min_image(2.2, 1.0) == pytest.approx(0.2)
    assert -0.5 <= min_image(0.5, 1.0) <= 0.5


def test_bench_quick_is_json_serialisable():
    from sphfem.bench import run_bench

    res = run_bench("neighbors", quick=True, threads=(1,), verbose=False)
    text = json.dumps(res)
    assert "cpu" in res["machine"] and res["machine"]["numba"] == numba.__version__
    (case,) = res["cases"]
    assert case["pairs"] > 0 and case["build_s"] > 0 and case["pairs_per_s"] > 0
    assert case["density_max_rel_err_interior"] < 0.01
    assert json.loads(text)["benchmark"] == "neighbors"


def test_clustered_with_empty_regions():
    """A dense blob plus sparse particles: chunks balanced by particle count stay exact."""
    rng = np.random.default_rng(11)
    blob = 0.8 + 0.05 * rng.random((1500, 3))
    sparse = rng.random((200, 3))
    x = np.vstack([blob, sparse])
    nl = build_neighbor_list(x, 0.02, np.zeros(3), np.ones(3), np.zeros(3))
    check_structure(nl, x.shape[0])
    assert pair_set(nl) == reference_pairs(x, 0.02)


@pytest.mark.parametrize("dim,periodic", [(2, False), (3, False), (3, True)])
def test_kind_filter_matches_filter_rows(dim, periodic):
    from sphfem.fluid.passes import VIEW_KEEP, filter_rows

    rng = np.random.default_rng(7)
    n = 1500 if dim == 3 else 800
    L = 10.0
    x = rng.uniform(0.0, L, (n, dim))
    kind = rng.integers(0, 4, n).astype(np.int8)
    period = np.full(dim, L if periodic else 0.0)
    radius = 1.7
    full = build_neighbor_list(x, radius, np.zeros(dim), np.full(dim, L), period)
    off, idx = filter_rows(full.offsets, full.indices, kind)
    nl = build_neighbor_list(x, radius, np.zeros(dim), np.full(dim, L), period, kind=kind,
                             keep=VIEW_KEEP)
    assert np.array_equal(nl.offsets, off)
    assert np.array_equal(nl.indices, idx)
    # a keep-everything filter reproduces the unfiltered list
    allk = build_neighbor_list(x, radius, np.zeros(dim), np.full(dim, L), period,
                               kind=kind, keep=[15] * 4)
    assert np.array_equal(allk.offsets, full.offsets)
    assert np.array_equal(allk.indices, full.indices)


def reference_csr(x, radius, period, kind=None, keep=None):
    """The exact list the search must return: cKDTree pairs, both directions, the pair
    filter applied, every row ascending."""
    pairs = np.array(sorted(reference_pairs(x, radius, period)), dtype=np.int64).reshape(-1, 2)
    i = np.concatenate([pairs[:, 0], pairs[:, 1]])
    j = np.concatenate([pairs[:, 1], pairs[:, 0]])
    if kind is not None:
        masks = np.zeros(8, np.int64)
        masks[: len(keep)] = keep
        sel = (masks[kind[i]] >> kind[j]) & 1 == 1
        i, j = i[sel], j[sel]
    o = np.lexsort((j, i))
    offsets = np.zeros(x.shape[0] + 1, np.int64)
    np.cumsum(np.bincount(i, minlength=x.shape[0]), out=offsets[1:])
    return offsets, j[o].astype(np.int32)


@pytest.mark.parametrize("dim,axes", [(2, ()), (2, (0,)), (3, ()), (3, (1,)), (3, (0, 2)),
                                      (3, (0, 1, 2))])
@pytest.mark.parametrize("order", ["sorted", "perturbed", "shuffled"])
@pytest.mark.parametrize("filt", ["none", "view", "random"])
def test_csr_identical_to_reference(dim, axes, order, filt):
    """Same pairs in the same order whatever the particle order (cell-sorted, a few
    particles out of place -- the candidates are sorted per cell -- or random) and filter."""
    from sphfem.fluid.passes import VIEW_KEEP

    rng = np.random.default_rng(100 * dim + 10 * len(axes) + len(order) + len(filt))
    n = 2500 if dim == 3 else 1200
    L = 10.0
    radius = 1.3
    period = np.array([L if k in axes else 0.0 for k in range(dim)])
    x = rng.uniform(0.0, L, (n, dim))
    lo, hi = np.zeros(dim), np.full(dim, L)
    if order != "shuffled":
        x = x[cell_sort_permutation(x, radius, lo, hi, period)]
    if order == "perturbed":  # swap some particles with a nearby one in the sorted order
        for a in rng.choice(n - 40, 60, replace=False):
            b = a + rng.integers(1, 40)
            x[[a, b]] = x[[b, a]]
    kind = keep = None
    if filt == "view":
        kind, keep = rng.integers(0, 4, n).astype(np.int8), VIEW_KEEP
    elif filt == "random":
        kind = rng.integers(0, 5, n).astype(np.int8)
        keep = [int(v) for v in rng.integers(0, 32, 5)]
        keep[0] = 0  # rows of kind 0 are empty
    nl = build_neighbor_list(x, radius, lo, hi, period, kind=kind, keep=keep)
    off, idx = reference_csr(x, radius, period, kind, keep)
    assert np.array_equal(nl.offsets, off)
    assert np.array_equal(nl.indices, idx)


def test_kind_filter_deterministic_across_threads():
    from sphfem.fluid.passes import VIEW_KEEP

    rng = np.random.default_rng(11)
    x = rng.random((5000, 3))
    lo, hi, period = np.zeros(3), np.ones(3), np.array([0.0, 1.0, 0.0])
    x = x[cell_sort_permutation(x, 0.07, lo, hi, period)]
    x[:2500] += rng.normal(0.0, 0.01, (2500, 3))  # drifted since the sort
    kind = (x[:, 2] < 0.3).astype(np.int8)  # fluid above a wall layer
    saved = numba.get_num_threads()
    try:
        out = []
        for t in (1, numba.config.NUMBA_NUM_THREADS):
            numba.set_num_threads(t)
            out.append(build_neighbor_list(x, 0.07, lo, hi, period, kind=kind, keep=VIEW_KEEP))
    finally:
        numba.set_num_threads(saved)
    assert np.array_equal(out[0].offsets, out[1].offsets)
    assert np.array_equal(out[0].indices, out[1].indices)
    off, idx = reference_csr(x, 0.07, period, kind, VIEW_KEEP)
    assert np.array_equal(out[0].offsets, off)
    assert np.array_equal(out[0].indices, idx)


def test_infinite_span_is_a_clear_error():
    """A particle thrown to ~1e308 (a blow-up) gives a ValueError naming the axis, not an
    OverflowError from the cell count."""
    import pytest

    from sphfem.neighbors import build_neighbor_list

    x = np.array([[0.0, 0.0], [1.0, 0.0], [-1.7e308, 1.0], [1.7e308, 1.0]])
    with pytest.raises(ValueError, match="axis 0 span an infinite range"):
        build_neighbor_list(x, 1.0, x.min(axis=0), x.max(axis=0))
