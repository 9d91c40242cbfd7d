"""Elastodynamic substrate (HHT-alpha / Newmark) against exact solutions.

A constrained 1D bar: a plane-strain strip of length L with rollers on its long sides (u_y =
0), clamped at x = 0; longitudinal waves travel at c_P = sqrt((lam + 2 mu) / rho).

* step traction at x = L: the exact solution before the reflection reaches the station is
  u(x, t) = -(p / (rho c_P)) (t - (L - x) / c_P)_+, sigma_xx = -p behind the front;
* first mode of the fixed-free bar: period 4 L / c_P; the trapezoidal rule's period of a
  mode of frequency w is 2 pi dt / (2 arctan(w dt / 2)) (Hughes 2000, sec. 9.3): error
  (w dt)^2 / 12, second order;
* zero load: the energy 1/2 v.Mv + 1/2 u.Ku of the average-acceleration rule is conserved
  to round-off (3D tets, plane strain, axisymmetric);
* a load ramped over t_r and held: every mode of period T_k oscillates about the static
  answer with relative amplitude |sin(pi t_r/T_k)| / (pi t_r/T_k) <= T_1 / (pi t_r); at the
  loaded tip all modal contributions have one sign, so |u - u_qs| / u_qs <= T_1 / (pi t_r).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.linalg import eigsh
from skfem import MeshQuad, MeshTet

from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, graded_tensor_rz
from sphfem.fem.elastodynamic import (
    ElastodynamicSubstrate,
    quasi_static_check,
    ramp_amplification,
    wave_speeds,
)
from sphfem.fem.substrate import FEMSubstrate

E, NU, RHO, L = 2.5, 0.25, 1.0, 1.0  # c_P = 2 (lam + 2 mu = 3 E / 1.875 ... see CP below)
CP = wave_speeds(E, NU, RHO)["P"]


def bar(n: int, hht_alpha: float = 0.0):
    m = MeshQuad.init_tensor(np.linspace(0, L, n + 1), np.array([0.0, L / n])).with_defaults()
    sub = FEMSubstrate(m, E, NU, 0.0, clamps=["left"], rollers={"bottom": "y", "top": "y"})
    return sub, ElastodynamicSubstrate(sub, RHO, hht_alpha=hht_alpha)


def tip_dof(sub):
    i = int(np.argmax(sub.mesh.p[0] + sub.mesh.p[1]))
    return sub.basis.nodal_dofs[0, i]


def test_wave_speeds_and_rayleigh():
    c = wave_speeds(300e9, 0.21, 3950.0)
    mu = 300e9 / 2.42
    assert c["S"] == pytest.approx(np.sqrt(mu / 3950.0), rel=1e-14)
    assert c["P"] == pytest.approx(np.sqrt((300e9 * 0.21 / (1.21 * 0.58) + 2 * mu) / 3950),
                                   rel=1e-14)
    # nu = 1/4: c_R / c_S = sqrt(2 - 2 / sqrt(3)) exactly (Rayleigh 1885)
    c4 = wave_speeds(1.0, 0.25, 1.0)
    assert c4["R"] / c4["S"] == pytest.approx(np.sqrt(2 - 2 / np.sqrt(3)), rel=1e-10)
    assert ramp_amplification(0.0, 1.0) == 2.0 and ramp_amplification(2.0, 1.0) == 1.0


def step_wave(n: int, p: float):
    """Step traction -p at x = L from rest, Courant number 0.5, until 1.4 L / c_P: times,
    u_x and sigma_xx at the station (L/2, h/2), and h."""
    sub, dyn = bar(n)
    h = L / n
    dt = 0.5 * h / CP
    xs = np.array([[0.5 * L, 0.5 * h]])
    ts, us, ss = [], [], []
    for _ in range(int(1.4 * L / CP / dt)):
        pr = dyn.step(dt, tractions={"right": np.array([-p, 0.0])}).probe(xs)
        ts.append(dyn.t)
        us.append(pr["u"][0, 0])
        ss.append(pr["stress"][0, 0, 0])
    return np.asarray(ts), np.asarray(us), np.asarray(ss), h


def test_step_traction_wave_arrival_and_plateau():
    """Step traction p at x = L: displacement history at x = L/2 within 2 % (L2 over the
    window before the reflection), the stress front (sigma = -p/2) within 2 h / c_P of
    L / (2 c_P), the mean stress behind it within 1 % of -p."""
    p = 1e-3
    t, u, s, h = step_wave(200, p)
    u_ex = -(p / (RHO * CP)) * np.maximum(t - 0.5 * L / CP, 0.0)
    assert np.linalg.norm(u - u_ex) / np.linalg.norm(u_ex) < 0.02
    t_arr = t[np.argmax(s < -0.5 * p)]
    assert abs(t_arr - 0.5 * L / CP) < 2 * h / CP
    plateau = (t > 0.5 * L / CP + 0.1 * L / CP)
    assert s[plateau].mean() == pytest.approx(-p, rel=0.01)


def _period(dyn, sub, dt, n_periods, T):
    """Period of the tip displacement y_n of a one-mode motion: y_n = A cos(w~ n dt + phi)
    satisfies y_{n+1} + y_{n-1} = 2 cos(w~ dt) y_n, fitted by least squares."""
    k = tip_dof(sub)
    y = [dyn.u[k]]
    for _ in range(int(np.ceil(n_periods * T / dt))):
        dyn.advance(dt, np.zeros(sub.basis.N))
        y.append(dyn.u[k])
    y = np.asarray(y)
    cos_wdt = (y[1:-1] @ (y[2:] + y[:-2])) / (2.0 * y[1:-1] @ y[1:-1])
    return 2.0 * np.pi * dt / np.arccos(cos_wdt)


def test_first_mode_period_and_second_order_in_time():
    """Semi-discrete first period vs 4 L / c_P within (k h)^2 / 24 x 1.25 (P1 consistent
    mass, k = pi / 2L); the Newmark period vs its exact value 2 pi dt / (2 atan(w dt/2))
    to 1e-9; the period error's observed order in dt within 0.1 of 2."""
    n = 80
    sub, dyn = bar(n)
    I = sub.I
    w2, V = eigsh(sub.K[I][:, I].tocsc(), k=1, M=dyn.M[I][:, I].tocsc(), sigma=0)
    w = float(np.sqrt(w2[0]))
    T_h, T_exact = 2 * np.pi / w, 4 * L / CP
    kh = np.pi / (2 * L) * (L / n)
    assert abs(T_h - T_exact) / T_exact < 1.25 * kh ** 2 / 24
    u0 = sub.basis.zeros()
    u0[I] = V[:, 0]
    errs = []
    for m in (16, 32, 64):
        dt = T_h / m
        dyn.reset(u0=u0)
        T_nm = _period(dyn, sub, dt, 6, T_h)
        assert T_nm == pytest.approx(dt * np.pi / np.arctan(w * dt / 2), rel=1e-9)
        errs.append(abs(T_nm - T_h) / T_h)
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.1), orders
    assert abs(T_nm - T_exact) / T_exact < 2e-3  # dt = T/64: (2 pi / 64)^2 / 12 = 8e-4


