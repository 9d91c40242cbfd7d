"""Debris of the axisymmetric fluid (sphfem.fluid.axisymmetric_debris): free-flying clusters
of a few rings are found, clusters touching a wall are not, and the fluid makes them inert
(out of every pair sum, ballistic, mass kept) instead of letting a torus of two rings blow up
at the axis."""

from __future__ import annotations

import numpy as np
import pytest

from sphfem.fluid.axisymmetric import INERT, AxisymmetricFluid
from sphfem.fluid.axisymmetric_debris import free_debris
from sphfem.fluid.wcsph import FluidParams
from sphfem.particles import FLUID, WALL

DX = 1e-4 / 181  # the spacing of the D/dx 181 droplet impact


def _block(r0, z0, nr, nz):
    r = r0 + np.arange(nr) * DX
    z = z0 + np.arange(nz) * DX
    return np.column_stack([q.ravel() for q in np.meshgrid(r, z, indexing="ij")])


def test_free_debris_finds_small_free_clusters_only():
    body = _block(0.5 * DX, 0.5 * DX, 20, 10)  # 200 rings on the wall
    pair = np.array([[40.0, 30.0], [40.8, 30.5]]) * DX  # free, 2 rings
    sliding = np.array([[60.0, 0.5], [61.0, 0.5]]) * DX  # 2 rings on the wall
    blob = _block(80 * DX, 30 * DX, 5, 4)  # free, 20 rings
    x = np.vstack([body, pair, sliding, blob])
    rows = np.arange(len(x))
    walls = _block(0.5 * DX, -2.5 * DX, 100, 3)
    found = free_debris(x, rows, 2 * DX, 16, walls, 3 * DX)
    assert found.tolist() == [200, 201]
    # the blob is debris with a larger limit; the sliding pair never
    found = free_debris(x, rows, 2 * DX, 20, walls, 3 * DX)
    assert found.tolist() == [200, 201] + list(range(204, 224))
    # a wall plane instead of wall rings: the same
    found = free_debris(x, rows, 2 * DX, 16, None, 3 * DX, wall_z=0.0)
    assert found.tolist() == [200, 201]
    assert free_debris(x, rows, 2 * DX, 0, walls, 3 * DX).size == 0


def _pair_towards_axis(debris_rings):
    """Two rings at r ~ 130 dx flying towards the axis and up at (-6.43, 2.52) m/s with
    surface tension (the debris of the D/dx 181 impact, session 28), no walls."""
    x = np.array([[130.0, 80.0], [130.7, 80.7]]) * DX
    v = np.array([[-6.43, 2.52], [-6.43, 2.52]])
    rho = np.full(2, 1000.0)
    M = rho * DX * DX * 2 * np.pi * x[:, 0]
    pa = FluidParams(rho0=1000.0, c0=100.0, mu=3e-4, delta=0.1, alpha=0.02)
    return AxisymmetricFluid(x, v, rho, np.full(2, FLUID, np.int8), M, DX * DX, 3 * DX, pa,
                             surface_tension=0.072, free_surface_no_tension=True,
                             fragment_hoop=False, axis_floor=0.25 * DX,
                             debris_rings=debris_rings), M.sum()


def test_debris_made_inert_flies_ballistically_through_the_axis():
    f, m0 = _pair_towards_axis(16)
    while not f.inert.all():
        f.step(f.stable_dt())
    assert f.step_count == AxisymmetricFluid.DEBRIS_EVERY
    assert (f.kind == INERT).all() and not f.fluid.any()
    x0, v0, rho0, t0 = f.x.copy(), f.v.copy(), f.rho.copy(), f.t
    while f.t < 4.0e-5:
        f.step(f.stable_dt())
    # through the axis (reflected at the axis floor) and out again, on straight lines,
    # nothing else changed
    T = f.t - t0
    assert np.all(f.x[:, 0] > 100 * DX) and np.all(f.v[:, 0] > 0.0)
    floor = f.axis_floor
    ballistic = np.column_stack([floor + np.abs(x0[:, 0] + T * v0[:, 0] - floor),
                                 x0[:, 1] + T * v0[:, 1]])
    assert np.allclose(f.x, ballistic, rtol=0, atol=1e-6 * DX)
    assert np.array_equal(f.rho, rho0)
    assert f.total_mass() == pytest.approx(m0, rel=1e-15)
    assert f.debris_events and f.debris_events[0][1].tolist() == [0, 1]


def test_without_debris_the_pair_compresses_towards_the_axis():
    """The defect the debris treatment removes: the same pair left in the pair sums gains
    density on its way in (CSF-driven pair vibration) - checked over the first half."""
    f, _ = _pair_towards_axis(0)
    while f.x[:, 0].min() > 60 * DX:
        f.step(f.stable_dt())
    assert f.rho.max() > 1.02 * 1000.0


