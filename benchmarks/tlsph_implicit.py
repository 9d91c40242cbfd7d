"""TL-SPH Newton-Krylov against dynamic relaxation and velocity Verlet (issue 19, "TL-SPH";
figures in benchmarks/README.md).

    python benchmarks/tlsph_implicit.py static newton|relax   # 3D substrate, 3 warm solves
    python benchmarks/tlsph_implicit.py step3d FACTOR         # 3D implicit steps, cost
    python benchmarks/tlsph_implicit.py mode [mode|static]    # 2D bar, accuracy vs dt

``static``/``step3d``: the TL-SPH substrate of examples/droplet_impact/
droplet_impact_tlsph.toml (0.3 x 0.3 x 0.06 mm alumina, E = 300 GPa, dx = 10 um, clamped
sides; 5400 body particles + clamp layers = 7776) under a Gaussian pressure (10 MPa x s,
radius 50 um x (0.6 + 0.4 s)) and a heated spot (80 K x s, decaying over 10 um), s = 0.5,
0.6, 0.8 in turn, each solve warm-started from the previous one.  ``mode``: a clamped
alumina bar (plane strain, 40 x 6 particles at dx = 10 um) released from its static tip
deflection (``static``: every mode excited) or from its lowest mode shape (``mode``,
inverse iteration) at the same tip deflection; tip deflection over two periods against
velocity Verlet at 0.8/16 of the explicit limit.  Run with NUMBA_NUM_THREADS=1.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from sphfem.solid import implicit
from sphfem.solid.backend import TLSPHSubstrate
from sphfem.solid.body import SolidBody
from sphfem.solid.constitutive import lame
from sphfem.solid.integrate import verlet_step
from sphfem.solid.lattice import box_lattice

E, NU, RHO, DX = 300e9, 0.21, 3950.0, 10e-6


def substrate(**kw):
    return TLSPHSubstrate((-0.15e-3, -0.15e-3, -0.06e-3), (0.15e-3, 0.15e-3, 0.0), DX,
                          E, NU, 8.1e-6, T0=293.15, rho=RHO,
                          clamps=("left", "right", "front", "back"), **kw)


def loads(sub, s):
    pts = sub.body.ref.X[sub.face_layer["top"]]
    a = 50e-6 * (0.6 + 0.4 * s)
    p = 10e6 * s * np.exp(-(pts[:, 0] ** 2 + pts[:, 1] ** 2) / a**2)
    F = np.zeros_like(pts)
    F[:, 2] = -p * DX**2

    def dT(Y):
        return 80.0 * s * np.exp(-(Y[0] ** 2 + Y[1] ** 2) / a**2) * np.exp(Y[2] / 10e-6)

    return dT, (pts, F)


def static(solver):
    sub = substrate(solver=solver)
    for s in (0.5, 0.6, 0.8):
        dT, pf = loads(sub, s)
        t = time.process_time()
        r = sub.solve(dT_nodal=dT, point_forces=pf, snap="top")
        print(f"s {s}: steps {r.info['steps']} (newton {r.info.get('newton')}, krylov "
              f"{r.info.get('krylov')}), CPU {time.process_time() - t:.2f} s, residual "
              f"{r.info['residual']:.2e}, vM max {r.von_mises.max():.7e} Pa", flush=True)


def step3d(fac):
    sub = substrate()
    b = sub.body
    dT, pf = loads(sub, 0.5)
    sub._set_loads(dT, None, pf, "top")
    lim = b.stable_dt(1.0)
    b.a = b.accelerations()
    n = int(round(30 * lim / (fac * lim)))
    t = time.process_time()
    for _ in range(n):
        if fac < 1:
            verlet_step(b, fac * lim)
        else:
            info = implicit.newmark_step(b, fac * lim, tol=1e-9)
            print(f"  newton {info['newton']}, krylov {info['krylov']}", flush=True)
    print(f"{fac} x limit ({lim:.3e} s): {n} steps over 30 limits, CPU "
          f"{time.process_time() - t:.2f} s")


def _bar(L=40, H=6):
    X = box_lattice((-3 * DX, 0.0), (L * DX, H * DX), DX)
    lam, mu = lame(E, NU)
    b = SolidBody(X, DX * DX, RHO, lam, mu, 0.0, DX)
    b.clamp(X[:, 0] < 0)
    tip = X[:, 0] > (L - 1) * DX
    b.f_ext[tip] = (0.0, -1e6 * DX * H / tip.sum())
    return b, tip


def mode(start="mode"):
    def released():
        b, tip = _bar()
        implicit.static_solve(b, tol=1e-7)
        if start == "mode":  # inverse iteration to the lowest mode, same tip deflection
            for _ in range(8):
                b.f_ext[:] = b.m[:, None] * b.u / abs(b.u[tip, 1].mean()) * 0.1
                b.f_ext[b.fixed] = 0.0
                implicit.static_solve(b, tol=1e-7)
            b.f_ext *= 2.4e-7 / abs(b.u[tip, 1].mean())
            implicit.static_solve(b, tol=1e-7)
        b.f_ext[:] = 0.0
        b.__dict__.pop("_nk_precond", None)
        b.a = b.accelerations()
        return b, tip

    b, tip = released()
    lim = 2.0 / b.omega_max()
    u0 = abs(b.u[tip, 1].mean())

    def run(step, dt, T):
        b, tip = released()
        n = int(round(T / dt))
        out = [b.u[tip, 1].mean()]
        c = time.process_time()
        for _ in range(n):
            step(b, dt)
            out.append(b.u[tip, 1].mean())
        return np.linspace(0, T, n + 1), np.array(out), time.process_time() - c

    def period(t, u):
        k = np.flatnonzero(np.diff(np.sign(u)) > 0)
        tc = t[k] - u[k] * (t[k + 1] - t[k]) / (u[k + 1] - u[k])
        return tc[1] - tc[0]

    tr, ur, _ = run(verlet_step, 0.8 * lim / 16, 3200 * lim)
    Tr = period(tr, ur)
    T = 2 * Tr
    tr, ur, _ = run(verlet_step, 0.8 * lim / 16, T)
    print(f"limit {lim:.4e} s, lowest period {Tr:.4e} s = {Tr / lim:.0f} limits")

    def report(name, step, dt):
        t, u, cpu = run(step, dt, T)
        err = np.max(np.abs(u - np.interp(t, tr, ur))) / u0
        print(f"{name}: {len(t) - 1} steps, max tip error {err:.2e} of the amplitude, "
              f"period error {period(t, u) / Tr - 1:+.1e}, CPU {cpu:.2f} s", flush=True)

    report("verlet 0.8 x", verlet_step, 0.8 * lim)
    for f in (1, 2, 5, 10, 20, 40, 80):
        report(f"implicit {f} x", lambda b, d: implicit.newmark_step(b, d, tol=1e-9), f * lim)


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "static":
        static(sys.argv[2])
    elif what == "step3d":
        step3d(float(sys.argv[2]))
    else:
        mode(sys.argv[2] if len(sys.argv) > 2 else "mode")
