#!/usr/bin/env python
"""Where the time of one sphfem fluid step goes (3D dam break, ~8e4 fluid particles).

Builds the 3D case of compare.py (R = 3 dx, alpha = 0.25, PySPH dam_break_3d's fluid
count) and times, each as the minimum over ``--repeats`` calls, every kernel of a step
called exactly as ``FluidSolver`` calls it (same arrays, same order):

  stable_dt (_fluid_maxima), _predict, _max_disp_sq (skin check), prepare_fluid,
  adami_wall_state, prepare_all, density_gradient, pack_rows, fluid_forces, _correct,
  check (guards)

plus the neighbour rebuild split into cell sort, build_neighbor_list and filter_rows,
on 1 and 2 threads, with numba's default static scheduling and with
``numba.set_parallel_chunksize`` (dynamic chunks).  Also: the pair passes on a list of
radius R (no skin) vs the Verlet list of radius 1.15 R, and the step of the whole solver
for reference.  Writes ``profile.json`` next to this file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(1, os.path.dirname(os.path.dirname(HERE)))
import compare  # noqa: E402
import run_pysph  # noqa: E402

from sphfem.fluid import integrator_symplectic_gomezgesteira2012 as SY  # noqa: E402
from sphfem.fluid import passes  # noqa: E402
from sphfem.fluid import wcsph as W  # noqa: E402
from sphfem.fluid.guards import check_fluid  # noqa: E402
from sphfem.fluid.standalone import max_disp_sq  # noqa: E402
from sphfem.fluid.walls_adami2012 import adami_wall_state  # noqa: E402
from sphfem.neighbors import build_neighbor_list, cell_sort_permutation  # noqa: E402
from sphfem.particles import FLUID, WALL  # noqa: E402


def tmin(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def kernels_of(s, nl=None):
    """name -> zero-argument callable, the kernels of one step in FluidSolver's order."""
    p, sc, pa = s.p, s._scratch, s.params
    nl = nl or s.nbrs
    g = s.gravity
    dt = s.stable_dt()[0] * 1e-6  # tiny: repeated calls leave the state unchanged
    delta_coef = pa.delta * s.h * pa.c0
    # the compacted in-range rows (density_gradient emits them; fluid_forces reads them)
    nb = np.empty_like(nl.indices)
    cnt = np.zeros(p.n, dtype=np.int64)
    passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices, s.R, s.period, nb, cnt)
    ks = {
        "stable_dt": lambda: W._fluid_maxima(p.v, p.acc, p.rho, p.mu, p.kind),
        "predict": lambda: SY.predict(p.x, p.v, p.rho, p.acc, p.drho, p.kind, dt, sc.v_n,
                                      sc.rho_n),
        "skin_check": lambda: max_disp_sq(p.x, s.ctx.provide.xref, p.v, 0.0, p.kind,
                                          s.period),
        "prepare_fluid": lambda: passes.prepare_fluid(p.rho, p.m, p.v, p.kind, pa.rho0, s.B,
                                                      pa.gamma, p.p, sc.vg),
        "adami_wall_state": lambda: adami_wall_state(
            p.x, p.v, p.rho, p.p, p.acc, p.kind, nl.offsets, nl.indices, s.R, s.kernel_code,
            s.period, g, pa.rho0, s.B, pa.gamma, sc.vg),
        "prepare_all": lambda: passes.prepare_all(p.rho, p.p, p.m, p.vol, p.kind, sc.pr,
                                                  sc.V, sc.meff, sc.isf),
        "density_gradient": lambda: passes.density_gradient(
            p.x, p.rho, sc.V, p.kind, nl.offsets, nl.indices, s.R, s.sigma, s.kernel_code,
            s.period, pa.cond_max, sc.grad, sc.ok, nb, cnt),
        "pack_rows": lambda: passes.pack_rows(p.x, p.v, sc.vg, p.rho, sc.pr, sc.V, sc.meff,
                                              sc.isf, p.mu, sc.grad, sc.P),
        "fluid_forces": lambda: passes.fluid_forces(
            sc.P, p.kind, nl.offsets, cnt, nb, s.R, s.sigma, s.kernel_code, s.period, g,
            pa.eps_visc * s.h * s.h, delta_coef, pa.alpha * s.h * pa.c0, p.acc, p.drho,
            p.f_fluid),
        "correct": lambda: SY.correct(p.x, p.v, p.rho, p.acc, p.drho, p.kind, dt, sc.v_n,
                                      sc.rho_n),
        "guards": lambda: check_fluid(p.x, p.v, p.rho, p.kind, s.lo, s.hi, s.period, pa.c0,
                                      pa.rho0, pa.max_speed_factor, pa.rho_ratio_band, 0,
                                      0.0),
    }
    return ks


def row_entries(s, nl):
    """List entries visited per pass (fluid rows / wall rows) and in-R pairs."""
    kind = s.p.kind
    cnt = np.diff(nl.offsets)
    fl = kind == FLUID
    wl = kind == WALL
    return {"fluid_row_entries": int(cnt[fl].sum()), "wall_row_entries": int(cnt[wl].sum())}


