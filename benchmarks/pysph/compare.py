#!/usr/bin/env python
"""sphfem's fluid step against PySPH's own dam-break examples, in one run.

Run from the repository root with the project's Python (sphfem importable) and a PySPH
venv (see README.md)::

    python benchmarks/pysph/compare.py --pysph-python /tmp/pysph-venv/bin/python

For every case (2D dam break at ~2e4 and ~1e5 fluid particles, 3D dam break at ~8e4
fluid particles) and every thread count (1, 2) it times, back to back in this run,

* ours: a :class:`sphfem.fluid.wcsph.FluidSolver` on a dam break built with
  ``sphfem.fluid.setup`` (2D: PySPH's geometry -- a 1 x 2 column in a 4 x 4 tank, the
  same spacing and the same number of fluid particles, 3 layers of Adami wall particles;
  3D: ``sphfem.fluid.bench.dambreak3d``'s block, a x a x 2a column in a 2a x a x 2.2a tank,
  with the fluid count of PySPH's dam_break_3d), Wendland C2 with support R = 3 dx (the
  project's setting) and, as a second variant, R = 2.6 dx (PySPH's support: 2 h,
  h = 1.3 dx); artificial viscosity alpha as in the PySPH example (2D 0.1, 3D 0.25) on top
  of delta-SPH and laminar viscosity;
* PySPH: ``run_pysph.py`` in a worker process of the PySPH venv (OpenMP build,
  ``OMP_NUM_THREADS`` = threads).

Timing of ours: after 3 warm-up steps, blocks of steps of ``stable_dt() -> step(dt) ->
check()`` (what ``FluidSolver.run`` does per step) with the Verlet list kept (no rebuild
inside the blocks); ``step_s`` is the minimum over blocks of the mean step time.  The
neighbour rebuild (``build_s``, minimum of 3) is then amortised over 4 steps as in
``sphfem.fluid.bench`` (``step_search_s = step_s + build_s / 4``) -- the headline figure,
since PySPH re-bins its particles at every evaluation and searches cells inside its pair
loops.  Pairs are counted the same way for both codes (see run_pysph.py): directed pairs
i != j with r < R for fluid rows (all neighbours) and wall rows (fluid neighbours).

Writes ``results.json`` and ``RESULTS.md`` next to this file (``--out`` to change).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import time

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(1, os.path.dirname(os.path.dirname(HERE)))  # the repository root (sphfem)
import run_pysph  # noqa: E402

from sphfem.fluid.bench import REBUILD_EVERY, _pairs_within  # noqa: E402
from sphfem.fluid.setup import box_walls, hydrostatic_density, lattice, make_particles  # noqa: E402
from sphfem.fluid.wcsph import FluidParams, FluidSolver  # noqa: E402
from sphfem.machine import machine_info, threading_layer  # noqa: E402
from sphfem.particles import FLUID  # noqa: E402

G = 9.81

# (name, PySPH case, PySPH dx, PySPH alpha)
CASES = [
    ("2d_2e4", "dam_break_2d", 0.01, 0.1),
    ("2d_1e5", "dam_break_2d", 0.0045, 0.1),
    ("3d_1e5", "dam_break_3d", 0.02, 0.25),
]


def dambreak2d(dx: float, R_over_dx: float, threads: int, alpha: float) -> FluidSolver:
    """PySPH dam_break_2d's set-up in sphfem: 1 x 2 column, 4 x 4 tank, spacing dx.

    PySPH's get_2d_block puts (1/dx + 1) x (2/dx + 1) particles in the column; the same
    counts are laid here on a cell-centred lattice of spacing dx (column (nx dx) x (ny dx)
    standing on the tank floor at the left wall).
    """
    H = 2.0
    nx = int(round(1.0 / dx)) + 1
    ny = int(round(2.0 / dx)) + 1
    xf = lattice([0.0, 0.0], [nx * dx, ny * dx], dx)
    layers = int(np.ceil(R_over_dx))
    xw = box_walls([0.0, 0.0], [4.0, 4.0], dx, layers)
    c0 = 10.0 * np.sqrt(2 * G * H)
    rhof = hydrostatic_density(ny * dx - xf[:, 1], 1000.0, c0, G)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    par = FluidParams(c0=c0, gravity=(0.0, -G), alpha=alpha, threads=threads)
    m = (layers + 1) * dx
    return FluidSolver(ps, R_over_dx * dx, [-m, -m], [4.0 + m, 4.0 + 2 * m], params=par)


def dambreak3d(n_fluid: int, R_over_dx: float, threads: int, alpha: float,
               a: float = 0.146) -> FluidSolver:
    """``sphfem.fluid.bench.dambreak3d`` with a choice of support and alpha."""
    dx = a / round((n_fluid / 2.0) ** (1.0 / 3.0))
    c0 = 10 * np.sqrt(2 * G * a)
    layers = int(np.ceil(R_over_dx))
    xf = lattice([0.0, 0.0, 0.0], [a, a, 2 * a], dx)
    xw = box_walls([0.0, 0.0, 0.0], [2 * a, a, 2.2 * a], dx, layers)
    rhof = hydrostatic_density(2 * a - xf[:, 2], 1000.0, c0, G)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    par = FluidParams(c0=c0, gravity=(0.0, 0.0, -G), alpha=alpha, threads=threads)
    m = (layers + 1) * dx
    return FluidSolver(ps, R_over_dx * dx, [-m] * 3, [2 * a + m, a + m, 2.2 * a + m],
                       params=par)


def bench_ours(build, threads: int, blocks: int = 3, block_seconds: float = 2.0,
               warmup: int = 3, min_steps: int = 3) -> dict:
    numba.set_num_threads(threads)
    t0 = time.perf_counter()
    s = build()
    setup_s = time.perf_counter() - t0

    def one_step():
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()

    for _ in range(warmup):
        one_step()
    s.params.skin = 10.0  # keep the list: no rebuild inside the timed blocks
    t0 = time.perf_counter()
    one_step()
    per = time.perf_counter() - t0
    steps = max(min_steps, int(round(block_seconds / max(per, 1e-9))))
    times = []
    ctimes = []
    for _ in range(blocks):
        t0 = time.perf_counter()
        c0 = time.process_time()
        for _ in range(steps):
            one_step()
        times.append((time.perf_counter() - t0) / steps)
        ctimes.append((time.process_time() - c0) / steps)
    step_s = min(times)
    cpu_step_s = min(ctimes)
    s.params.skin = FluidParams.skin
    s.params.sort_every = 0
    bt = []
    cbt = []
    for _ in range(3):
        t0 = time.perf_counter()
        c0 = time.process_time()
        s.rebuild_neighbors()
        bt.append(time.perf_counter() - t0)
        cbt.append(time.process_time() - c0)
    build_s = min(bt)
    cpu_build_s = min(cbt)
    nl = s.nbrs
    pairs = int(_pairs_within(s.p.x, nl.offsets, nl.indices, s.R, s.p.kind))
    n = int(s.p.n)
    nf = int((s.p.kind == FLUID).sum())
    ss = step_s + build_s / REBUILD_EVERY
    d = s.diagnostics()
    return {
        "code": "sphfem", "threads": threads, "numba_threads": numba.get_num_threads(),
        "threading_layer": threading_layer(), "n_fluid": nf, "n_total": n,
        "dim": s.dim, "R": s.R, "R_over_dx": None, "pairs": pairs,
        "list_pairs": int(nl.n_pairs), "setup_s": setup_s, "steps_per_block": steps,
        "blocks": blocks, "block_step_s": times, "step_s": step_s, "build_s": build_s,
        "step_search_s": ss, "cpu_step_s": cpu_step_s, "cpu_build_s": cpu_build_s,
        "cpu_step_search_s": cpu_step_s + cpu_build_s / REBUILD_EVERY,
        "cpu_particle_steps_per_s": n / (cpu_step_s + cpu_build_s / REBUILD_EVERY),
        "particle_steps_per_s": n / ss, "pairs_per_s": pairs / ss,
        "particle_steps_per_s_no_search": n / step_s, "pairs_per_s_no_search": pairs / step_s,
        "search_share": build_s / (REBUILD_EVERY * step_s + build_s),
        "rho_ratio_range": d["rho_ratio_range"], "max_speed": d["max_speed"],
        "loadavg_end": run_pysph.loadavg(),
    }


def git_head() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                              cwd=HERE).stdout.strip()
    except OSError:
        return ""


def ratio(a, b):
    return a / b if b else float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pysph-python", default="/tmp/pysph-venv/bin/python")
    ap.add_argument("--cases", nargs="+", default=[c[0] for c in CASES])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--ours-R", type=float, nargs="+", default=[3.0, 2.6],
                    help="support radii of ours in units of dx (first: headline)")
    ap.add_argument("--rounds", type=int, default=1,
                    help="repeat every measurement this many times (the minimum is kept)")
    ap.add_argument("--block-seconds", type=float, default=2.0)
    ap.add_argument("--blocks", type=int, default=3)
    ap.add_argument("--out", default=HERE)
    a = ap.parse_args(argv)

    started = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    la0 = run_pysph.loadavg()
    results = {"date": started, "loadavg_start": la0, "machine": machine_info(),
               "git_head": git_head(), "pysph_versions": run_pysph.pysph_version(
                   a.pysph_python), "command": " ".join([sys.executable] + sys.argv),
               "runs": []}
    print(f"{started} load {la0} {results['machine']['cpu']}", flush=True)
    best: dict = {}
    for name, case, dx, alpha in CASES:
        if name not in a.cases:
            continue
        for t in a.threads:
            for rnd in range(a.rounds):
                # PySPH first: its run also fixes the fluid count ours mirrors
                la = run_pysph.loadavg()
                rp = run_pysph.run_one(a.pysph_python, case, dx, t,
                                       block_seconds=a.block_seconds, blocks=a.blocks)
                rp.update(name=name, round=rnd)
                results["runs"].append(rp)
                print(f"[{name} t={t} r{rnd}] pysph  n={rp['n_total']:>7} "
                      f"{rp['step_s'] * 1e3:8.1f} ms/step  {rp['particle_steps_per_s']:.3e} "
                      f"p-steps/s  {rp['pairs_per_s']:.3e} pairs/s  load {la}", flush=True)
                k = (name, t, "pysph")
                if k not in best or rp["step_s"] < best[k]["step_s"]:
                    best[k] = rp
                for Rf in a.ours_R:
                    if case == "dam_break_2d":
                        def build(dx=dx, Rf=Rf, t=t, alpha=alpha):
                            return dambreak2d(dx, Rf, t, alpha)
                    else:
                        nfl = rp["n_fluid"]

                        def build(nfl=nfl, Rf=Rf, t=t, alpha=alpha):
                            return dambreak3d(nfl, Rf, t, alpha)
                    la = run_pysph.loadavg()
                    ro = bench_ours(build, t, blocks=a.blocks, block_seconds=a.block_seconds)
                    ro.update(name=name, round=rnd, R_over_dx=Rf, loadavg_start=la,
                              case=case, alpha=alpha)
                    results["runs"].append(ro)
                    print(f"[{name} t={t} r{rnd}] ours R={Rf}dx n={ro['n_total']:>7} "
                          f"{ro['step_s'] * 1e3:8.1f} ms/step (+search/4 "
                          f"{ro['step_search_s'] * 1e3:.1f})  {ro['particle_steps_per_s']:.3e}"
                          f" p-steps/s  {ro['pairs_per_s']:.3e} pairs/s  load {la}",
                          flush=True)
                    k = (name, t, f"ours_R{Rf}")
                    if k not in best or ro["step_search_s"] < best[k]["step_search_s"]:
                        best[k] = ro
    results["loadavg_end"] = run_pysph.loadavg()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)

    rows = []
    for name, _case, _dx, _alpha in CASES:
        for t in a.threads:
            p = best.get((name, t, "pysph"))
            if p is None:
                continue
            for Rf in a.ours_R:
                o = best[(name, t, f"ours_R{Rf}")]
                rows.append({
                    "name": name, "case": case, "threads": t, "R_over_dx": Rf,
                    "ours": {k: o[k] for k in ("n_fluid", "n_total", "pairs", "step_s",
                                               "build_s", "step_search_s",
                                               "particle_steps_per_s", "pairs_per_s",
                                               "particle_steps_per_s_no_search",
                                               "pairs_per_s_no_search", "loadavg_start",
                                               "cpu_step_search_s",
                                               "cpu_particle_steps_per_s")},
                    "pysph": {k: p[k] for k in ("n_fluid", "n_total", "pairs", "step_s",
                                                "evals_per_step", "particle_steps_per_s",
                                                "pairs_per_s", "pair_evals_per_s",
                                                "loadavg_start", "command", "cpu_step_s",
                                                "cpu_particle_steps_per_s")},
                    "ratio_particle_steps": ratio(o["particle_steps_per_s"],
                                                  p["particle_steps_per_s"]),
                    "ratio_pairs": ratio(o["pairs_per_s"], p["pairs_per_s"]),
                    "ratio_cpu_particle_steps": ratio(o["cpu_particle_steps_per_s"],
                                                      p["cpu_particle_steps_per_s"]),
                    "ratio_particle_steps_no_search": ratio(
                        o["particle_steps_per_s_no_search"], p["particle_steps_per_s"]),
                    "ratio_pairs_no_search": ratio(o["pairs_per_s_no_search"],
                                                   p["pairs_per_s"]),
                })
    results["comparison"] = rows
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(results, f, indent=2, default=float)
    with open(os.path.join(a.out, "RESULTS.md"), "w") as f:
        f.write(markdown(results, a))
    print(markdown(results, a))


def markdown(res, a) -> str:
    m = res["machine"]
    v = res["pysph_versions"]
    L = []
    L.append("# sphfem fluid step vs PySPH dam-break examples\n")
    L.append(f"Generated by `benchmarks/pysph/compare.py` on {res['date']} (git "
             f"`{res['git_head'][:12]}`).  Machine: {m['cpu']}, {m['cores']} cores "
             f"(shared with other processes: timings are minima over blocks/rounds, load "
             f"averages are `/proc/loadavg` 1/5/15 min at the start of each measurement).  "
             f"Load average at start {res['loadavg_start']}, at end {res['loadavg_end']}.\n")
    L.append(f"Versions: python {m['python']}, numba {m['numba']}, numpy {m['numpy']} "
             f"(ours); PySPH {v.get('pysph')}, compyle {v.get('compyle')}, Cython "
             f"{v.get('cython')}, numpy {v.get('numpy')} (PySPH venv, gcc -O3 -fopenmp).\n")
    L.append(f"Command: `{res['command']}`\n")
    L.append("Definitions: *pairs* = directed neighbour pairs (i != j, r < R) per step, "
             "for fluid rows (all neighbours) and wall rows (fluid neighbours), counted on "
             "the initial positions with each code's own support R (ours 3 dx or 2.6 dx, "
             "PySPH 2 h = 2.6 dx); *pairs/s* = pairs x steps / seconds; *particle-steps/s* "
             "= all particles (walls included) x steps / seconds.  Ours includes the "
             "neighbour rebuild amortised over 4 steps (`+search`); the `no search` ratio "
             "uses the bare step.  *CPU-time ratio*: the same ratio from process CPU "
             "time (all threads) instead of wall time -- on 1 thread nearly independent of "
             "the other processes on the machine; on 2 threads it counts OpenMP "
             "spin-waiting.  PySPH's dam_break_3d uses EPECIntegrator (2 "
             "acceleration evaluations per step), dam_break_2d PECIntegrator (1); ours "
             "always 1 evaluation (2 pair passes + the wall-state pass).\n")
    L.append("| case | threads | ours R | fluid ours / PySPH | total ours / PySPH | "
             "pairs/particle ours / PySPH | ours ms/step (+search) | PySPH ms/step | "
             "ours particle-steps/s | PySPH particle-steps/s | **ratio p-steps** | "
             "ours pairs/s | PySPH pairs/s | **ratio pairs/s** | ratios no search "
             "(p-steps, pairs) | CPU-time ratio p-steps | load avg ours; PySPH |")
    L.append("|" + "---|" * 17)
    for r in res["comparison"]:
        o, p = r["ours"], r["pysph"]
        L.append(
            f"| {r['case']} ({r['name']}) | {r['threads']} | {r['R_over_dx']:g} dx | "
            f"{o['n_fluid']} / {p['n_fluid']} | {o['n_total']} / {p['n_total']} | "
            f"{o['pairs'] / o['n_total']:.1f} / {p['pairs'] / p['n_total']:.1f} | "
            f"{o['step_s'] * 1e3:.1f} ({o['step_search_s'] * 1e3:.1f}) | "
            f"{p['step_s'] * 1e3:.1f} | {o['particle_steps_per_s']:.3e} | "
            f"{p['particle_steps_per_s']:.3e} | **{r['ratio_particle_steps']:.2f}** | "
            f"{o['pairs_per_s']:.3e} | {p['pairs_per_s']:.3e} | **{r['ratio_pairs']:.2f}** | "
            f"{r['ratio_particle_steps_no_search']:.2f}, {r['ratio_pairs_no_search']:.2f} | "
            f"{r.get('ratio_cpu_particle_steps', float('nan')):.2f} | "
            f"{o['loadavg_start']}; {p['loadavg_start']} |")
    L.append("\nPySPH pair-evaluations/s (pairs x evaluations per step / s): " + ", ".join(
        f"{r['name']} t={r['threads']}: {r['pysph']['pair_evals_per_s']:.3e}"
        for r in res["comparison"] if r["R_over_dx"] == a.ours_R[0]) + "\n")
    L.append("PySPH commands (each a fresh worker process; `--worker` builds the example's "
             "Application with `--dx D --openmp --disable-output -q` and times its "
             "steps):\n")
    seen = set()
    for r in res["comparison"]:
        c = r["pysph"]["command"]
        if c not in seen:
            seen.add(c)
            L.append(f"    {c}")
    L.append("")
    return "\n".join(L)


if __name__ == "__main__":
    main()
