"""Figures of the elastodynamic validation (the cases of tests/test_elastodynamic.py),
printed: ``python docs/validation/substrate_dynamics/figures.py``."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from scipy.sparse.linalg import eigsh

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "tests"))
from test_elastodynamic import (  # noqa: E402
    CP,
    RHO,
    L,
    _energy_run,
    _period,
    bar,
    step_wave,
    tip_dof,
)

from sphfem.fem.elastodynamic import ElastodynamicSubstrate  # noqa: E402

# (a) step traction, station x = L/2, for three meshes at Courant number 0.5
print("(a) step wave: n, L2 error of u(L/2, t), arrival error / (h/c), plateau error, s")
for n in (50, 100, 200):
    t0 = time.perf_counter()
    p = 1e-3
    t, u, s, h = step_wave(n, p)
    u_ex = -(p / (RHO * CP)) * np.maximum(t - 0.5 * L / CP, 0.0)
    e = np.linalg.norm(u - u_ex) / np.linalg.norm(u_ex)
    t_arr = t[np.argmax(s < -0.5 * p)]
    pl = s[t > 0.6 * L / CP].mean() / -p - 1
    print(f"  {n:4d}  {e:.3e}  {(t_arr - 0.5 * L / CP) / (h / CP):+.2f}  {pl:+.2e}  "
          f"{time.perf_counter() - t0:.1f}")

# (b) first mode
n = 80
sub, dyn = bar(n)
I = sub.I
w2, V = eigsh(sub.K[I][:, I].tocsc(), k=1, M=dyn.M[I][:, I].tocsc(), sigma=0)
w = float(np.sqrt(w2[0]))
T_h, T_ex = 2 * np.pi / w, 4 * L / CP
print(f"(b) semi-discrete period error vs 4L/c: {(T_h - T_ex) / T_ex:.3e} "
      f"((kh)^2/24 = {(np.pi / (2 * n)) ** 2 / 24:.3e})")
u0 = sub.basis.zeros()
u0[I] = V[:, 0]
prev = None
for m in (16, 32, 64, 128):
    dyn.reset(u0=u0)
    T = _period(dyn, sub, T_h / m, 6, T_h)
    e = abs(T - T_h) / T_h
    print(f"  dt = T/{m}: period error {e:.3e}, vs 4L/c {(T - T_ex) / T_ex:+.3e}"
          + (f", order {np.log2(prev / e):.3f}" if prev else ""))
    prev = e

# (c) energy
for mass in ("consistent", "lumped"):
    sub, _ = bar(40)
    d = ElastodynamicSubstrate(sub, RHO, mass=mass)
    e0, es = _energy_run(sub, d, 300, 0.2 * L / CP)
    drift = np.max(np.abs(es - e0)) / e0
    print(f"(c) {mass}: max relative energy drift over 300 steps {drift:.2e}")

# (d) slow ramp
sub, dyn = bar(40)
k = tip_dof(sub)
u_qs = sub.solve(tractions={"right": np.array([1e-3, 0.0])}).dofs[k]
T1 = 4 * L / CP
f1 = dyn.load_vector(tractions={"right": np.array([1e-3, 0.0])})[0]
for mult in (2.5, 4.5, 8.5, 16.5):  # half-integer: the first mode's residual is largest
    tr = mult * T1
    dyn.reset()
    dev = 0.0
    while dyn.t < tr + 2 * T1 - 1e-12:
        dyn.advance(T1 / 200, min(1.0, (dyn.t + T1 / 200) / tr) * f1)
        if dyn.t >= tr - 1e-12:
            dev = max(dev, abs(dyn.u[k] - u_qs) / abs(u_qs))
    print(f"(d) t_r = {mult} T1: max |u - u_qs|/u_qs {dev:.3e} (bound T1/(pi t_r) "
          f"{T1 / (np.pi * tr):.3e})")
