"""Micro-benchmarks of the hot kernels: neighbour search and summation density.

``run_bench(name)`` builds 3D lattice blocks (spacing dx, support radius R = 3 dx, the
thesis setting, 92 interacting neighbours per interior particle), sorts them by cell once
(as a simulation does every few steps), and times, after a warm-up call that compiles:

* ``build_s``: building the CSR neighbour list (min over repeats);
* ``density_s``: one summation-density pass over that list (min over repeats);
* ``pairs``: directed interacting pairs (i, j), i != j, r < R -- counted as the fluid
  bench (:mod:`sphfem.fluid.bench`) and PySPH count them;
* ``list_pairs``: pairs in the list, r <= R: on the lattice 30 of an interior particle's
  122 listed neighbours sit exactly at r = R, where every kernel weight is zero (so the
  list holds 1.31-1.32x the interacting pairs);
* ``pairs_per_s``: pairs / density_s, the pair-interaction rate of the density pass;
  ``build_pairs_per_s``: pairs / build_s;
* ``particle_steps_per_s``: n / (build_s + density_s), a "step" being one neighbour build
  and one density pass;
* ``search_share``: build_s / (build_s + density_s);
* ``build_cpu_s``, ``density_cpu_s``: minimum process CPU seconds (all threads), to judge
  contention on a shared machine.

Full fluid steps: ``dambreak2d``, ``droplet3d`` (and ``dambreak3d``) dispatch to
:mod:`sphfem.fluid.bench` (particle-steps/s and pairs/s on 1 and 2 threads).

Run ``python -m sphfem.bench NAME [--json FILE] [--quick]`` or ``sphfem bench NAME``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numba
import numpy as np
from numba import njit, prange

from sphfem.density import summation_density
from sphfem.kernels import WENDLAND_C2, kernel_sigma
from sphfem.machine import machine_info
from sphfem.neighbors import build_neighbor_list, cell_sort_permutation

BENCHES = ("neighbors", "density")
#: full fluid steps (:mod:`sphfem.fluid.bench`): particle-steps/s and pairs/s
FLUID_BENCHES = ("dambreak2d", "droplet3d", "dambreak3d")
#: every name ``run_bench`` / ``sphfem bench NAME`` accepts
BENCHMARKS = BENCHES + FLUID_BENCHES
QUICK_SIZES = (20_000,)


@njit(parallel=True, cache=True)
def _calibration_work(n):
    out = np.empty(n)
    for i in prange(n):
        acc = 0.0
        for k in range(2000):
            acc += np.sqrt(i + k * 1.0)
        out[i] = acc
    return out


def parallel_calibration(threads) -> dict:
    """Speed-up of a trivially parallel, compute-bound loop at each thread count.

    On a shared machine this shows how many cores were really free during the run: a
    value near 1 for 2 threads means the second core was busy with other work.
    """
    saved = numba.get_num_threads()
    times = {}
    try:
        _calibration_work(100)
        for t in threads:
            numba.set_num_threads(t)
            times[t], _, _ = _best(lambda: _calibration_work(4000), 5)
    finally:
        numba.set_num_threads(saved)
    t1 = times.get(1, min(times.values()))
    return {str(t): t1 / s for t, s in times.items()}


@njit(cache=True)
def _pairs_within(x, offsets, indices, R):
    """Directed pairs of the list with r < R (those with a non-zero kernel weight)."""
    c = 0
    for i in range(x.shape[0]):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            s = 0.0
            for k in range(x.shape[1]):
                d = x[i, k] - x[j, k]
                s += d * d
            c += s < R * R
    return c


def lattice_block(n_target: int, dx: float = 1.0) -> np.ndarray:
    """A cubic lattice block of about ``n_target`` particles, spacing ``dx`` (n, 3)."""
    k = max(2, round(n_target ** (1.0 / 3.0)))
    g = np.arange(k) * dx
    x = np.stack([a.ravel() for a in np.meshgrid(g, g, g, indexing="ij")], axis=1)
    return np.ascontiguousarray(x)


def _best(fn, repeats: int) -> tuple[float, float, object]:
    """Minimum wall seconds and minimum process CPU seconds over ``repeats`` calls.

    On a shared machine the CPU time (all threads) shows contention: for t threads,
    ``cpu / t`` well below the wall time means the threads were waiting for a core.
    """
    best = np.inf
    best_cpu = np.inf
    out = None
    for _ in range(repeats):
        c0 = time.process_time()
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best, best_cpu, out


def _one_case(n_target: int, nthreads: int, repeats: int, cells_per_radius: int) -> dict:
    dx = 1.0
    R = 3.0 * dx
    x = lattice_block(n_target, dx)
    # shuffle, then sort by cell once, as a simulation would every few steps
    x = x[np.random.default_rng(1).permutation(x.shape[0])]
    lo = x.min(axis=0) - 0.5 * dx
    hi = x.max(axis=0) + 0.5 * dx
    period = np.zeros(3)
    cell = R / cells_per_radius  # the search's cells, so candidate rows are contiguous
    cell_sort_permutation(x[:10], cell, lo, hi)  # compile / load the cache
    t0 = time.perf_counter()
    perm = cell_sort_permutation(x, cell, lo, hi)
    x = np.ascontiguousarray(x[perm])
    sort_s = time.perf_counter() - t0
    n = x.shape[0]
    m = np.full(n, dx**3)
    sigma = kernel_sigma(WENDLAND_C2, 3, R)

    numba.set_num_threads(nthreads)

    def build():
        return build_neighbor_list(x, R, lo, hi, period, cells_per_radius=cells_per_radius)

    build()  # warm-up (compile / load cache, first-touch of memory)
    build_s, build_cpu_s, nl = _best(build, repeats)

    def dens():
        return summation_density(x, m, nl.offsets, nl.indices, R, sigma, WENDLAND_C2, period)

    dens()
    density_s, density_cpu_s, rho = _best(dens, repeats)
    pairs = int(_pairs_within(x, nl.offsets, nl.indices, R))  # r < R: interacting
    interior = np.all((x > lo + R) & (x < hi - R), axis=1)
    rho_err = float(np.max(np.abs(rho[interior] - 1.0))) if interior.any() else float("nan")
    return {
        "n": int(n),
        "threads": int(nthreads),
        "radius_over_dx": 3.0,
        "cells_per_radius": int(cells_per_radius),
        "sort_s": sort_s,
        "build_s": build_s,
        "build_cpu_s": build_cpu_s,
        "pairs": pairs,
        "list_pairs": nl.n_pairs,
        "pairs_per_particle": pairs / n,
        "build_pairs_per_s": pairs / build_s,
        "density_s": density_s,
        "density_cpu_s": density_cpu_s,
        "pairs_per_s": pairs / density_s,
        "particle_steps_per_s": n / (build_s + density_s),
        "search_share": build_s / (build_s + density_s),
        "density_max_rel_err_interior": rho_err,
    }


def run_bench(
    name: str,
    sizes=(100_000, 1_000_000),
    threads=(1, 2),
    *,
    quick: bool = False,
    repeats: int | None = None,
    cells_per_radius: int = 1,
    verbose: bool = True,
) -> dict:
    """Run benchmark ``name`` (:data:`BENCHMARKS`); returns a JSON-serialisable dict.

    "neighbors" and "density" time the same cases (neighbour build and density pass, since
    the density pass needs the list); ``name`` selects which figures are printed first.
    "dambreak2d", "droplet3d" and "dambreak3d" time full fluid steps
    (:func:`sphfem.fluid.bench.run_fluid_bench`: particle-steps/s and pairs/s on each
    thread count; ``sizes`` there are fluid particle counts, the case's own by default).
    ``quick`` uses ~2e4 particles and 2 repeats (for tests).
    """
    if name in FLUID_BENCHES:
        from sphfem.fluid.bench import run_fluid_bench

        fs = None if quick or sizes == (100_000, 1_000_000) else sizes
        return run_fluid_bench(quick, name, sizes=fs, threads=threads, verbose=verbose)
    if name not in BENCHES:
        raise ValueError(f"unknown benchmark {name!r}; expected one of {BENCHMARKS}")
    if quick:
        sizes = QUICK_SIZES
    if repeats is None:
        repeats = 2 if quick else 3
    max_threads = numba.config.NUMBA_NUM_THREADS
    threads = [t for t in threads if 1 <= t <= max_threads] or [1]
    saved = numba.get_num_threads()
    cases = []
    try:
        for n in sizes:
            for t in threads:
                cases.append(_one_case(int(n), int(t), repeats, cells_per_radius))
    finally:
        numba.set_num_threads(saved)
    machine = machine_info()
    machine["parallel_speedup_calibration"] = parallel_calibration(threads)
    result = {
        "benchmark": name,
        "machine": machine,
        "setup": "3D cubic lattice block, R = 3 dx, Wendland C2, non-periodic, cell-sorted",
        "repeats": repeats,
        "cases": cases,
    }
    if verbose:
        print(format_table(result))
    return result


def format_table(result: dict) -> str:
    """The cases of a :func:`run_bench` result as a fixed-width text table."""
    mi = result["machine"]
    head = (
        f"{result['benchmark']}: {result['setup']}\n"
        f"cpu: {mi['cpu']} ({mi['cores']} cores), numba {mi['numba']}, {mi['date']}, "
        f"load average {mi['load_average']}\n"
        f"speed-up of a trivially parallel loop by threads (free cores): "
        f"{mi.get('parallel_speedup_calibration')}\n"
    )
    cols = (
        f"{'n':>9} {'thr':>3} {'build s':>8} {'(cpu s)':>8} {'pairs r<R':>11} "
        f"{'build pairs/s':>13} "
        f"{'density s':>9} {'(cpu s)':>8} {'pairs/s':>9} {'particle-steps/s':>16} {'search %':>8}"
    )
    rows = [head + cols, "-" * len(cols)]
    for c in result["cases"]:
        rows.append(
            f"{c['n']:>9} {c['threads']:>3} {c['build_s']:>8.4f} {c['build_cpu_s']:>8.4f} "
            f"{c['pairs']:>11} {c['build_pairs_per_s']:>13.3e} {c['density_s']:>9.4f} "
            f"{c['density_cpu_s']:>8.4f} {c['pairs_per_s']:>9.3e} "
            f"{c['particle_steps_per_s']:>16.3e} {100 * c['search_share']:>8.1f}"
        )
    return "\n".join(rows)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m sphfem.bench", description=__doc__.split("\n")[0])
    p.add_argument("name", choices=BENCHMARKS)
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--quick", action="store_true", help="small sizes (~2e4 particles)")
    p.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument("--repeats", type=int, default=None)
    p.add_argument("--cells-per-radius", type=int, default=1, choices=(1, 2, 3))
    a = p.parse_args(argv)
    res = run_bench(
        a.name,
        sizes=tuple(a.sizes),  # fluid cases: fluid particle counts (default: the case's)
        threads=tuple(a.threads),
        quick=a.quick,
        repeats=a.repeats,
        cells_per_radius=a.cells_per_radius,
    )
    if a.json:
        tmp = a.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(res, f, indent=2)
        os.replace(tmp, a.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
