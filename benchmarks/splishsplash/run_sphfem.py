"""sphfem on SPlisHSPlasH's DamBreakModel geometry; prints its timing as one JSON line.

The same scene as ``run_splishsplash.py`` (1 m fluid cube of SPlisHSPlasH's particle
positions, 4 x 3 x 1.5 m tank, rho0 = 1000, nu = 0.01 m^2/s, g = 9.81) with sphfem's
``pressure = "dfsph"`` or ``"iisph"``, the same density-error (and divergence-error)
tolerance, and the same time-step rule: dt = min(0.4 (2r) / v_max, 5 ms) (SPlisHSPlasH's
CFL with cflFactor 1 and cflMaxTimeStepSize; sphfem's ``cfl`` set to 0.4 (2r) / h).
Axes: x along the tank, y across, z up (SPlisHSPlasH: y up).  Walls: R / (2r) layers of
wall particles on the tank's floor and four sides, open top (the flow stays below the 3 m lid
within the timed 1 s).  Kernel: sphfem's Wendland C2 at R = 3 dx (the project setting) or,
with ``--kernel cubic_spline --support 2``, SPlisHSPlasH's cubic spline at R = 4 r = 2 dx.

    NUMBA_NUM_THREADS=2 python run_sphfem.py --method dfsph --radius 0.0125 --stop-at 1

Timed: the stepping loop alone, after a compile/cache-load warm-up on a coarse copy of the
scene.  Per-phase seconds are the solver's own ``wall`` timers.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import sys
import time

import numpy as np

#: SPlisHSPlasH's tank [m] (UnitBox scaled 4 x 3 x 1.5, in sphfem axes x, y across, z up)
TANK_LO = (-2.0, -0.75, 0.0)
TANK_HI = (2.0, 0.75, 3.0)
#: SPlisHSPlasH's fluid block (start + translation, end + translation), sphfem axes
BLOCK_LO = (-1.95, -0.5, 0.05)
BLOCK_HI = (-0.95, 0.5, 1.05)
DT_MAX = 0.005
CFL_DIAMETERS = 0.4
NU = 0.01


def block_positions(radius: float) -> np.ndarray:
    """SPlisHSPlasH's denseMode-0 fluid block: per axis round(L / 2r) - 1 particles at
    lo + 2r + j 2r (SimulatorBase::createFluidBlocks)."""
    d = 2.0 * radius
    axes = []
    for lo, hi in zip(BLOCK_LO, BLOCK_HI, strict=True):
        m = int(round((hi - lo) / d)) - 1
        axes.append(lo + d + d * np.arange(m))
    g = np.meshgrid(*axes, indexing="ij")
    return np.ascontiguousarray(np.stack([c.ravel() for c in g], axis=1))


def build(method: str, radius: float, tol: float, tol_v: float, kernel: str,
          support: float, threads: int, extra: dict | None = None):
    """The solver of the scene (fluid at rest at rho0 with the hydrostatic pressure as the
    first solve's start)."""
    from sphfem.fluid import FluidParams, FluidSolver
    from sphfem.fluid.setup import box_walls, make_particles
    from sphfem.particles import FLUID

    d = 2.0 * radius
    rho0, g = 1000.0, 9.81
    xf = block_positions(radius)
    xw = box_walls(TANK_LO, TANK_HI, d, int(np.ceil(support - 1e-9)), open_top=True)
    ps = make_particles(xf, xw, d, rho0)
    R = support * d
    keys = {"dfsph": {"dfsph_tolerance": tol, "dfsph_divergence_tolerance": tol_v},
            "iisph": {"iisph_tolerance": tol}}[method]
    keys.update(extra or {})
    par = FluidParams(rho0=rho0, mu=rho0 * NU, gravity=(0.0, 0.0, -g), pressure=method,
                      cfl=CFL_DIAMETERS * d / (0.5 * R), threads=threads, **keys)
    m = 4 * d
    lo = [a - m for a in TANK_LO]
    hi = [b + m for b in TANK_HI]
    s = FluidSolver(ps, R, lo, hi, params=par, kernel=kernel)
    fl = s.p.kind == FLUID
    top = float(xf[:, 2].max()) + radius
    s.p.p[fl] = rho0 * g * (top - s.p.x[fl, 2])
    return s


def step_to(s, t_end: float) -> None:
    """Steps of dt = min(CFL step of sphfem (cfl set to SPlisHSPlasH's), DT_MAX) to t_end."""
    while s.t < t_end * (1 - 1e-12):
        lim = s.dt_limits()
        dt = min(lim.get("cfl", DT_MAX), DT_MAX, t_end - s.t)
        s.step(dt)
        s.check()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", choices=("dfsph", "iisph"), default="dfsph")
    ap.add_argument("--radius", type=float, default=0.0125)
    ap.add_argument("--stop-at", type=float, default=1.0)
    ap.add_argument("--max-error", type=float, default=0.05, help="[%%]")
    ap.add_argument("--max-error-v", type=float, default=0.1, help="[%%] (DFSPH)")
    ap.add_argument("--kernel", default="wendland_c2")
    ap.add_argument("--support", type=float, default=3.0, help="R / (2 r)")
    ap.add_argument("--threads", type=int, default=int(os.environ.get("NUMBA_NUM_THREADS", 2)))
    ap.add_argument("--no-warmup", action="store_true")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="further FluidParams keys (e.g. dfsph_deficient_fraction=0.75)")
    a = ap.parse_args(argv)

    from sphfem.particles import FLUID

    extra = {}
    for kv in a.set:
        k, v = kv.split("=", 1)
        extra[k] = ast.literal_eval(v)  # a number (or other literal)
    args = (a.method, a.radius, a.max_error, a.max_error_v, a.kernel, a.support, a.threads,
            extra)
    if not a.no_warmup:  # numba compile / cache load on a coarse copy (16^3 fluid)
        w = build(a.method, 1.0 / 34, *args[2:])
        step_to(w, 5 * DT_MAX)
    s = build(*args)
    nf = int(np.count_nonzero(s.p.kind == FLUID))
    t0 = time.perf_counter()
    c0 = time.process_time()
    step_to(s, a.stop_at)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    log = s.pressure_state.log
    fl = s.p.kind == FLUID
    out = {"code": "sphfem", "method": a.method, "kernel": a.kernel, "support_dx": a.support,
           "fluid_particles": nf, "wall_particles": int(s.p.n - nf), "radius": a.radius,
           "t_end": s.t, "steps": s.step_count, "neighbor_rebuilds": s.n_rebuilds,
           "wall_s": wall, "cpu_s": cpu,
           "threads": a.threads, "mean_dt": s.t / s.step_count,
           "it_mean": float(np.mean(log.iterations)), "it_max": int(max(log.iterations)),
           "density_err_max_pct": 100 * float(max(log.density_error)),
           "not_converged": int(log.not_converged),
           "particle_steps_per_s": nf * s.step_count / wall,
           "tolerance_pct": a.max_error,
           "divergence_tolerance_pct": a.max_error_v if a.method == "dfsph" else None,
           "z_max": float(s.p.x[fl, 2].max()), "x_front": float(s.p.x[fl, 0].max()),
           "phase_s": {k: float(v) for k, v in s.wall.items()}}
    if log.divergence_iterations:
        out["div_it_mean"] = float(np.mean(log.divergence_iterations))
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
