"""Transient FEM substrate conduction (sphfem.fem.heat_transient) against exact solutions
of the semi-infinite body (Carslaw & Jaeger 1959): constant surface flux (ierfc) and a
step surface temperature (erf); observed orders in space and time; energy to round-off."""

import math

import numpy as np
import pytest
from skfem import MeshQuad1

from sphfem.fem.heat_transient import (
    TransientHeat,
    graded_coordinates,
    graded_mesh,
    semi_infinite_flux,
    semi_infinite_step,
)

K, RHO, C = 10.0, 3950.0, 900.0  # alumina of the droplet scene
ALPHA = K / (RHO * C)
T_END = 5e-6
S = math.sqrt(ALPHA * T_END)     # 3.7 um
Q = 1e7                          # W/m^2


def column(nref: int = 0, h0: float = S / 10, growth: float = 1.2, depth: float = 10 * S):
    """A one-element-wide graded column below z = 0, each cell split 2^nref times."""
    z = -graded_coordinates(depth, h0, growth)[::-1]
    for _ in range(nref):
        z = np.sort(np.concatenate([z, 0.5 * (z[1:] + z[:-1])]))
    m = MeshQuad1.init_tensor(np.array([0.0, S]), z)
    tol = 1e-9 * depth
    return m.with_boundaries({"top": lambda x: np.abs(x[1]) < tol,
                              "bottom": lambda x: np.abs(x[1] + depth) < tol})


def run_flux(mesh, theta=0.5, n=200, axisymmetric=False):
    th = TransientHeat(mesh, K, RHO, C, 0.0, theta=theta, startup=2,
                       axisymmetric=axisymmetric)
    P = th.nodal_power(Q)
    for _ in range(n):
        th.step(T_END / n, power=P)
    return th


def test_graded_coordinates():
    z = graded_coordinates(10e-6, 0.1e-6, 1.2)
    h = np.diff(z)
    assert z[0] == 0.0 and z[-1] == pytest.approx(10e-6, rel=1e-14)
    assert h[0] == pytest.approx(0.1e-6) and np.all(h[1:-1] / h[:-2] == pytest.approx(1.2))


@pytest.mark.parametrize("kind", ["planar", "axisymmetric", "3d"])
def test_constant_flux_semi_infinite(kind):
    """T - T0 = (2 q sqrt(alpha t)/k) ierfc(z / 2 sqrt(alpha t)) on the default graded
    mesh (simplices, first cell sqrt(alpha t)/20, growth 1.1, one element wide), lumped,
    CN: the surface temperature within 0.2 % of 2 q sqrt(alpha t / pi)/k (measured
    0.12 %), every node within 1 % of it (measured 0.53 %: the two corners of the column
    differ by the triangles' orientation; Q1 quads 0.12 %)."""
    if kind == "3d":
        mesh = graded_mesh([(0.0, S), (0.0, S)], 10 * S, S / 20, 1.1, h_lateral=S)
    else:
        mesh = graded_mesh([(0.0, S)], 10 * S, S / 20, 1.1, h_lateral=S,
                           axisymmetric=kind == "axisymmetric")
    th = run_flux(mesh, axisymmetric=kind == "axisymmetric")
    z = -mesh.p[-1]
    exact = semi_infinite_flux(z, T_END, Q, K, ALPHA)
    assert abs(th.surface_temperature().mean() / exact.max() - 1) < 2e-3
    assert np.max(np.abs(th.T - exact)) / exact.max() < 1e-2
    # energy: 1^T M T gains sum(P) dt to round-off
    assert abs(th.energy_residual()) < 1e-12 * th.heat_in


def test_space_order_two():
    """Uniform refinement of the graded mesh (every cell split in two), CN with steps far
    below the spatial error: observed order of the max nodal error 2.0 (measured 1.99,
    2.00)."""
    errs = []
    for nref in range(3):
        m = column(nref)
        th = run_flux(m, n=2000)
        ex = semi_infinite_flux(-m.p[1], T_END, Q, K, ALPHA)
        errs.append(np.max(np.abs(th.T - ex)) / ex.max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.9), (errs, orders)


@pytest.mark.parametrize("theta, order", [(1.0, 1.0), (0.5, 2.0)])
def test_time_order(theta, order):
    """Against a reference with 3200 CN steps on the same mesh (time error only):
    backward Euler 1.00, Crank-Nicolson with Rannacher start-up 2.00 (measured)."""
    m = column(1)
    ref = run_flux(m, 0.5, 3200).T
    errs = [np.max(np.abs(run_flux(m, theta, n).T - ref)) / ref.max() for n in (25, 50, 100)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > order - 0.05), (errs, orders)


