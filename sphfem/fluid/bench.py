"""Throughput of a full fluid step (``run_fluid_bench``): 3D dam break, 2D dam break, 3D droplet.

Cases (:data:`CASES`): ``dambreak3d`` (below), ``dambreak2d`` (PySPH's dam_break_2d
geometry: 1 x 2 column in a 4 x 4 tank) and ``droplet3d`` (a ball of fluid moving at 1 m/s
onto a wall block, c0 = 20 m/s); the same timings for each.

Set-up: a water column (a x a x 2a, cell-centred lattice, spacing dx) at rest in a tank
2a x a x 2.2a with 3 layers of Adami wall particles, Wendland C2 kernel, support R = 3 dx
(the thesis' setting, ~110 neighbours within R per interior particle), Verlet list of radius
1.15 R, delta = 0.1, laminar viscosity, gravity.  After a warm-up (compilation and a few steps)
the benchmark times, each as the minimum over repeats:

* ``step_s``: one full step (predictor, wall extrapolation, density-gradient pass,
  force/continuity pass, corrector, guards) without a neighbour rebuild;
* ``build_s``: one neighbour rebuild (cell sort excluded, it runs every 10th rebuild);

and reports

* ``pairs``: directed interacting pairs (r < R) per step -- rows of fluid particles (all
  neighbours) and of wall particles (fluid neighbours; the wall rows of the list are filtered
  to these); ``list_pairs``: pairs in the (skin-enlarged, filtered) list;
* ``pairs_per_s = pairs / step_s``: pair interactions per second of a full fluid step;
* ``particle_steps_per_s = n / step_s`` (all particles, walls included) and the same with the
  neighbour search amortised over ``rebuild_every`` steps (4: a dam-break front at 0.2 c0
  moves skin R / 2 in about 4 steps at the acoustic CFL);
* ``search_share = build_s / (rebuild_every step_s + build_s)`` and ``search_share_every_step``;
* ``cpu_*``: the same from the minimum process CPU time (all threads; on a shared machine the
  stable figure on 1 thread);
* ``pass_cpu_ms``: process CPU time of each kernel of a force evaluation called alone with
  the solver's arrays (minimum over repeats): prepare (EOS + packing of per-particle data),
  Adami wall state, density-gradient pass (with the row compaction), force pass, and
  ``compact_rows`` (the compaction alone, run instead of the density-gradient pass when
  delta = 0).

Run ``python -m sphfem.fluid.bench [CASE] [--quick] [--sizes N ...] [--threads T ...]
[--json FILE]`` or ``sphfem bench dambreak2d | droplet3d [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from sphfem.fluid import passes
from sphfem.fluid.setup import (
    box_walls,
    droplet_packing,
    hydrostatic_density,
    lattice,
    make_particles,
)
from sphfem.fluid.walls_adami2012 import adami_wall_state
from sphfem.fluid.wcsph import FluidParams, FluidSolver
from sphfem.machine import machine_info
from sphfem.particles import FLUID

REBUILD_EVERY = 4


def dambreak3d(n_fluid: int, a: float = 0.146, g: float = 9.81):
    """Solver of a 3D dam-break block with about ``n_fluid`` fluid particles."""
    dx = a / round((n_fluid / 2.0) ** (1.0 / 3.0))
    c0 = 10 * np.sqrt(2 * g * a)
    xf = lattice([0.0, 0.0, 0.0], [a, a, 2 * a], dx)
    xw = box_walls([0.0, 0.0, 0.0], [2 * a, a, 2.2 * a], dx, 3)
    rhof = hydrostatic_density(2 * a - xf[:, 2], 1000.0, c0, g)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    par = FluidParams(c0=c0, gravity=(0.0, 0.0, -g), threads=numba.get_num_threads())
    m = 4 * dx
    return FluidSolver(ps, 3 * dx, [-m] * 3, [2 * a + m, a + m, 2.2 * a + m], params=par)


def dambreak2d(n_fluid: int, g: float = 9.81):
    """Solver of PySPH's 2D dam break (1 x 2 column in a 4 x 4 tank, 3 wall layers) with
    about ``n_fluid`` fluid particles, R = 3 dx."""
    dx = np.sqrt(2.0 / n_fluid)
    H = 2.0
    c0 = 10 * np.sqrt(2 * g * H)
    xf = lattice([0.0, 0.0], [1.0, H], dx)
    xw = box_walls([0.0, 0.0], [4.0, 4.0], dx, 3)
    rhof = hydrostatic_density(H - xf[:, 1], 1000.0, c0, g)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    par = FluidParams(c0=c0, gravity=(0.0, -g), threads=numba.get_num_threads())
    m = 4 * dx
    return FluidSolver(ps, 3 * dx, [-m, -m], [4.0 + m, 4.0 + m], params=par)


def droplet3d(n_fluid: int, r0: float = 0.01, v0: float = 1.0):
    """Solver of a 3D droplet (a ball of radius ``r0`` of about ``n_fluid`` particles)
    moving at ``v0`` onto a wall block (4 r0 x 4 r0, 3 layers), R = 3 dx, c0 = 20 v0, no
    gravity; it touches the block from the first step."""
    dx = r0 * (4.0 * np.pi / 3.0 / n_fluid) ** (1.0 / 3.0)
    xf = droplet_packing(3, r0, dx)
    xf[:, 2] += r0 + 0.5 * dx
    xw = lattice([-2 * r0, -2 * r0, -3 * dx], [2 * r0, 2 * r0, 0.0], dx)
    ps = make_particles(xf, xw, dx, 1000.0)
    par = FluidParams(c0=20.0 * v0, gravity=(0.0, 0.0, 0.0), threads=numba.get_num_threads())
    s = FluidSolver(ps, 3 * dx, [-2 * r0 - 4 * dx, -2 * r0 - 4 * dx, -8 * dx],
                    [2 * r0 + 4 * dx, 2 * r0 + 4 * dx, 3 * r0], params=par)
    s.p.v[s.p.kind == FLUID, 2] = -v0
    s.evaluate()
    return s


#: cases of :func:`run_fluid_bench`: name -> (builder, quick sizes, full sizes)
CASES = {
    "dambreak3d": (dambreak3d, (20_000,), (100_000, 500_000)),
    "dambreak2d": (dambreak2d, (20_000,), (100_000, 400_000)),
    "droplet3d": (droplet3d, (20_000,), (100_000,)),
}


def _min_time(fn, repeats):
    """(minimum wall s, minimum process CPU s) over ``repeats`` calls."""
    best = np.inf
    best_cpu = np.inf
    for _ in range(repeats):
        c0 = time.process_time()
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best, best_cpu


def pass_profile(s: FluidSolver, repeats: int = 5) -> dict:
    """Process CPU time [ms] of each kernel of a force evaluation of ``s``, each called alone
    as :meth:`FluidSolver.evaluate` calls it (minimum over ``repeats``; the state is left
    unchanged: every kernel recomputes its outputs from the same inputs)."""
    p, sc, pa, nl = s.p, s._scratch, s.params, s.nbrs
    g = s.gravity
    nb = np.empty_like(nl.indices)
    cnt = np.zeros(p.n, dtype=np.int64)
    delta_coef = pa.delta * s.h * pa.c0

    def prepare():
        passes.prepare_fluid(p.rho, p.m, p.v, p.kind, pa.rho0, s.B, pa.gamma, p.p, sc.vg)
        passes.prepare_all(p.rho, p.p, p.m, p.vol, p.kind, sc.pr, sc.V, sc.meff, sc.isf)
        passes.pack_rows(p.x, p.v, sc.vg, p.rho, sc.pr, sc.V, sc.meff, sc.isf, p.mu, sc.grad,
                         sc.P)

    kernels = {
        "prepare": prepare,
        "adami_wall_state": lambda: adami_wall_state(
            p.x, p.v, p.rho, p.p, p.acc, p.kind, nl.offsets, nl.indices, s.R, s.kernel_code,
            s.period, g, pa.rho0, s.B, pa.gamma, sc.vg),
        "density_gradient": lambda: passes.density_gradient(
            p.x, p.rho, sc.V, p.kind, nl.offsets, nl.indices, s.R, s.sigma, s.kernel_code,
            s.period, pa.cond_max, sc.grad, sc.ok, nb, cnt),
        "fluid_forces": lambda: passes.fluid_forces(
            sc.P, p.kind, nl.offsets, cnt, nb, s.R, s.sigma, s.kernel_code, s.period, g,
            pa.eps_visc * s.h * s.h, delta_coef, pa.alpha * s.h * pa.c0, p.acc, p.drho,
            p.f_fluid),
        "compact_rows": lambda: passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices,
                                                    s.R, s.period, nb, cnt),
    }
    out = {}
    for name, fn in kernels.items():
        out[name] = round(_min_time(fn, repeats)[1] * 1e3, 3)
    s.evaluate()  # leave the solver's state exactly as an evaluation does
    return out


def bench_one(n_fluid: int, threads: int, repeats: int = 5, case: str = "dambreak3d") -> dict:
    numba.set_num_threads(threads)
    s = CASES[case][0](n_fluid)
    dt, _ = s.stable_dt()
    for _ in range(2):
        s.step(dt)
        s.check()
    s.params.skin = 10.0  # no rebuild inside the timed steps

    def one_step():
        s.step(dt)
        s.check()

    step_s, cpu_step_s = _min_time(one_step, repeats)
    parts = pass_profile(s, repeats)
    s.params.skin = FluidParams.skin
    s.params.sort_every = 0
    build_s, cpu_build_s = _min_time(s.rebuild_neighbors, max(2, repeats // 2))
    nl = s.nbrs
    x = s.p.x
    counts_in_R = _pairs_within(x, nl.offsets, nl.indices, s.R, s.p.kind)
    n = s.p.n
    amort = step_s + build_s / REBUILD_EVERY
    return {
        "case": case, "dim": s.dim,
        "n_fluid": int((s.p.kind == FLUID).sum()), "n_total": int(n), "threads": threads,
        "step_s": step_s, "build_s": build_s, "cpu_step_s": cpu_step_s,
        "cpu_build_s": cpu_build_s, "cpu_pairs_per_s": counts_in_R / cpu_step_s,
        "cpu_particle_steps_per_s": n / cpu_step_s,
        "pairs": int(counts_in_R), "list_pairs": int(nl.n_pairs),
        "pairs_per_s": counts_in_R / step_s,
        "particle_steps_per_s": n / step_s,
        "particle_steps_per_s_with_search": n / amort,
        "search_share": build_s / (REBUILD_EVERY * step_s + build_s),
        "search_share_every_step": build_s / (step_s + build_s),
        "cpu_particle_steps_per_s_with_search": n / (cpu_step_s + cpu_build_s / REBUILD_EVERY),
        "cpu_search_share": cpu_build_s / (REBUILD_EVERY * cpu_step_s + cpu_build_s),
        "wall_s_split": {k: round(v, 4) for k, v in s.wall.items()},
        "pass_cpu_ms": parts,
    }


@numba.njit(cache=True)
def _pairs_within(x, offsets, indices, R, kind):
    n, dim = x.shape
    c = 0
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            s = 0.0
            for k in range(dim):
                d = x[j, k] - x[i, k]
                s += d * d
            if s < R * R:
                c += 1
    return c


def run_fluid_bench(quick: bool = False, case: str = "dambreak3d", sizes=None,
                    threads=(1, 2), verbose: bool = True) -> dict:
    """Fluid-step throughput of ``case`` (:data:`CASES`) on 1 and 2 threads (2e4 fluid
    particles quick; 1e5 and more full)."""
    if case not in CASES:
        raise ValueError(f"unknown fluid benchmark {case!r}; expected one of {tuple(CASES)}")
    if sizes is None:
        sizes = CASES[case][1] if quick else CASES[case][2]
    maxt = numba.config.NUMBA_NUM_THREADS
    old = numba.get_num_threads()
    out = {"benchmark": case, "machine": machine_info(), "rebuild_every": REBUILD_EVERY,
           "runs": []}
    try:
        for n in sizes:
            for t in sorted({min(max(1, k), maxt) for k in threads}):
                r = bench_one(n, t, repeats=3 if n > 200_000 else 5, case=case)
                out["runs"].append(r)
                if not verbose:
                    continue
                print(f"{case} n_fluid={r['n_fluid']:>7} n={r['n_total']:>7} threads={t}\n"
                      f"  wall: step {r['step_s'] * 1e3:8.2f} ms, build "
                      f"{r['build_s'] * 1e3:8.2f} ms, pairs/s {r['pairs_per_s']:.3e}, "
                      f"particle-steps/s {r['particle_steps_per_s']:.3e} (with search "
                      f"{r['particle_steps_per_s_with_search']:.3e}), search share "
                      f"{r['search_share']:.1%}\n"
                      f"  cpu:  step {r['cpu_step_s'] * 1e3:8.2f} ms, build "
                      f"{r['cpu_build_s'] * 1e3:8.2f} ms, pairs/s {r['cpu_pairs_per_s']:.3e}, "
                      f"particle-steps/s {r['cpu_particle_steps_per_s']:.3e} (with search "
                      f"{r['cpu_particle_steps_per_s_with_search']:.3e}), search share "
                      f"{r['cpu_search_share']:.1%}\n"
                      f"  passes (cpu ms): " + ", ".join(
                          f"{k} {v:.2f}" for k, v in r["pass_cpu_ms"].items()), flush=True)
    finally:
        numba.set_num_threads(old)
    out["machine"]["load_average_end"] = machine_info()["load_average"]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default="dambreak3d", choices=tuple(CASES))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--sizes", type=int, nargs="+", help="fluid particle counts")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    res = run_fluid_bench(args.quick, args.case, sizes=args.sizes, threads=args.threads)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2, default=float)


if __name__ == "__main__":
    main()