def _energy_run(sub, dyn, steps, dt, seed=0):
    rng = np.random.default_rng(seed)
    dyn.reset(u0=rng.standard_normal(sub.basis.N) * 1e-6,
              v0=rng.standard_normal(sub.basis.N) * 1e-3)
    e0 = dyn.energy()["total"]
    es = []
    for _ in range(steps):
        dyn.advance(dt, np.zeros(sub.basis.N))
        es.append(dyn.energy()["total"])
    return e0, np.asarray(es)


@pytest.mark.parametrize("kind", ["plane", "tet", "axisymmetric", "lumped"])
def test_energy_conserved_without_load(kind):
    """Average acceleration, zero load, random initial state (all modes, w dt up to ~10):
    relative energy drift < 1e-11 over 300 steps; HHT (a = -0.1) dissipates the unresolved
    modes (its 1/2 v.Mv + 1/2 u.Ku is not monotone step by step, only on average)."""
    if kind == "tet":
        m = MeshTet.init_tensor(*(np.linspace(0, 1, 5),) * 3).with_defaults()
        sub = FEMSubstrate(m, E, NU, 0.0, clamps=["left"])
    elif kind == "axisymmetric":
        m = graded_tensor_rz(1.0, 0.5, 0.1, 0.3, growth=1.3)
        sub = AxisymmetricFEMSubstrate(m, E, NU, 0.0, clamps=["bottom"])
    else:
        sub, _ = bar(40)
    mass = "lumped" if kind == "lumped" else "consistent"
    dt = 0.2 * L / CP
    dyn = ElastodynamicSubstrate(sub, RHO, mass=mass)
    e0, es = _energy_run(sub, dyn, 300, dt)
    assert np.max(np.abs(es - e0)) / e0 < 1e-11
    damped = ElastodynamicSubstrate(sub, RHO, hht_alpha=-0.1, mass=mass)
    e0, es = _energy_run(sub, damped, 300, dt)
    assert es[-50:].max() < 0.9 * e0 and es[-50:].mean() < es[:50].mean()


