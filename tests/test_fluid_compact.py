"""The force pass on the compacted in-range rows gives the same results as on the full
filtered Verlet list (PROFILE.md recommendation 1)."""

import numpy as np
import pytest

from sphfem.fluid.setup import box_walls, hydrostatic_density, lattice, make_particles
from sphfem.fluid.wcsph import FluidParams, FluidSolver


def _dambreak(dim, delta, alpha, g=9.81):
    a = 0.1
    dx = a / (8 if dim == 3 else 20)
    c0 = 10 * np.sqrt(2 * g * a)
    lo_f = [0.0] * dim
    hi_f = [a] * (dim - 1) + [2 * a]
    xf = lattice(lo_f, hi_f, dx)
    xw = box_walls([0.0] * dim, [2 * a] + [a] * (dim - 2) + [2.2 * a], dx, 3)
    rhof = hydrostatic_density(2 * a - xf[:, -1], 1000.0, c0, g)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    grav = (0.0,) * (dim - 1) + (-g,)
    par = FluidParams(c0=c0, gravity=grav, delta=delta, alpha=alpha, threads=1)
    m = 4 * dx
    hi = [2 * a + m] + [a + m] * (dim - 2) + [2.2 * a + m]
    return FluidSolver(ps, 3 * dx, [-m] * dim, hi, params=par)


def _rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize("dim,delta,alpha", [(2, 0.1, 0.0), (2, 0.0, 0.02), (3, 0.1, 0.25)])
def test_compacted_rows_give_identical_forces(dim, delta, alpha):
    s = _dambreak(dim, delta, alpha)
    for _ in range(5):  # move the particles off the lattice (skin entries, mixed distances)
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()
    p = s.p
    s.compact_rows = True
    s.evaluate()
    got = (p.acc.copy(), p.drho.copy(), p.f_fluid.copy())
    s.compact_rows = False
    s.evaluate()
    ref = (p.acc.copy(), p.drho.copy(), p.f_fluid.copy())
    for a, b in zip(got, ref, strict=True):
        assert _rel(a, b) <= 1e-14
    # the compacted rows are the in-range subset of the (skin-enlarged) view
    cnt = s._scratch.cnt
    assert cnt.sum() < s.nbrs.n_pairs
    assert np.all(cnt <= np.diff(s.nbrs.offsets))


@pytest.mark.parametrize("modules", [("fluid", "heat"), ("fluid",)])
def test_driven_fluid_leaves_the_shared_list_alone(modules):
    """Driven by a Simulation, the fluid's compaction (and filter) write only work buffers:
    sim.nbrs is unchanged by a step, on the shared list of fluid + heat (the fluid filters
    a copy) and on the list built as the fluid's view (fluid alone: the list itself)."""
    from test_fluid_module import _scene

    from sphfem import neighbors
    from sphfem.fluid.passes import VIEW_KEEP
    from sphfem.simulation import Simulation

    sim = Simulation(_scene(modules=modules, skin=0.5))
    fl = sim.modules[0].solver
    assert sim.ctx.pair_filter == (VIEW_KEEP if modules == ("fluid",) else None)
    assert (fl.nbrs is sim.nbrs) == (modules == ("fluid",))
    sim.step(1.0e-5)
    nl = sim.nbrs
    off, idx, version = nl.offsets.copy(), nl.indices.copy(), sim.nbrs_version
    sim.step(1.0e-5)
    assert sim.nbrs_version == version  # no rebuild in between
    assert np.array_equal(sim.nbrs.offsets, off) and np.array_equal(sim.nbrs.indices, idx)
    work = neighbors._SCRATCH.work  # the compacted rows' buffer
    assert not np.shares_memory(work, sim.nbrs.indices)
    assert not np.shares_memory(work, fl.nbrs.indices)


