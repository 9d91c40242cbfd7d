"""IISPH (Ihmsen et al. 2014, ``pressure = "iisph"``) and the projection kernels it shares
with DFSPH (sphfem/fluid/projection.py).

Kernels alone, on lattices in 2D and 3D (one code path):
* the lattice sum S and the calibrated summation density (rho0 inside a lattice);
* the pressure acceleration of a linear pressure field: -grad p / rho to the lattice's
  moment error (< 1 %);
* momentum: the fluid's pressure forces plus the walls' reaction sum to zero (round-off);
* the Jacobi diagonal A_i is the exact coefficient of q_i in the density rate of a_i(q)
  inside the fluid; lambda_max of the Jacobi operator from its Fourier symbol matches a
  power iteration on the particle operator.
Physics: a 2D water column at rest (H/20, 2 s, gravity ramped over 0.5 s): time-mean
pressure against rho0 g depth, the walls carry the weight, density error within the
tolerance at every step.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid import projection as P
from sphfem.fluid.setup import box_walls, lattice, make_particles
from sphfem.kernels import WENDLAND_C2, kernel_sigma
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID, WALL


def _lattice_system(dim, n, walls=0, periodic=False):
    """A lattice block (n per axis, dx = 1/n) of fluid, with ``walls`` layers of wall
    particles around it; kernels' inputs at rest (pairs, g, W, rho, A)."""
    dx = 1.0 / n
    R = 3.0 * dx
    xf = lattice([0.0] * dim, [1.0] * dim, dx)
    xw = box_walls([0.0] * dim, [1.0] * dim, dx, walls, open_top=False) if walls else None
    ps = make_particles(xf, xw, dx, 1000.0)
    period = np.ones(dim) if periodic else np.zeros(dim)
    m = (walls + 1) * dx
    nl = build_neighbor_list(ps.x, R, np.full(dim, -m), np.full(dim, 1.0 + m), period=period)
    S = P.lattice_sum(WENDLAND_C2, dim, 3.0)
    M = np.where(ps.kind == FLUID, ps.m, 1000.0 * ps.vol) / S
    npair = nl.indices.shape[0]
    out = dict(x=ps.x, kind=ps.kind, m=ps.m, M=M, off=nl.offsets, nbj=np.zeros(npair, np.int64),
               grad=np.zeros((npair, dim)), wgt=np.zeros(npair), cnt=np.zeros(ps.n, np.int64),
               rho=np.zeros(ps.n), A=np.zeros(ps.n), dx=dx, period=period, n=ps.n, dim=dim)
    P.pairs_and_density(ps.x, ps.kind, M, nl.offsets, nl.indices, R,
                        kernel_sigma(WENDLAND_C2, dim, R), WENDLAND_C2, period, out["nbj"],
                        out["grad"], out["wgt"], out["cnt"], out["rho"])
    out["packed"] = _pack(out, np.float64)  # and A
    return out


def _pack(s, dtype):
    """The fluid rows' packed pairs (:func:`P.pack_pairs`) with M_j g_ij in ``dtype``; the
    diagonal into s["A"]."""
    fl = s["kind"] == FLUID
    off_c = np.zeros(s["n"] + 1, np.int64)
    off_c[1:] = np.cumsum(np.where(fl, s["cnt"], 0))
    nb_c = np.zeros(off_c[-1], np.int32)
    mg_c = np.zeros((off_c[-1], s["dim"]), dtype)
    P.pack_pairs(s["M"], s["kind"], s["off"], s["nbj"], s["grad"], s["cnt"], off_c, nb_c, mg_c,
                 s["A"])
    return off_c, nb_c, mg_c


def _pairs(s, packed=None):
    """Arguments of P.density_rate / P.pressure_acceleration (double precision unless
    ``packed`` is given)."""
    return (s["kind"], *(packed or s["packed"]))


def _accel(s, q, packed=None):
    a = np.zeros((s["n"], s["dim"]))
    P.pressure_acceleration(q, *_pairs(s, packed), 1.0, a, False)
    return a