def test_step_temperature_erf_and_reaction():
    """Surface held at T_w from t = 0: T = T_w + (T0 - T_w) erf(z / 2 sqrt(alpha t)) within
    0.2 % of T_w - T0; the heat through the held nodes (reaction) closes the energy
    ledger to round-off; the heat absorbed, int rho c (T - T0) dV (the held nodes' own
    jump included), matches 2 k (T_w - T0) sqrt(t / (pi alpha)) per unit area to 0.5 %
    (measured 0.11 %)."""
    m = column(1)
    th = TransientHeat(m, K, RHO, C, 0.0, theta=0.5, startup=2, flux_group="bottom",
                       dirichlet={"top": 1.0})
    for _ in range(400):
        th.step(T_END / 400)
    ex = semi_infinite_step(-m.p[1], T_END, 1.0, 0.0, ALPHA)
    assert np.max(np.abs(th.T - ex)) < 2e-3
    assert abs(th.energy_residual()) < 1e-12 * abs(th.heat_dirichlet)
    # exact heat through the surface: 2 k (T_w - T0) sqrt(t / (pi alpha)) per unit area
    q_exact = 2 * K * math.sqrt(T_END / (math.pi * ALPHA)) * S
    assert np.sum(th.M @ th.T) == pytest.approx(q_exact, rel=5e-3)


def test_robin_implicit_limit_and_monotone():
    """A large exchange H (T_ext - T) at the surface (Biot number h sqrt(alpha t)/k =
    1000) tends to the held-temperature solution (measured max error 1.3e-3); taken
    implicitly (factorised once for a constant H), the surface never overshoots T_ext;
    the heat the steps report is what the energy gained (to round-off times the Biot
    number: F is a difference of terms ~H T)."""
    m = column(1)
    th = TransientHeat(m, K, RHO, C, 0.0, theta=1.0)
    H = 1e3 * K / S * th.surface_area
    for _ in range(400):
        heat = th.step(T_END / 400, robin=(H, 1.0))
        assert th.T.max() <= 1.0 + 1e-12
    ex = semi_infinite_step(-m.p[1], T_END, 1.0, 0.0, ALPHA)
    assert np.max(np.abs(th.T - ex)) < 5e-3
    assert th.factorisations == 1
    assert heat.sum() > 0 and abs(th.energy_residual()) < 1e-12 * th.heat_in * 1e3


def test_maximum_principle_simplex_lumped():
    """Heat into one surface node of a strongly stretched mesh (cells S/50 deep, 2S wide):
    P1 triangles + lumped capacity + backward Euler (an M-matrix) never go below T0; the
    consistent capacity, or stretched Q1 quads, do (measured minima -9 % and -25 % of the
    peak), the reason for the defaults."""
    mins = {}
    for simplex, lumped in ((True, True), (True, False), (False, True)):
        mesh = graded_mesh([(0.0, 4 * S)], 10 * S, S / 50, 1.1, h_lateral=2 * S,
                           simplex=simplex)
        th = TransientHeat(mesh, K, RHO, C, 0.0, theta=1.0, lumped=lumped)
        P = np.zeros(th.n_surface)
        P[np.argmin(np.abs(th.surface_points()[:, 0] - 2 * S))] = Q * S
        th.step(T_END / 400, power=P)
        mins[simplex, lumped] = th.T.min() / th.T.max()
    assert mins[True, True] >= 0.0
    assert mins[True, False] < -1e-2 and mins[False, True] < -1e-2


def test_energy_conserved_random_powers_3d():
    """Arbitrary nodal powers on a 3D hex mesh: E - E0 = sum P dt to round-off."""
    rng = np.random.default_rng(1)
    mesh = graded_mesh([(0.0, 2 * S), (0.0, 2 * S)], 5 * S, S / 10, 1.3, h_lateral=S)
    th = TransientHeat(mesh, K, RHO, C, 300.0, theta=0.5)
    total = 0.0
    for _ in range(20):
        P = rng.normal(size=th.n_surface) * 1e-3
        th.step(1e-8, power=P)
        total += P.sum() * 1e-8
    assert th.heat_in == pytest.approx(total, rel=1e-12)
    assert abs(th.energy_residual()) < 1e-9 * abs(total)
