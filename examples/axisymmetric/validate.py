"""Validation tables of the axisymmetric heat and fluid modules (issue 16): error and wall
time per resolution.

    python examples/axisymmetric/validate.py heat      # cylinder vs Bessel modes, a/dx = 10..80
    python examples/axisymmetric/validate.py pipe      # Hagen-Poiseuille start-up, a/dx = 10..40
    python examples/axisymmetric/validate.py column    # hydrostatic column, H/dx = 20, 40

The set-ups are those of tests/test_heat_axisymmetric.py and tests/test_fluid_axisymmetric.py
(imported from there); times include the neighbour search, not numba's compilation (a
warm-up run at the coarsest resolution is made first).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))


def heat():
    from test_heat_axisymmetric import cylinder_error

    cylinder_error(10, True)
    print("a/dx  particles  form        L2 (r-weighted)  Linf      order(L2)  seconds")
    for norm in (False, True):
        prev = None
        for N in (10, 20, 40, 80):
            t0 = time.perf_counter()
            l2, linf = cylinder_error(N, norm)
            sec = time.perf_counter() - t0
            o = f"{math.log2(prev / l2):5.2f}" if prev else "    -"
            print(f"{N:4d}  {N * N:9d}  {'normalised' if norm else 'plain':10s}  {l2:.3e}"
                  f"        {linf:.3e}  {o}      {sec:7.2f}")
            prev = l2


def pipe():
    from test_fluid_axisymmetric import poiseuille_error

    poiseuille_error(10, 0.01)
    print("a/dx  t nu/a^2  L2 (r-weighted)  order  seconds")
    for ts in (0.1, 0.5):
        prev = None
        for N in (10, 20, 40):
            t0 = time.perf_counter()
            e = poiseuille_error(N, ts)
            sec = time.perf_counter() - t0
            o = f"{math.log2(prev / e):5.2f}" if prev else "    -"
            print(f"{N:4d}  {ts:8.2f}  {e:.3e}        {o}  {sec:7.1f}")
            prev = e


def column():
    from test_fluid_axisymmetric import column as col

    from sphfem.axisymmetric import ring_mass
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.eos import density
    from sphfem.fluid.wcsph import FluidParams
    from sphfem.particles import FLUID, WALL

    a, H, g = 0.1, 0.2, 9.81
    print("H/dx  fluid  t sqrt(g/H)  L2/(rho g H)  Linf/(rho g H)  max|v|/sqrt(gH)  seconds")
    for N in (20, 40):
        dx = H / N
        xf, xw = col(a, H, dx)
        c0 = 10 * math.sqrt(g * H)
        pa = FluidParams(rho0=1000.0, c0=c0, mu=0.01, delta=0.1, alpha=0.02,
                         gravity=(0.0, -g))
        rhof = density(1000 * g * (H - xf[:, 1]), 1000.0, c0)
        x = np.vstack([xf, xw])
        kind = np.r_[np.full(len(xf), FLUID), np.full(len(xw), WALL)].astype(np.int8)
        M = np.r_[ring_mass(xf[:, 0], rhof, dx * dx), np.zeros(len(xw))]
        t0 = time.perf_counter()
        f = AxisymmetricFluid(x, np.zeros_like(x), np.r_[rhof, np.full(len(xw), 1000.0)],
                              kind, M, dx * dx, 3 * dx, pa)
        f.run(0.5)
        sec = time.perf_counter() - t0
        fl = f.fluid
        e = (f.p[fl] - 1000 * g * (H - f.x[fl, 1])) / (1000 * g * H)
        print(f"{N:4d}  {len(xf):5d}  {0.5 * math.sqrt(g / H):10.2f}  "
              f"{math.sqrt(np.mean(e**2)):.3e}     {np.abs(e).max():.3e}       "
              f"{np.abs(f.v[fl]).max() / math.sqrt(g * H):.2e}         {sec:7.1f}")


if __name__ == "__main__":
    {"heat": heat, "pipe": pipe, "column": column}[sys.argv[1]]()