@pytest.mark.parametrize("dim,delta,alpha", [(2, 0.1, 0.02), (3, 0.1, 0.25)])
def test_versioned_pair_loops_match_the_generic_loops(dim, delta, alpha):
    """The pair loops compiled for Wendland C2 without periodic axes (vectorised, dim
    constant) give the same sums as the generic loops, run here through a period far
    larger than the box (min_image is then exactly the identity)."""
    from sphfem.fluid import passes

    s = _dambreak(dim, delta, alpha)
    for _ in range(5):
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()
    p, sc, pa, nl = s.p, s._scratch, s.params, s.nbrs
    out = {}
    for name, period in (("fast", np.zeros(dim)), ("generic", np.full(dim, 1.0e6))):
        nb = np.zeros_like(nl.indices)
        cnt = np.zeros(p.n, dtype=np.int64)
        grad = np.zeros((p.n, dim))
        ok = np.zeros(p.n, dtype=np.bool_)
        passes.density_gradient(p.x, p.rho, sc.V, p.kind, nl.offsets, nl.indices, s.R,
                                s.sigma, s.kernel_code, period, pa.cond_max, grad, ok, nb, cnt)
        nb2 = np.zeros_like(nl.indices)
        cnt2 = np.zeros(p.n, dtype=np.int64)
        passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices, s.R, period, nb2, cnt2)
        assert np.array_equal(cnt, cnt2)
        for i in range(0, p.n, 7):
            o = nl.offsets[i]
            assert np.array_equal(nb[o:o + cnt[i]], nb2[o:o + cnt2[i]])
        passes.pack_rows(p.x, p.v, sc.vg, p.rho, sc.pr, sc.V, sc.meff, sc.isf, p.mu, grad,
                         sc.P)
        acc, drho, fw = p.acc.copy(), p.drho.copy(), p.f_fluid.copy()
        passes.fluid_forces(sc.P, p.kind, nl.offsets, cnt, nb, s.R, s.sigma, s.kernel_code,
                            period, s.gravity, pa.eps_visc * s.h * s.h,
                            pa.delta * s.h * pa.c0, pa.alpha * s.h * pa.c0, acc, drho, fw)
        out[name] = (cnt.copy(), ok.copy(), grad, acc, drho, fw)
    f, g = out["fast"], out["generic"]
    assert np.array_equal(f[0], g[0]) and np.array_equal(f[1], g[1])
    for a, b in zip(f[2:], g[2:], strict=True):
        assert _rel(a, b) <= 1e-14


def test_compaction_keeps_order_and_in_range_pairs():
    """compact_rows: each row's in-range neighbours (0 < r < R; walls: fluid ones), in
    list order, at the row's own offset."""
    from sphfem.fluid import passes
    from sphfem.particles import FLUID, WALL

    s = _dambreak(2, 0.1, 0.0)
    for _ in range(3):
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()
    p, nl = s.p, s.nbrs
    nb = np.full_like(nl.indices, -7)
    cnt = np.zeros(p.n, dtype=np.int64)
    passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices, s.R, s.period, nb, cnt)
    for i in range(p.n):
        o, e = nl.offsets[i], nl.offsets[i + 1]
        row = nl.indices[o:e]
        d2 = ((p.x[row] - p.x[i]) ** 2).sum(axis=1)
        keep = (d2 < s.R * s.R) & (d2 > 0.0)
        if p.kind[i] == WALL:
            keep &= p.kind[row] == FLUID
        elif p.kind[i] != FLUID:
            keep[:] = False
        assert cnt[i] == keep.sum()
        assert np.array_equal(nb[o:o + cnt[i]], row[keep])
    # the position form (uint16 positions in the list row) lists the same neighbours, and
    # the density-gradient pass emits the same rows as compact_rows in both forms
    pos = np.zeros(nl.indices.shape[0], dtype=np.uint16)
    cnt2 = np.zeros(p.n, dtype=np.int64)
    passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices, s.R, s.period,
                        (pos, nl.indices), cnt2)
    assert np.array_equal(cnt2, cnt)
    sc, pa = s._scratch, s.params
    for rows in (np.zeros_like(nl.indices), (np.zeros_like(pos), nl.indices)):
        cnt3 = np.zeros(p.n, dtype=np.int64)
        passes.density_gradient(p.x, p.rho, sc.V, p.kind, nl.offsets, nl.indices, s.R,
                                s.sigma, s.kernel_code, s.period, pa.cond_max, sc.grad, sc.ok,
                                rows, cnt3)
        assert np.array_equal(cnt3, cnt)
        for i in range(p.n):
            o, c = nl.offsets[i], cnt[i]
            want = nb[o:o + c]
            assert np.array_equal(nl.indices[o + pos[o:o + c].astype(np.int64)], want)
            got = rows[o:o + c] if isinstance(rows, np.ndarray) else (
                nl.indices[o + rows[0][o:o + c].astype(np.int64)])
            assert np.array_equal(got, want)