@pytest.mark.parametrize("dim", [2, 3])
def test_lattice_sum_calibrates_the_summation_density(dim):
    sig = kernel_sigma(WENDLAND_C2, dim, 3.0)
    r = np.arange(-3, 4)
    k = np.stack(np.meshgrid(*[r] * dim), -1).reshape(-1, dim)
    q = np.sqrt((k**2).sum(1)) / 3.0
    direct = sig * np.sum(np.where(q < 1, (1 - q) ** 4 * (1 + 4 * q), 0.0))
    assert abs(P.lattice_sum(WENDLAND_C2, dim, 3.0) - direct) < 1e-14
    assert 1.003 < direct < 1.006  # the kernel sum of a lattice is not one
    s = _lattice_system(dim, 12 if dim == 2 else 8, periodic=True)
    assert np.abs(s["rho"] / 1000.0 - 1.0).max() < 1e-12  # calibrated: rho0 at rest


@pytest.mark.parametrize("dim", [2, 3])
def test_pressure_acceleration_of_a_linear_field(dim):
    """q = p / rho0^2 with p = rho0 g (1 - z): a = -grad p / rho0 = +g e_z inside."""
    n = 16 if dim == 2 else 10
    s = _lattice_system(dim, n)
    x, fl = s["x"], s["kind"] == FLUID
    g = 9.81
    q = np.where(fl, 1000.0 * g * (1.0 - x[:, -1]) / 1000.0**2, 0.0)
    a = _accel(s, q)
    inner = fl & np.all((x > 3.2 * s["dx"]) & (x < 1 - 3.2 * s["dx"]), axis=1)
    assert inner.sum() > 10
    assert np.abs(a[inner, -1] / g - 1.0).max() < 0.01  # lattice moment error (2D: 0.77 %)
    assert np.abs(a[inner, :-1]).max() < 1e-9 * g


@pytest.mark.parametrize("single", [False, True])
@pytest.mark.parametrize("dim", [2, 3])
def test_wall_reaction_balances_the_pressure_forces(dim, single):
    """To round-off, with the packed M_j g_ij in double or (as the solvers store them) in
    single precision: the reaction rounds its terms alike."""
    s = _lattice_system(dim, 10 if dim == 2 else 6, walls=3)
    fl, wall = s["kind"] == FLUID, s["kind"] == WALL
    rng = np.random.default_rng(1)
    q = np.where(fl, rng.random(s["n"]), 0.0)
    P.wall_extrapolate(q, s["kind"], s["off"], s["nbj"], s["wgt"], s["cnt"])
    assert q[wall].max() > 0  # the walls next to the fluid carry pressure
    a = _accel(s, q, _pack(s, np.float32 if single else np.float64))
    f = np.zeros((s["n"], dim))
    P.wall_reaction(q, s["m"], s["M"], s["kind"], s["off"], s["nbj"], s["grad"], s["cnt"],
                    single, f)
    total = (s["m"][fl, None] * a[fl]).sum(0) + f[wall].sum(0)
    scale = np.abs(s["m"][fl, None] * a[fl]).sum()
    assert np.abs(total).max() < 1e-13 * scale


@pytest.mark.parametrize("dim", [2, 3])
def test_single_precision_pairs_match_double(dim):
    """The solvers' float32 M_j g_ij (projection.PAIR_DTYPE) change a density rate and a
    pressure acceleration by ~1e-7 relative (float32's 6e-8 unit round-off)."""
    assert P.PAIR_DTYPE == np.float32 and P.SINGLE_PAIRS
    s = _lattice_system(dim, 10 if dim == 2 else 6, walls=3)
    rng = np.random.default_rng(2)
    fl = s["kind"] == FLUID
    q = np.where(fl, rng.random(s["n"]), 0.0)
    u = rng.standard_normal((s["n"], dim))
    single = _pack(s, np.float32)
    a64, a32 = _accel(s, q), _accel(s, q, single)
    r64, r32 = np.zeros(s["n"]), np.zeros(s["n"])
    P.density_rate(u, *_pairs(s), r64)
    P.density_rate(u, *_pairs(s, single), r32)
    assert 0 < np.abs(a32 - a64).max() < 1e-6 * np.abs(a64).max()
    assert 0 < np.abs(r32 - r64).max() < 1e-6 * np.abs(r64).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_diagonal_is_the_coefficient_of_q_i_inside(dim):
    s = _lattice_system(dim, 12 if dim == 2 else 8, periodic=True)
    i = s["n"] // 2 + 3
    q = np.zeros(s["n"])
    q[i] = 1.0
    rate = np.zeros(s["n"])
    P.density_rate(_accel(s, q), *_pairs(s), rate)
    assert abs(-rate[i] / s["A"][i] - 1.0) < 1e-12