def profile(threads, s, repeats, chunksize=0):
    numba.set_num_threads(threads)
    old = numba.set_parallel_chunksize(chunksize) if chunksize else None
    try:
        ks = kernels_of(s)
        for f in ks.values():  # warm
            f()
        la = run_pysph.loadavg()
        out = {name: tmin(f, repeats) for name, f in ks.items()}

        def step():
            dt, _ = s.stable_dt()
            s.step(dt)
            s.check()

        s.params.skin = 10.0
        step()
        out["full_step"] = tmin(step, repeats)
        s.params.skin = W.FluidParams.skin
        # rebuild, split
        p = s.p
        out["cell_sort"] = tmin(lambda: cell_sort_permutation(p.x, s.list_radius, s.lo, s.hi,
                                                              s.period), 3)
        box = {}

        def build():
            box["nl"] = build_neighbor_list(p.x, s.list_radius, s.lo, s.hi, s.period)

        out["build_neighbor_list"] = tmin(build, 3)
        nl = box["nl"]
        out["filter_rows"] = tmin(lambda: passes.filter_rows(nl.offsets, nl.indices,
                                                             p.kind), 3)
        out["loadavg"] = la
    finally:
        if old is not None:
            numba.set_parallel_chunksize(old)
    return out


@numba.njit(cache=True, parallel=True)
def compact_to_R(x, offsets, indices, R):
    """Prototype (not in sphfem): the rows of a Verlet list reduced to entries with r < R
    (count pass + fill pass, like passes.filter_rows) -- what a per-step compaction of
    the skin list would cost."""
    n, dim = x.shape
    R2 = R * R
    cnt = np.empty(n, np.int64)
    for i in numba.prange(n):
        c = 0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d2 = 0.0
            for k in range(dim):
                d = x[j, k] - x[i, k]
                d2 += d * d
            c += d2 < R2
        cnt[i] = c
    off = np.zeros(n + 1, np.int64)
    for i in range(n):
        off[i + 1] = off[i] + cnt[i]
    out = np.empty(off[n], indices.dtype)
    for i in numba.prange(n):
        k = off[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d2 = 0.0
            for kk in range(dim):
                d = x[j, kk] - x[i, kk]
                d2 += d * d
            if d2 < R2:
                out[k] = j
                k += 1
    return off, out


def list_radius_experiment(s, threads, repeats):
    """The two pair passes and the wall pass on a list of radius R vs 1.15 R."""
    from sphfem.neighbors import NeighborList

    numba.set_num_threads(threads)
    p = s.p
    res = {}
    for name, rad in (("R", s.R * (1 + 1e-9)), ("1.15R", s.list_radius)):
        nl0 = build_neighbor_list(p.x, rad, s.lo, s.hi, s.period)
        off, idx = passes.filter_rows(nl0.offsets, nl0.indices, p.kind)
        nl = NeighborList(off, idx, rad, nl0.period)
        ks = kernels_of(s, nl)
        t = {k: tmin(ks[k], repeats) for k in ("adami_wall_state", "density_gradient",
                                                "fluid_forces")}
        t["entries"] = int(idx.shape[0])
        if name == "1.15R":
            t["compact_to_R"] = tmin(lambda p=p, off=off, idx=idx: compact_to_R(p.x, off, idx, s.R),
                                     repeats)
        t.update(row_entries(s, nl))
        res[name] = t
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-fluid", type=int, default=80703)
    ap.add_argument("--R", type=float, default=3.0, help="support in dx")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--chunksizes", type=int, nargs="*", default=[0, 256])
    ap.add_argument("--out", default=os.path.join(HERE, "profile.json"))
    a = ap.parse_args(argv)
    res = {"loadavg_start": run_pysph.loadavg(), "machine": compare.machine(),
           "command": " ".join([sys.executable] + sys.argv)}
    s = compare.dambreak3d(a.n_fluid, a.R, 0, 0.25)
    s.params.threads = 0
    s.nthreads = 0
    for _ in range(3):
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()
    nl = s.nbrs
    from sphfem.fluid.bench import _pairs_within
    res["n_total"] = int(s.p.n)
    res["n_fluid"] = int((s.p.kind == FLUID).sum())
    res["n_wall"] = int((s.p.kind == WALL).sum())
    res["pairs_in_R"] = int(_pairs_within(s.p.x, nl.offsets, nl.indices, s.R, s.p.kind))
    res["list_entries"] = int(nl.n_pairs)
    res.update(row_entries(s, nl))
    res["threading_layer"] = compare.threading_layer()
    res["runs"] = []
    for cs in a.chunksizes:
        for t in (1, 2):
            r = profile(t, s, a.repeats, cs)
            r.update(threads=t, chunksize=cs)
            res["runs"].append(r)
            print(json.dumps({k: (round(v * 1e3, 2) if isinstance(v, float) else v)
                              for k, v in r.items()}), flush=True)
    res["list_radius"] = {t: list_radius_experiment(s, t, a.repeats) for t in (1, 2)}
    print(json.dumps(res["list_radius"], indent=1), flush=True)
    res["loadavg_end"] = run_pysph.loadavg()
    with open(a.out, "w") as f:
        json.dump(res, f, indent=2)


if __name__ == "__main__":
    main()
