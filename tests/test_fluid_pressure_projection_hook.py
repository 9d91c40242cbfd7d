"""The pressure registry's projection hook (sphfem/fluid/pressure.py): a projection method
(IISPH, DFSPH) gets the forces without pressure, then runs its own pressure solve inside
the semi-implicit Euler step of projection_advance; wcsph keeps its equation-of-state step.

A toy projection method whose solve adds nothing ("pressureless dust") checks the hook
against exact solutions: a compressed fluid block at rest feels exactly g (the pressure
would push its surface out), and a falling block follows the discrete free fall of
semi-implicit Euler, v_n = n dt g, x_n = x_0 + n (n + 1) / 2 dt^2 g, to round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

from sphfem.fluid import integrators, pressure
from sphfem.fluid.pressure import PressureMethod, projection_advance
from sphfem.fluid.setup import box_walls, lattice, make_particles
from sphfem.fluid.wcsph import FluidParams, FluidSolver
from sphfem.particles import FLUID

G = np.array([0.0, -9.81])
P_TOY = 123.0  # the toy method's pressure [Pa]


@pytest.fixture
def toy():
    """Register the toy projection method; its solve records dt and sets p = P_TOY."""
    calls = []

    def solve(solver, dt, state):
        calls.append(dt)
        solver.p.p[solver.p.kind == FLUID] = P_TOY
        return (state or 0) + 1

    pressure.register(PressureMethod(name="toy-dust", doc="no pressure", params=(),
                                     solve=solve))
    yield calls
    pressure.REGISTRY.unregister("toy-dust")


def _solver(method, walls=True, rho_ratio=1.01):
    dx = 0.01
    xf = lattice([0.0, 0.0], [0.2, 0.15], dx)
    xw = box_walls([0.0, 0.0], [0.2, 0.2], dx, 3) if walls else None
    ps = make_particles(xf, xw, dx, 1000.0, rho_fluid=1000.0 * rho_ratio)
    par = FluidParams(c0=10.0, mu=1e-3, gravity=tuple(G), pressure=method)
    return FluidSolver(ps, 3 * dx, [-0.05, -0.2], [0.25, 0.25], params=par)


def test_wcsph_is_the_equation_of_state_step():
    m = pressure.lookup("wcsph")
    assert m.eos and m.solve is None and m.advance is not projection_advance
    with pytest.raises(ValueError, match="advance .* or solve"):
        PressureMethod(name="x", doc="", params=())
    with pytest.raises(ValueError, match="not both"):
        PressureMethod(name="x", doc="", params=(), advance=m.advance, solve=m.advance)
    assert integrators.lookup("symplectic") is not None


def test_projection_method_sees_the_forces_without_pressure(toy):
    """A block compressed by 1 % at rest over a wall: with wcsph the Tait pressure
    (rho0 c0^2 / gamma ((1.01)^7 - 1) = 1.0 kPa) pushes the surface particles at several g
    (measured 8.7 g);
    the projection method's evaluation leaves exactly g and the method's own p."""
    wc = _solver("wcsph")
    fl = wc.p.kind == FLUID
    assert np.abs(wc.p.acc[fl] - G).max() > 5 * abs(G[1])
    s = _solver("toy-dust")
    fl = s.p.kind == FLUID
    assert s.pressure_method.eos is False
    s.p.p[fl] = P_TOY
    s.evaluate()
    assert np.abs(s.p.acc[fl] - G).max() < 1e-12 * abs(G[1])
    assert np.all(s.p.p[fl] == P_TOY)


def test_projection_step_is_semi_implicit_euler_free_fall(toy):
    s = _solver("toy-dust", walls=False, rho_ratio=1.0)
    x0 = s.p.x[s.p.kind == FLUID].copy()
    dt, n = 1e-3, 25
    for _ in range(n):
        s.step(dt)
    fl = s.p.kind == FLUID
    assert toy == [dt] * n and s.pressure_state == n
    assert np.abs(s.p.v[fl] - n * dt * G).max() < 1e-12 * n * dt * abs(G[1])
    expect = x0 + 0.5 * n * (n + 1) * dt * dt * G

    def key(a):  # cell sorts permute the particles
        return a[np.lexsort(a.T[::-1])]

    drop = 0.5 * n * (n + 1) * dt * dt * abs(G[1])
    assert np.abs(key(s.p.x[fl]) - key(expect)).max() < 1e-12 * drop + 1e-15
    assert np.all(s.p.p[fl] == P_TOY) and abs(s.t - n * dt) < 1e-15