def test_slow_ramp_tends_to_quasi_static():
    """Tip traction ramped over t_r = 2.5, 4.5, 8.5 T_1 (half-integer multiples, where the
    first mode's residual |sin(pi t_r/T_1)| / (pi t_r/T_1) is largest) and held 2 T_1:
    max |u_tip - u_qs| / u_qs over the hold <= T_1 / (pi t_r) (+2 % for the time
    discretisation) and decreasing."""
    n, p = 40, 1e-3
    sub, dyn = bar(n)
    k = tip_dof(sub)
    u_qs = sub.solve(tractions={"right": np.array([p, 0.0])}).dofs[k]
    T1 = 4 * L / CP
    dt = T1 / 200
    f1 = dyn.load_vector(tractions={"right": np.array([p, 0.0])})[0]
    devs = []
    for mult in (2.5, 4.5, 8.5):
        tr = mult * T1
        dyn.reset()
        dev = 0.0
        while dyn.t < tr + 2 * T1 - 1e-12:
            s = min(1.0, (dyn.t + dt) / tr)
            dyn.advance(dt, s * f1)
            if dyn.t >= tr - 1e-12:
                dev = max(dev, abs(dyn.u[k] - u_qs) / abs(u_qs))
        assert dev <= 1.02 * T1 / (np.pi * tr), (mult, dev)
        devs.append(dev)
    assert devs[0] > devs[1] > devs[2]


def test_variable_dt_refactorises_only_on_change():
    sub, dyn = bar(20)
    f = dyn.load_vector(tractions={"right": np.array([1e-3, 0.0])})[0]
    for dt in (0.01, 0.01, 0.02, 0.01, 0.02, 0.015):
        dyn.advance(dt, f)
    assert dyn.n_factorizations == 3 and dyn.t == pytest.approx(0.085)


def test_quasi_static_check_default_droplet():
    """Alumina 0.26 mm: 4h/c_S ~ 186 ns; a water-hammer pulse of R/c_f ~ 34 ns is dynamic,
    the contact time D/v = 2 us is quasi-static within 10 %."""
    chk = quasi_static_check(300e9, 0.21, 3950.0, 0.26e-3, 1e-3,
                             {"water hammer": 50e-6 / 1480.0, "contact": 1e-4 / 50.0})
    assert chk.period == pytest.approx(4 * 0.26e-3 / chk.speeds["S"], rel=1e-14)
    assert not chk.applies["water hammer"] and chk.applies["contact"]


def test_droplet_study_quasi_static_peak_is_the_half_space_value():
    """examples/droplet_impact/substrate_dynamics.py, quasi-static: the peak von Mises under
    the pressure patch (a = 2-4 um << the 0.26 mm layer) is the half-space value on the axis
    of a uniform circular pressure p (Johnson, *Contact Mechanics*, 1985, eq. 3.41:
    sigma_z = -p (1 - z^3/s^3), sigma_r = -p/2 [(1 + 2 nu) - 2 (1 + nu) z/s + z^3/s^3],
    s^2 = a^2 + z^2), max |sigma_z - sigma_r| = 0.708 p at z = 0.61 a for nu = 0.21; within
    3 % (element averages on a 1 um mesh)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples/droplet_impact/substrate_dynamics.py"
    spec = importlib.util.spec_from_file_location("substrate_dynamics", path)
    sd = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sd)
    z = np.linspace(1e-4, 5.0, 200001)
    s = np.sqrt(1.0 + z * z)
    vm = np.abs(-(1 - z**3 / s**3) + 0.5 * ((1 + 2 * sd.NU) - 2 * (1 + sd.NU) * z / s
                                            + z**3 / s**3))
    r = sd.run(1480.0, 1e-9, 3e-9, 1e-6)
    q = r["qs"]
    p = sd.load_history(1480.0)[1](q["t"])
    assert q["peak"] / p == pytest.approx(vm.max(), rel=0.03)
    assert q["r"] < 1e-6
