"""Moving contact lines (issue 17): wall slip of the viscous term, Young's normals at walls,
the sessile drop's angle measurement.

* ``wall_slip``: the viscous acceleration of the fluid rows next to a flat wall vanishes
  for the velocity profile the slip condition admits -- a plug u = U for free slip, the
  linear Navier profile u = G (y + b) (zero Laplacian, u = b du/dy at the wall face y = 0)
  for ``navier`` with slip length b -- to the discretisation residual of Adami's no-slip
  ghost on its own profile u = G y; the same profiles under a no-slip wall feel the drag
  of the wrong condition, 100x larger.  The default (no-slip) is not touched and navier
  with b = 0 is no-slip.
* Young's normals (Breinlinger et al. 2013): fluid particles of the first layer along a
  wall get inward normals with -n . n_w = cos theta, whatever their colour gradient's
  angle; the tangential direction (towards the liquid) is kept.
* The angle measurement of :mod:`sphfem.validation.sessile_drop` on lattice caps of known
  angle: within 2.5 deg (the lattice's staircase) at R0/dx = 10 and 20.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.contact_angle_breinlinger2013 import apply_young_normals
from sphfem.fluid.setup import lattice, make_particles
from sphfem.particles import FLUID
from sphfem.validation.sessile_drop import contact_angle


def _channel(profile, n=20, **params):
    """Fluid layer y in [0, 10 dx] over a 3-layer wall, periodic in x, velocity
    u_x = profile(y), rho = rho0 (p = 0), mu = 1: the fluid rows within R of the wall and
    the viscous scale mu |G| / (rho dx) with G = 1."""
    dx = 1.0 / n
    R, L, H = 3 * dx, 20 * dx, 10 * dx
    ps = make_particles(lattice([0, 0], [L, H], dx), lattice([0, -3 * dx], [L, 0], dx), dx,
                        1000.0)
    ps.add_field("v", 2)
    fl = ps.kind == FLUID
    ps.v[fl, 0] = profile(ps.x[fl, 1])
    par = FluidParams(rho0=1000.0, c0=10.0, mu=1.0, gravity=(0.0, 0.0), **params)
    s = FluidSolver(ps, R, [0, -4 * dx], [L, 2 * H], period=[L, 0.0], params=par)
    near = (s.p.kind == FLUID) & (s.p.x[:, 1] < R)
    return s, near, 1.0 / (1000.0 * dx)


def _max_acc(profile, **params):
    s, near, scale = _channel(profile, **params)
    return float(np.abs(s.p.acc[near]).max()) / scale, s


def test_navier_and_free_slip_admit_their_profiles():
    b = 0.1
    base, _ = _max_acc(lambda y: y)  # Adami no-slip on u = G y: the discretisation residual
    assert base < 0.05
    wrong, _ = _max_acc(lambda y: y + b)  # a slipping profile under a no-slip wall: drag
    navier, _ = _max_acc(lambda y: y + b, wall_slip="navier", slip_length=b)
    assert wrong > 100 * base
    assert navier < 1.5 * base
    plug_ns, _ = _max_acc(lambda y: np.full_like(y, 0.5))
    plug_fs, _ = _max_acc(lambda y: np.full_like(y, 0.5), wall_slip="free-slip")
    assert plug_ns > 100 * base
    assert plug_fs < 1e-9


def test_no_slip_default_and_zero_slip_length():
    assert FluidParams().wall_slip == "no-slip"
    a_ns, s_ns = _max_acc(lambda y: y + 0.05)
    a_nv, s_nv = _max_acc(lambda y: y + 0.05, wall_slip="navier", slip_length=0.0)
    np.testing.assert_allclose(s_nv.p.acc, s_ns.p.acc, rtol=0, atol=1e-12 * a_ns)


@pytest.mark.parametrize("theta", [45.0, 90.0, 135.0])
def test_young_normals_on_the_first_layer(theta):
    n = 10
    dx = 1.0 / n
    # a fluid block x < 0 on a wall y < 0: the first layer's colour gradient points into the
    # liquid at ~45 deg (walls count as liquid); its own normals are random otherwise
    xf = lattice([-2.0, 0.0], [0.0, 1.0], dx)
    ps = make_particles(xf, lattice([-2.5, -3 * dx], [1.0, 0.0], dx), dx, 1000.0)
    s = FluidSolver(ps, 3 * dx, [-3.0, -1.0], [2.0, 2.0],
                    params=FluidParams(rho0=1000.0, c0=10.0, gravity=(0.0, 0.0)))
    rng = np.random.default_rng(1)
    g = np.zeros_like(s.p.x)
    fl = s.p.kind == FLUID
    g[fl] = [-1.0, 0.0] + 0.3 * rng.standard_normal((fl.sum(), 2))  # into the liquid (-x)
    mag = np.hypot(g[:, 0], g[:, 1])
    beta = apply_young_normals(s, g, theta)
    first = fl & (s.p.x[:, 1] < dx)
    assert np.all(beta[first] == 1.0)
    assert np.all(beta[fl & (s.p.x[:, 1] > 2.5 * dx)] == 0.0)
    nu = g[first] / np.hypot(g[first, 0], g[first, 1])[:, None]
    # n_out = -nu, n_w = +y: n_out . n_w = cos theta; tangential part points out (+x)
    np.testing.assert_allclose(-nu[:, 1], math.cos(math.radians(theta)), atol=1e-12)
    assert np.all(-nu[:, 0] > 0.0)
    np.testing.assert_allclose(np.hypot(g[:, 0], g[:, 1]), mag, rtol=1e-12)


@pytest.mark.parametrize("n", [10, 20])
def test_angle_of_lattice_caps(n):
    dx = 1e-3 / n
    for th in (45.0, 60.0, 90.0, 120.0, 150.0):
        t = math.radians(th)
        r = math.sqrt(0.5 * math.pi * 1e-6 / (t - math.sin(t) * math.cos(t)))  # area pi/2 R0^2
        x = lattice([-2e-3, 0.0], [2e-3, 3e-3], dx)
        x = x[np.hypot(x[:, 0], x[:, 1] + r * math.cos(t)) < r]
        ang, res = contact_angle(x, dx)
        assert ang == pytest.approx(th, abs=2.5)
        assert res < 0.5
