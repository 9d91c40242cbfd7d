"""Throughput of a full fluid step on a 3D dam-break block (``run_fluid_bench``).

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
* ``search_share = build_s / (rebuild_every step_s + build_s)`` and ``search_share_every_step``.

Run ``python -m sphfem.fluid.bench [--quick] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from sphfem.fluid.setup import box_walls, hydrostatic_density, lattice, make_particles
from sphfem.fluid.wcsph import FluidParams, FluidSolver
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


def _min_time(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def bench_one(n_fluid: int, threads: int, repeats: int = 5) -> dict:
    numba.set_num_threads(threads)
    s = dambreak3d(n_fluid)
    dt, _ = s.stable_dt()
    for _ in range(2):
        s.step(dt)
        s.check()
    s.params.skin = 10.0  # no rebuild inside the timed steps

    def one_step():
        s.step(dt)
        s.check()

    step_s = _min_time(one_step, repeats)
    s.params.skin = FluidParams.skin
    s.params.sort_every = 0
    build_s = _min_time(s.rebuild_neighbors, max(2, repeats // 2))
    nl = s.nbrs
    x = s.p.x
    counts_in_R = _pairs_within(x, nl.offsets, nl.indices, s.R, s.p.kind)
    n = s.p.n
    amort = step_s + build_s / REBUILD_EVERY
    return {
        "n_fluid": int((s.p.kind == FLUID).sum()), "n_total": int(n), "threads": threads,
        "step_s": step_s, "build_s": build_s,
        "pairs": int(counts_in_R), "list_pairs": int(nl.n_pairs),
        "pairs_per_s": counts_in_R / step_s,
        "particle_steps_per_s": n / step_s,
        "particle_steps_per_s_with_search": n / amort,
        "search_share": build_s / (REBUILD_EVERY * step_s + build_s),
        "search_share_every_step": build_s / (step_s + build_s),
        "wall_s_split": {k: round(v, 4) for k, v in s.wall.items()},
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


def run_fluid_bench(quick: bool = False) -> dict:
    """Fluid-step throughput on 1 and 2 threads (sizes 2e4 quick; 1e5 and 5e5 full)."""
    from sphfem.bench import machine_info

    sizes = (20_000,) if quick else (100_000, 500_000)
    maxt = numba.config.NUMBA_NUM_THREADS
    old = numba.get_num_threads()
    out = {"machine": machine_info(), "runs": []}
    try:
        for n in sizes:
            for t in sorted({1, min(2, maxt)}):
                r = bench_one(n, t, repeats=3 if n > 200_000 else 5)
                out["runs"].append(r)
                print(f"n_fluid={r['n_fluid']:>7} n={r['n_total']:>7} threads={t} "
                      f"step={r['step_s'] * 1e3:8.1f} ms build={r['build_s'] * 1e3:8.1f} ms "
                      f"pairs/s={r['pairs_per_s']:.3e} particle-steps/s="
                      f"{r['particle_steps_per_s']:.3e} (with search "
                      f"{r['particle_steps_per_s_with_search']:.3e}) search share="
                      f"{r['search_share']:.1%} (every step {r['search_share_every_step']:.1%})",
                      flush=True)
    finally:
        numba.set_num_threads(old)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    res = run_fluid_bench(args.quick)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2, default=float)


if __name__ == "__main__":
    main()
