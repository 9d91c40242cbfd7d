"""Robustness of the axisymmetric droplet impact at fine spacing (issue 16).

Water droplet D = 0.1 mm onto a rigid wall of 3 layers of Adami particles (the set-up of
droplet_crosscheck.py: lattice rings, surface R = 3 dx above the wall top z = 0, no gravity,
no surface tension), D/dx, V, c0 and mu from the command line.  Every 0.1 t_c it records the
deepest fluid position under the wall top (z_min / dx; the first lattice row sits at +0.5),
the pressure range / (rho V^2), the density range, the largest speed / V, the spread
diameter 2 max r / D, the wetted diameter 2 r_wall / D (rings within 1.5 dx of the wall) and
the rings with no fluid neighbour within the support radius R (``isolated``: ejected
rings).  A run is clean when z_min > -0.5 dx, no ring is isolated, no state is NaN and the
mass is unchanged.

    python examples/axisymmetric/impact_robustness.py --n 32 --v 10 --out n32_v10.json
    python examples/axisymmetric/impact_robustness.py --n 32 --v 10 --c0 1480 --tc 1

Measured cases and what they show: examples/axisymmetric/robustness_results.md.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))

import droplet_crosscheck as dc  # noqa: E402

COLUMNS = ("t/tc", "z_min/dx", "p_min/q", "p_max/q", "rho_min/rho0", "rho_max/rho0",
           "max|v|/V", "2 max r/D", "2 r_wall/D", "isolated")


def build(n, v, c0, mu, no_penetration=True, adaptive_h=True, half_width=None, **kw):
    """The droplet and the wall as an :class:`AxisymmetricFluid` (``kw``: more keywords)."""
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.wcsph import FluidParams
    from sphfem.particles import FLUID, WALL

    dx = dc.D / n
    hw = half_width or max(0.3e-3, 2.5 * dc.D)
    xf, xw = dc.lattice_sphere(dx, 2), dc.wall(dx, 2, hw)
    x = np.vstack([xf, xw])
    nf = len(xf)
    kind = np.r_[np.full(nf, FLUID), np.full(len(xw), WALL)].astype(np.int8)
    vel = np.zeros_like(x)
    vel[:nf, 1] = -v
    M = np.r_[2 * math.pi * xf[:, 0] * dc.RHO * dx * dx, np.zeros(len(xw))]
    nrm = np.zeros_like(x)
    nrm[nf:, 1] = 1.0
    pa = FluidParams(rho0=dc.RHO, c0=c0, mu=mu, delta=0.1, alpha=0.02)
    return AxisymmetricFluid(x, vel, np.full(len(x), dc.RHO), kind, M, dx * dx, 3 * dx, pa,
                             wall_normals=nrm, adaptive_h=adaptive_h,
                             no_penetration=no_penetration, **kw), dx


def row(f, dx, v):
    fl = f.fluid
    x, p, rho = f.x[fl], f.p[fl], f.rho[fl]
    q = dc.RHO * v * v
    d, _ = cKDTree(x).query(x, k=2)
    near = x[:, 1] < 1.5 * dx
    return (f.t * v / dc.D, x[:, 1].min() / dx, p.min() / q, p.max() / q, rho.min() / dc.RHO,
            rho.max() / dc.RHO, float(np.sqrt((f.v[fl] ** 2).sum(axis=1)).max()) / v,
            2 * x[:, 0].max() / dc.D, 2 * (x[near, 0].max() if near.any() else 0.0) / dc.D,
            int((d[:, 1] > 3 * dx).sum()))


def run(n, v, c0, mu, tc=4.0, verbose=True, **kw):
    """Run one case to ``tc`` t_c; returns the record (history rows, verdict, seconds)."""
    f, dx = build(n, v, c0, mu, **kw)
    m0 = f.total_mass()
    hist = [row(f, dx, v)]
    t0 = time.perf_counter()
    error = None

    def cb(s):
        hist.append(row(s, dx, v))
        if verbose:
            cols = zip(COLUMNS, hist[-1], strict=True)
            print(" ".join(f"{c}={x:.3g}" for c, x in cols), flush=True)

    try:
        f.run(tc * dc.D / v, cb, every=0.1 * dc.D / v)
    except (FloatingPointError, ValueError, MemoryError) as e:
        error = f"{type(e).__name__}: {e}"
    h = np.array(hist)
    clean = (error is None and h[:, 1].min() > -0.5 and h[:, 9].max() == 0
             and f.total_mass() == m0)
    return dict(n=n, v=v, c0=c0, mu=mu, dx=dx, fluid=int(f.fluid.sum()),
                wall=int((~f.fluid).sum()), steps=f.step_count,
                seconds=time.perf_counter() - t0, t_reached=f.t * v / dc.D, error=error,
                clean=bool(clean), z_min=float(h[:, 1].min()), isolated=int(h[:, 9].max()),
                p_min=float(h[:, 2].min()), mass_change=f.total_mass() / m0 - 1,
                corrections=getattr(f, "penetration_corrections", 0), options=kw,
                columns=COLUMNS, history=hist)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=32, help="D / dx")
    ap.add_argument("--v", type=float, default=10.0, help="impact speed [m/s]")
    ap.add_argument("--c0", type=float, default=None, help="speed of sound (default 10 V)")
    ap.add_argument("--mu", type=float, default=1e-3)
    ap.add_argument("--tc", type=float, default=4.0)
    ap.add_argument("--fixed-h", action="store_true")
    ap.add_argument("--h-mode", choices=("area", "mean-area"), default="area",
                    help="adaptive h from the ring's own area or the local mean area")
    ap.add_argument("--no-penetration-off", action="store_true")
    ap.add_argument("--no-fragment-hoop", action="store_true")
    ap.add_argument("--kw", action="append", default=[], metavar="KEY=VALUE",
                    help="more AxisymmetricFluid keywords (Python literals), repeatable")
    ap.add_argument("--out")
    a = ap.parse_args()
    extra = {k: ast.literal_eval(x) for k, x in (s.split("=", 1) for s in a.kw)}
    res = run(a.n, a.v, a.c0 or 10 * a.v, a.mu, a.tc, adaptive_h=False if a.fixed_h else a.h_mode,
              no_penetration=not a.no_penetration_off,
              fragment_hoop=not a.no_fragment_hoop, **extra)
    print(json.dumps({k: x for k, x in res.items() if k not in ("history", "columns")}))
    if a.out:
        with open(a.out, "w") as fh:
            json.dump(res, fh)


if __name__ == "__main__":
    main()