@pytest.mark.parametrize("dim", [2, 3])
def test_jacobi_lambda_matches_a_power_iteration(dim):
    s = _lattice_system(dim, 16 if dim == 2 else 10, periodic=True)
    rng = np.random.default_rng(0)
    v = rng.standard_normal(s["n"])
    lam = 0.0
    for _ in range(300):
        rate = np.zeros(s["n"])
        P.density_rate(_accel(s, v), *_pairs(s), rate)
        y = -rate / s["A"]
        lam = np.linalg.norm(y) / np.linalg.norm(v)
        v = y / np.linalg.norm(y)
    fourier = P.jacobi_lambda(WENDLAND_C2, dim, 3.0)
    assert abs(lam / fourier - 1.0) < 0.03
    assert (0.5 * fourier < 2.0) == (dim == 2)  # omega = 0.5 diverges in 3D ...
    st = P.ProjectionState(jacobi_lambda=fourier)
    assert P.relaxation(st, 0.5) * fourier <= P.OMEGA_LAMBDA + 1e-12  # ... and is capped


def run_column(method: str, n: int = 20, dt: float = 2e-3, t_end: float = 2.0,
               average_from: float = 1.5, **kw):
    """2D water column H = 1 m at rest in a tank (gravity ramped over 0.5 s, alpha 0.02),
    fixed step dt; returns (solver, time-mean fluid p by id, max |v|, mean wall force /
    weight) over t >= average_from."""
    H, g = 1.0, 9.81
    dx = H / n
    ps = make_particles(lattice([0, 0], [H, H], dx), box_walls([0, 0], [H, 1.5 * H], dx, 3),
                        dx, 1000.0)
    par = FluidParams(rho0=1000.0, c0=10 * math.sqrt(g * H), mu=1e-3, gravity=(0.0, -g),
                      alpha=0.02, gravity_ramp=0.5, pressure=method, **kw)
    m = 4 * dx
    s = FluidSolver(ps, 3 * dx, [-m, -m], [H + m, 1.5 * H], params=par)
    p_sum, k, vmax, fw = 0.0, 0, 0.0, []
    while s.t < t_end - 1e-12:
        s.step(min(dt, t_end - s.t))
        s.check()
        if s.t > average_from:
            ps = s.p
            fl = ps.kind == FLUID
            p_sum = p_sum + ps.p[np.argsort(ps.id)]
            k += 1
            vmax = max(vmax, float(np.sqrt((ps.v[fl] ** 2).sum(1)).max()))
            fw.append(-ps.f_fluid[ps.kind == WALL].sum(0)[1] / (ps.m[fl].sum() * g))
    return s, p_sum / k, vmax, float(np.mean(fw))


def check_column(s, p_mean, vmax, fw, tol_percent):
    """Time-mean p within 5 % (L2) of rho0 g depth, the walls carry the weight within 1 %,
    max speed below 0.06 sqrt(g H), density error within the tolerance at every step."""
    ps = s.p
    order = np.argsort(ps.id)
    fl = (ps.kind == FLUID)[order]
    depth = 1.0 - ps.x[order][fl, 1]
    p_ex = 1000.0 * 9.81 * depth
    e2 = np.sqrt(np.mean((p_mean[fl] - p_ex) ** 2) / np.mean(p_ex**2))
    log = s.pressure_state.log
    assert e2 < 0.05
    assert abs(fw - 1.0) < 0.01
    assert vmax < 0.06 * math.sqrt(9.81)
    assert max(log.density_error) <= tol_percent / 100 and log.not_converged == 0
    assert s.diagnostics()["pressure_solve"]["steps"] == len(log.iterations) == s.step_count
    return e2


def test_iisph_column_at_rest():
    """Measured: time-mean p within 3.0 % of rho0 g depth, wall force / weight 0.999, max
    speed 0.051 sqrt(g H) over the last 0.5 s, 2.0 iterations per step."""
    s, p_mean, vmax, fw = run_column("iisph")
    check_column(s, p_mean, vmax, fw, 0.1)
    assert set(s.dt_limits()) >= {"cfl", "force"} and "acoustic" not in s.dt_limits()
