"""The density-rate time-step limit ``[fluid] density_cfl``: dt <= C min(rho / |Drho/Dt|),
on a prescribed uniformly converging flow whose density rate is known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from sphfem.axisymmetric import ring_mass
from sphfem.fluid.axisymmetric import AxisymmetricFluid
from sphfem.fluid.wcsph import FluidParams
from sphfem.particles import FLUID


def converging_block(C: float, a: float = 50.0, N: int = 20):
    """An all-fluid (r, z) block with v = (-a r, 0): Drho/Dt = -rho div v = 2 a rho (the
    hoop term -rho v_r / r = a rho and the meridian one a rho)."""
    dx = 1.0 / N
    g = (np.arange(N) + 0.5) * dx
    x = np.column_stack([q.ravel() for q in np.meshgrid(g, g - 0.5, indexing="ij")])
    v = np.column_stack([-a * x[:, 0], 0.0 * x[:, 1]])
    pa = FluidParams(rho0=1.0, c0=10.0, mu=0.0, delta=0.0, density_cfl=C)
    f = AxisymmetricFluid(x, v, np.ones(len(x)), np.full(len(x), FLUID),
                          ring_mass(x[:, 0], 1.0, dx * dx), dx * dx, 3 * dx, pa)
    f.evaluate()
    return f


def test_density_limit_is_the_fraction_of_the_fastest_density_change():
    """C / max |Drho/Dt| / rho, and that rate is the exact 2 a where the support is full
    (renormalised divergence, exact for linear v; the edges of the block are free
    surfaces, within 20 %)."""
    a, C = 50.0, 0.02
    f = converging_block(C, a)
    lim = f.dt_limits()
    rate = np.abs(f.drho) / f.rho
    assert lim["density"] == pytest.approx(C / rate.max(), rel=1e-12)
    assert lim["density"] == pytest.approx(C / (2 * a), rel=0.2)
    assert f.stable_dt() <= lim["density"]
    inner = (f.x[:, 0] < 0.8) & (np.abs(f.x[:, 1]) < 0.3)
    assert np.allclose(rate[inner], 2 * a, rtol=1e-6)


def test_density_limit_off_by_default():
    assert "density" not in converging_block(0.0).dt_limits()
    assert FluidParams().density_cfl == 0.0


def test_density_limit_in_the_cartesian_solver():
    """The planar solver honours the same key: C over the fluid's largest |Drho/Dt| / rho
    (walls excluded), on a walled 2D block with random velocities."""
    from sphfem.fluid import FluidSolver
    from sphfem.fluid.setup import box_walls, lattice, make_particles

    dx = 0.01
    ps = make_particles(lattice([0.0, 0.0], [0.2, 0.15], dx),
                        box_walls([0.0, 0.0], [0.2, 0.2], dx, 3), dx, 1000.0)
    par = FluidParams(c0=10.0, mu=0.0, gravity=(0.0, 0.0), delta=0.0, density_cfl=0.05)
    s = FluidSolver(ps, 3 * dx, [-0.05, -0.05], [0.25, 0.25], params=par)
    fl = s.p.kind == FLUID
    s.p.v[fl] = np.random.default_rng(1).normal(0.0, 0.5, (int(fl.sum()), 2))
    s.evaluate()
    rate = np.abs(s.p.drho[fl]) / s.p.rho[fl]
    assert s.dt_limits()["density"] == pytest.approx(0.05 / rate.max(), rel=1e-12)
