"""Work the projection methods (IISPH, DFSPH) leave out, and the DFSPH warm starts.

* the force pass under a projection method runs without the delta-SPH term, so the
  renormalised density gradient (:func:`sphfem.fluid.passes.density_gradient`) is not
  computed (it feeds only ``drho``, which the projection does not use; the density is a
  summation there), while the accelerations stay bit-identical; WCSPH still computes it;
* the DFSPH divergence solve's warm start (default 0.5): half the last step's dt kappa^v
  by particle id, independent of the new dt, applied only where the flow compresses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver, passes
from sphfem.fluid.setup import box_walls, lattice, make_particles


def _solver(pressure: str, n: int = 8, **kw) -> FluidSolver:
    """2D column H = 1 m, H/n spacing, in a tank with 3 wall layers."""
    H, g = 1.0, 9.81
    dx = H / n
    ps = make_particles(lattice([0, 0], [H, H], dx), box_walls([0, 0], [2 * H, 1.5 * H], dx, 3),
                        dx, 1000.0)
    par = FluidParams(rho0=1000.0, c0=10 * math.sqrt(g * H), mu=1e-3, gravity=(0.0, -g),
                      alpha=0.02, pressure=pressure, **kw)
    m = 4 * dx
    return FluidSolver(ps, 3 * dx, [-m, -m], [2 * H + m, 1.5 * H], params=par)


def _count_gradient_calls(monkeypatch) -> list:
    calls = []
    orig = passes.density_gradient

    def counted(*a):
        calls.append(1)
        return orig(*a)

    monkeypatch.setattr(passes, "density_gradient", counted)
    return calls


@pytest.mark.parametrize("pressure", ["dfsph", "iisph"])
def test_projection_skips_the_density_gradient(monkeypatch, pressure):
    calls = _count_gradient_calls(monkeypatch)
    s = _solver(pressure, delta=0.1)
    for _ in range(3):
        s.step(1e-3)
    assert not calls  # the delta term (and with it the gradient) is WCSPH's only
    acc = s.p.acc.copy()
    s0 = _solver(pressure, delta=0.0)
    for _ in range(3):
        s0.step(1e-3)
    assert np.array_equal(acc, s0.p.acc)  # delta never entered a projection's forces


def test_wcsph_still_computes_the_density_gradient(monkeypatch):
    calls = _count_gradient_calls(monkeypatch)
    s = _solver("wcsph", delta=0.1)
    s.step(1e-4)
    assert calls


def test_dfsph_divergence_warm_start_is_half_the_last_velocity_change():
    """The divergence solve's warm start (default 0.5; see the module docstring) takes
    half of the last step's kappa^v (Bender & Koschier 2017; SPlisHSPlasH's
    warmstartDivergenceSolve), looked up by particle id and kept as dt kappa^v: the velocity
    change it applies does not depend on the new step's dt; only particles whose flow
    compresses (D_i > 0) carry a warm q^v, and the change conserves momentum (fluid and
    walls' reaction)."""
    from sphfem.fluid import pressure_dfsph_bender2017 as dfsph
    from sphfem.fluid import projection
    from sphfem.particles import FLUID, WALL

    s = _solver("dfsph", dfsph_divergence_warm_start=0.5)
    for _ in range(4):
        s.step(2e-3)
    st = s.pressure_state
    w = projection.prepare(s, st)
    fl = s.p.kind == FLUID
    stored = st.warm_v.get(s.p.id)
    assert stored[fl].max() > 0.0 and stored.min() >= 0.0  # compressed somewhere, clamped
    v0 = s.p.v.copy()
    projection.density_rate(v0, *projection.solve_pairs(s, w), w.rate)
    comp = fl & (w.rate > 0.0)
    assert comp.any() and (fl & ~comp).any()
    dv = []
    for dt in (1e-3, 3e-3):
        s.p.v[:] = v0
        dfsph.warm_start_divergence(s, st, w, dt)
        expect = np.zeros(s.p.n)
        expect[comp] = 0.5 * stored[comp] / (dt * w.rho[comp])
        assert np.allclose(w.Qv[fl], expect[fl], rtol=1e-14, atol=0.0)
        dv.append(s.p.v - v0)
        # momentum: the fluid's change is the negative of the walls' reaction
        f = np.zeros_like(s.p.v)
        projection.wall_reaction(w.Qv, s.p.m, w.M, s.p.kind, s.nbrs.offsets, w.nbj, w.grad,
                                 w.cnt, projection.SINGLE_PAIRS, f)
        mom = (s.p.m[fl, None] * dv[-1][fl]).sum(0) / dt + f[s.p.kind == WALL].sum(0)
        assert np.abs(mom).max() < 1e-10 * np.abs(s.p.m[fl, None] * dv[-1][fl]).sum() / dt
    assert np.abs(dv[0]).max() > 0.0
    assert np.allclose(dv[0], dv[1], rtol=1e-12, atol=1e-15 * np.abs(dv[0]).max())


@pytest.mark.parametrize("pressure", ["dfsph", "iisph"])
def test_projection_timers_are_disjoint(pressure):
    """``pressure_solve`` excludes the pair set-up timed as ``pressure_pairs`` (it runs inside
    the solve), so the fluid's timers add up to no more than the steps' wall time."""
    import time

    s = _solver(pressure)
    s.step(1e-3)  # compile outside the timed steps
    w0 = dict(s.wall)
    t0 = time.perf_counter()
    for _ in range(3):
        s.step(1e-3)
    elapsed = time.perf_counter() - t0
    spent = {k: s.wall[k] - w0.get(k, 0.0) for k in s.wall}
    assert spent["pressure_pairs"] > 0.0 and spent["pressure_solve"] > 0.0
    assert sum(spent.values()) <= elapsed


def _dam_break(pressure: str) -> FluidSolver:
    """PySPH's dam_break_2d geometry at dx = 0.03 (benchmarks/pysph/time_to_solution.py):
    a 1 x 2 m column in a 4 x 4 m tank, the hydrostatic pressure as the first guess."""
    from sphfem.particles import FLUID

    dx, g, H = 0.03, 9.81, 2.0
    nx, ny = int(1.0 / dx) + 1, int(H / dx) + 1
    ps = make_particles(lattice([0.0, 0.0], [nx * dx, ny * dx], dx),
                        box_walls([0.0, 0.0], [4.0, 4.0], dx, 3), dx, 1000.0)
    par = FluidParams(c0=10 * math.sqrt(2 * g * H), mu=1e-3, gravity=(0.0, -g), alpha=0.02,
                      pressure=pressure)
    s = FluidSolver(ps, 3 * dx, [-4 * dx, -4 * dx], [4.0 + 4 * dx, 8.0], params=par)
    fl = s.p.kind == FLUID
    s.p.p[fl] = 1000.0 * g * (ny * dx - s.p.x[fl, 1])
    return s


@pytest.mark.parametrize("pressure", ["dfsph", "iisph"])
def test_a_tiny_first_step_does_not_throw_the_fluid(pressure):
    """The first step's carried weight is measured against the solver's own stable step, so a
    first step of 1e-6 s (e.g. shortened to an output time) leaves the set-up's density
    error to the next, full step, which removes it at a full step's pace: after the tiny
    step and three stable ones no particle of the 2 m dam break moves faster than 2
    sqrt(2 g H) (12.5 m/s; measured 1.2 m/s).  Without the weight the error went out in
    the 1e-6 s step: 165 m/s, and the CFL step shrank 50-fold."""
    s = _dam_break(pressure)
    s.step(1e-6)
    for _ in range(3):
        s.step(s.stable_dt()[0])
    assert float(np.abs(s.p.v).max()) < 2 * math.sqrt(2 * 9.81 * 2.0)
