"""Surface tension (IIF calibration, momentum), free-surface detection and shifting."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.setup import lattice, make_particles
from sphfem.fluid.surface_tension_iif_tartakovsky2005 import iif_accel, iif_constant, iif_sigma
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID


def _lattice_split_energy(dim, k, s=1.0, dx=1.0):
    """Energy per area to separate a cell-centred lattice into two half-lattices along a
    lattice plane, divided by 2 (two surfaces): the discrete surface tension of the IIF
    pair potential phi(d) = int_d^R s cos(3 pi t/(2R)) dt, R = k dx."""
    R = k * dx
    c = 1.5 * math.pi / R
    m = int(math.ceil(R / dx)) + 1
    ax = np.arange(-m, m + 1) * dx
    g = np.stack(np.meshgrid(*([ax] * (dim - 1) + [np.arange(1, m + 1) * dx]),
                             indexing="ij"), -1).reshape(-1, dim)
    E = 0.0
    for a in range(1, m + 1):  # particle rows below the plane at depth (a - 1/2) dx
        rel = g.copy()
        rel[:, -1] = (g[:, -1] - 0.5 * dx) + (a - 0.5) * dx
        d = np.sqrt((rel**2).sum(1))
        d = d[(d < R) & (d > 0)]
        E += -np.sum((s / c) * (-1.0 - np.sin(c * d)))
    return E / dx ** (dim - 1) / 2


@pytest.mark.parametrize("dim", [2, 3])
def test_iif_calibration_matches_lattice_sum(dim):
    """The half-space integral behind iif_constant agrees with the exact energy of cutting
    a lattice, the more closely the more neighbours (error ~ (dx/R)^2)."""
    errs = [abs(_lattice_split_energy(dim, k) / iif_sigma(1.0, 1.0, 1.0, float(k), dim) - 1)
            for k in (3, 4, 8)]
    assert errs[0] < 0.07 and errs[2] < 0.01
    assert errs[0] > errs[1] > errs[2]
    # round trip sigma -> s -> sigma, and the scaling s ~ sigma dx^(2 dim) / R^(dim + 2)
    s = iif_constant(0.072, 1000.0, 1000.0 * 1e-4**dim, 3e-4, dim)
    assert iif_sigma(s, 1000.0, 1000.0 * 1e-4**dim, 3e-4, dim) == pytest.approx(0.072)


def test_iif_conserves_linear_and_angular_momentum():
    rng = np.random.default_rng(3)
    n, dim = 200, 3
    x = rng.random((n, dim))
    m = rng.uniform(0.5, 2.0, n)
    kind = np.full(n, FLUID, np.int8)
    nl = build_neighbor_list(x, 0.3, [0.0] * 3, [1.0] * 3)
    acc = np.zeros((n, dim))
    iif_accel(x, m, kind, nl.offsets, nl.indices, 0.3, 2.0, m.mean(), np.zeros(3), acc)
    F = m[:, None] * acc
    scale = np.abs(F).sum()
    assert scale > 0
    assert np.abs(F.sum(axis=0)).max() < 1e-12 * scale
    assert np.abs(np.cross(x, F).sum(axis=0)).max() < 1e-12 * scale


def _block(n=16, dim=2, jitter=0.0, seed=0):
    dx = 1.0 / n
    x = lattice([0.0] * dim, [1.0] * dim, dx)
    if jitter:
        x = x + jitter * dx * np.random.default_rng(seed).uniform(-1, 1, x.shape)
    return make_particles(x, None, dx, 1000.0), dx


@pytest.mark.parametrize("dim", [2, 3])
def test_free_surface_of_a_block_is_its_outer_layer(dim):
    n = 12 if dim == 2 else 8
    ps, dx = _block(n, dim)
    par = FluidParams(c0=10.0, gravity=(0.0,) * dim, detect_free_surface=True)
    s = FluidSolver(ps, 3 * dx, [-1.0] * dim, [2.0] * dim, params=par)
    x = ps.x
    outer = np.any((x < dx) | (x > 1 - dx), axis=1)
    np.testing.assert_array_equal(ps.free_surface.astype(bool), outer)
    # outward normals of face particles farther than R from the edges are the face normals
    face = (x[:, 0] < dx) & np.all((x[:, 1:] > 3 * dx) & (x[:, 1:] < 1 - 3 * dx), axis=1)
    assert face.sum() > 0
    nrm = s._scratch.nrm[face]
    np.testing.assert_allclose(nrm[:, 0], -1.0, atol=1e-9)


def test_shifting_is_tangential_on_the_free_surface():
    """shifting = "all": free-surface and near-surface particles move only along their
    tangent plane; interior particles move down the concentration gradient."""
    ps, dx = _block(16, 2, jitter=0.1, seed=4)
    ps.add_field("v", 2)
    ps.v[:] = np.random.default_rng(5).normal(0.0, 0.1, ps.v.shape)
    par = FluidParams(c0=10.0, gravity=(0.0, 0.0), shifting="all", shifting_coef=50.0)
    s = FluidSolver(ps, 3 * dx, [-1.0, -1.0], [2.0, 2.0], params=par)
    x_before = ps.x.copy()
    ids = ps.id.copy()
    s.step(1e-4)
    assert np.array_equal(ps.id, ids)  # no re-sort in one step
    sc = s._scratch
    moved = ps.x - x_before - 1e-4 * 0.5 * (s._scratch.v_n + ps.v)  # drift part removed
    near = sc.near
    assert near.sum() > 0 and (~near).sum() > 0
    normal_part = np.abs((moved[near] * sc.nrm[near]).sum(axis=1))
    assert sc.shift[near].max() > 0
    assert normal_part.max() < 1e-9 * dx
    # interior particles were shifted by a measurable amount
    assert sc.shift[~near].max() > 1e-6 * dx


@pytest.mark.parametrize("dim", [2, 3])
def test_remove_local_mean_keeps_only_the_relative_shift(dim):
    """:func:`remove_local_mean`: a shift shared by every particle is taken out whole (also
    across a periodic side); a shift c + d gives exactly what d alone gives (the mean of a
    constant is the constant); a particle with no shift of its own moves against the
    common shift of its neighbours, and the shifted ones keep less than the common shift."""
    from sphfem.fluid.surface import remove_local_mean
    from sphfem.kernels import kernel_code

    n1 = 12 if dim == 2 else 8
    ps, dx = _block(n1, dim, jitter=0.1, seed=2)
    x = ps.x
    n = x.shape[0]
    R = 3 * dx
    period = np.zeros(dim)
    period[0] = 1.0  # the block tiles x with period 1
    lo, hi = np.zeros(dim) - R, np.ones(dim) + R
    lo[0], hi[0] = 0.0, 1.0
    nl = build_neighbor_list(x, R, lo, hi, period)
    kc = kernel_code("wendland_c2")
    liquid = np.ones(n, np.bool_)
    Rp = np.full(n, R)
    rng = np.random.default_rng(1)
    c = rng.normal(size=dim) * 0.01 * dx
    d = rng.normal(size=(n, dim)) * 0.01 * dx

    def run(dr):
        out = np.empty_like(dr)
        remove_local_mean(dr, x, liquid, nl.offsets, nl.indices, Rp, kc, period, n, out)
        return out

    assert np.abs(run(np.tile(c, (n, 1)))).max() < 1e-12 * dx
    np.testing.assert_allclose(run(c + d), run(d), rtol=0, atol=1e-12 * dx)
    assert np.abs(run(d)).max() > 1e-4 * dx
    # a particle the shift left alone moves against its neighbourhood's drift
    dz = np.tile(c, (n, 1))
    dz[::3] = 0.0
    out = run(dz)
    assert np.all((out[::3] @ c) < 0.0)
    assert np.all(np.abs(out[1::3] @ c) < (c @ c))


def test_shifting_drift_removed_moves_no_mass_along_a_thinning_film():
    """A planar wedge film, 6 rows thick at x = 0 thinning to 2 rows at its end, carried at
    1 m/s along itself (the lamella of an impact): the plain surface-projected shift moves
    its rows towards the thin end and its centroid with them; with ``shifting_drift =
    "removed"`` the centroid moves by less than a tenth of that, while the rows are
    still shifted relative to each other (the largest shift at least half the plain one's)."""
    dx = 1.0e-3
    rows = []
    for i in range(40):
        k = 6 - (4 * i) // 40  # rows of this column
        rows += [((i + 0.5) * dx, (j + 0.5) * dx) for j in range(k)]
    x0 = np.array(rows)
    x0 += np.random.default_rng(7).uniform(-0.1, 0.1, x0.shape) * dx
    res = {}
    for drift in ("kept", "removed"):
        p = make_particles(x0, None, dx, 1000.0)
        p.add_field("v", 2)
        p.v[:, 0] = 1.0
        par = FluidParams(c0=10.0, gravity=(0.0, 0.0), shifting="all", shifting_drift=drift,
                          delta=0.0, alpha=0.0, mu=0.0)
        s = FluidSolver(p, 3 * dx, [-1.0, -1.0], [1.0, 1.0], params=par)
        s.step(2e-4)
        order = np.argsort(p.id)
        moved = p.x[order] - x0 - 2e-4 * p.v[order]  # the shift part (v is uniform)
        res[drift] = (moved[:, 0].mean(), np.abs(moved).max())
    kept, removed = res["kept"], res["removed"]
    # measured: mean 2.5e-4 dx kept, 1.3e-5 dx removed (5 %); largest shift 2.2e-2 dx kept
    assert kept[0] > 1e-4 * dx  # the plain shift drifts towards the thin end
    assert abs(removed[0]) < 0.1 * kept[0]
    assert removed[1] > 0.5 * kept[1]