def test_debris_rings_bad_values():
    x = np.array([[1.0, 1.0]]) * DX
    args = (x, np.zeros((1, 2)), np.full(1, 1000.0), np.array([FLUID], np.int8), 1.0,
            DX * DX, 3 * DX, FluidParams(rho0=1000.0, c0=10.0))
    with pytest.raises(ValueError, match="debris_rings"):
        AxisymmetricFluid(*args, debris_rings=-1)
    with pytest.raises(ValueError, match="debris_rings"):
        AxisymmetricFluid(*args, debris_rings=4, periodic_z=(0.0, 20 * DX))
    f = AxisymmetricFluid(*args, debris_rings=0)
    with pytest.raises(ValueError, match="only fluid rows"):
        xw = np.vstack([x, [[1.0, -1.0]]])
        g = AxisymmetricFluid(xw, np.zeros((2, 2)), np.full(2, 1000.0),
                              np.array([FLUID, WALL], np.int8), 1.0, DX * DX, 3 * DX,
                              FluidParams(rho0=1000.0, c0=10.0))
        g.make_inert([1])
    assert f.debris_rings == 0


@pytest.fixture(scope="module")
def short_coupled_run(tmp_path_factory):
    """The droplet job (fluid, ring heat, fem-contact substrate heat, fem-axisymmetric
    stress) at D/dx 16 to 0.05 t_c."""
    from builders import coupled_droplet_run

    return coupled_droplet_run(tmp_path_factory.mktemp("debris"), 10, 16, 0.05)


def test_the_scene_module_takes_debris_out_of_the_heat_and_reports_it(short_coupled_run):
    """The axisymmetric scene's fluid module: inert rings get k_heat = 0 (the heat module and
    the contact interface skip them), the fluid's energy for the coupling's balance still
    counts them, summary.json reports them, and a checkpoint restores them."""
    sim = short_coupled_run
    ctx, ps = sim.ctx, sim.ctx.particles
    fm = next(m for m in sim.modules if m.name == "fluid")
    s = fm.solver
    assert s.debris_rings == 16 and not s.inert.any()
    top = np.argsort(s.x[:, 1])[-2:]  # two rings at the droplet's top
    state = fm.checkpoint_state(ctx)
    s.make_inert(top)
    fm._inert_heat(ctx, top)
    assert np.all(ps.k_heat[fm.idx[top]] == 0.0)
    d = fm.diagnostics(ctx)["debris"]
    assert d["count"] == 2 and d["mass_fraction"] == pytest.approx(
        s.M[top].sum() / s.total_mass())
    cm = next(m for m in sim.modules if m.name == "coupling")
    sh = cm.driver.thermal  # the fem-contact substrate heat
    wet = sh._fluid(ps)
    every = sh._fluid(ps, wet_only=False)
    assert set(fm.idx[top]) <= set(every) and not set(fm.idx[top]) & set(wet)
    assert every.size == wet.size + 2
    s.debris_events.append((1.5e-7, np.sort(top)))
    st = fm.checkpoint_state(ctx)
    assert st["_inert"].tolist() == sorted(top.tolist()) and st["_debris_t_first"] == 1.5e-7
    # restored into the same module: the rows stay inert, the first time is kept
    fm.restore_state(ctx, dict(st))
    assert fm.diagnostics(ctx)["debris"]["t_first_s"] == 1.5e-7
    assert np.flatnonzero(s.inert).tolist() == sorted(top.tolist())
    # the checkpoint written before makes no ring inert; the later one does
    assert state["_inert"].size == 0


def _debris_over_a_wall(no_penetration):
    """A 10 x 4 block of rings at rest on a 3-row wall (z < 0, normals +z) and one ring
    flying at (2, -5) m/s from 6 dx above the wall at r = 40 dx, made inert at once."""
    body = _block(0.5 * DX, 0.5 * DX, 10, 4)
    drop = np.array([[40.0, 6.0]]) * DX
    walls = _block(0.5 * DX, -2.5 * DX, 80, 3)
    x = np.vstack([body, drop, walls])
    nf = len(body) + 1
    kind = np.array([FLUID] * nf + [WALL] * len(walls), np.int8)
    v = np.zeros_like(x)
    v[nf - 1] = (2.0, -5.0)
    rho = np.full(len(x), 1000.0)
    M = rho * DX * DX * 2 * np.pi * x[:, 0]
    nrm = np.where((kind == WALL)[:, None], [0.0, 1.0], 0.0)
    pa = FluidParams(rho0=1000.0, c0=100.0, mu=3e-4, delta=0.1, alpha=0.02)
    f = AxisymmetricFluid(x, v, rho, kind, M, DX * DX, 3 * DX, pa, wall_normals=nrm,
                          no_penetration=no_penetration, axis_floor=0.25 * DX)
    f.make_inert([nf - 1])
    return f, nf - 1


@pytest.mark.parametrize("no_penetration", [True, False])
def test_inert_debris_lands_on_a_particle_wall(no_penetration):
    """Inert debris is held out of a particle wall as the fluid is (``no_penetration``): it
    lands on the surface z = 0 and slides on with its radial velocity; without the option
    it flies through the wall (the D/dx 256 impact had 25 debris rings under its wall)."""
    f, i = _debris_over_a_wall(no_penetration)
    t_land = 6.0 * DX / 5.0
    while f.t < 2.0 * t_land:
        f.step(min(f.stable_dt(), 0.05 * t_land))
    if no_penetration:
        assert f.x[i, 1] == pytest.approx(0.0, abs=1e-9 * DX)  # on the wall's surface
        assert abs(f.v[i, 1]) < 1e-12 and f.v[i, 0] == pytest.approx(2.0, rel=1e-12)
        assert f.x[i, 0] == pytest.approx(40.0 * DX + 2.0 * f.t, rel=1e-9)
    else:
        assert f.x[i, 1] < -3.0 * DX  # through the three rows
