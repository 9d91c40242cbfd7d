#!/usr/bin/env python
"""Throughput of PySPH's own ``dam_break_2d`` / ``dam_break_3d`` examples.

Run it with the Python of a venv that has PySPH (``pip install pysph scipy``), e.g.::

    /tmp/pysph-venv/bin/python benchmarks/pysph/run_pysph.py \
        --case dam_break_2d --dx 0.01 --threads 1 2 --json out.json

(``OMP_NUM_THREADS`` is set per worker by this script.)

Every (case, dx, threads) runs in a fresh worker process (``--worker``) so that
``OMP_NUM_THREADS`` is set before OpenMP starts.  The worker builds the example's
``Application`` exactly as ``pysph run <case>`` does (``app.setup(argv)`` with ``--dx``,
``--openmp``, ``--disable-output``, ``-q``), then calls ``app.solve()`` with a post-step
callback that timestamps every step.  Code generation and compilation happen in
``setup`` (cached in ``~/.pysph`` after the first run) and are excluded; the first
``--warmup`` steps are excluded too (the initial acceleration evaluation, first touches).
The remaining steps are timed in ``--blocks`` blocks of equal length (the block length is
chosen from the warm-up so that a block lasts about ``--block-seconds``); the reported
step time is the minimum over blocks of (block wall time / steps in block).

One deviation from the shipped example, needed to make ``--dx`` mean anything in 2D:
``dam_break_2d.create_particles`` gives the particles the module constants ``h`` and
``m`` (computed from the default dx = 0.03) instead of ``self.h`` and ``self.dx``, so at
any other ``--dx`` every particle would have h = 0.039 and the mass of a 0.03 spacing.
The worker sets those two module constants from ``--dx`` before ``setup`` (h = hdx dx,
m = rho0 dx^2); nothing else is changed.  ``dam_break_3d`` uses ``self.dx`` already.

Definitions (the same as ``sphfem.fluid.bench``):

* ``pairs`` -- directed interacting pairs per step: (i, j), i != j, |x_i - x_j| < R with
  R = kernel.radius_scale * h (WendlandQuintic: 2 h, h = hdx dx = 1.3 dx), counted at
  the start with scipy's cKDTree for rows of fluid particles (all neighbours: fluid and
  solid) and rows of solid particles (fluid neighbours only) -- exactly the
  (dest, source) pairs of the example's pair equations (ContinuityEquation for solids
  from fluids; Continuity/Momentum for fluid from all; XSPH fluid-fluid);
* ``pairs_per_s = pairs / step_s`` and ``particle_steps_per_s = n_total / step_s``
  (all particles, walls included);
* ``cpu_step_s`` -- process CPU time (all threads, ``time.process_time``) per step, minimum
  over blocks; on 1 thread it is insensitive to other processes on a shared machine
  (``cpu_particle_steps_per_s = n_total / cpu_step_s``); on 2 threads it includes OpenMP
  spin-waiting;
* ``evals_per_step`` -- acceleration evaluations per step of the integrator
  (PECIntegrator: 1 for dam_break_2d; EPECIntegrator: 2 for dam_break_3d), and
  ``pair_evals_per_s = pairs * evals_per_step / step_s``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))

#: default spacings: dam_break_2d ~2e4 and ~1e5 fluid particles, dam_break_3d its default
DEFAULT_DX = {"dam_break_2d": [0.01, 0.0045], "dam_break_3d": [0.02]}
EVALS_PER_STEP = {"PECIntegrator": 1, "EPECIntegrator": 2, "TVDRK3Integrator": 3,
                  "EulerIntegrator": 1}


def loadavg() -> str:
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "n/a"


# ------------------------------------------------------------------------------------------
# worker: one (case, dx, threads) run inside the PySPH interpreter
# ------------------------------------------------------------------------------------------
def count_pairs(arrays, fluids, R):
    """Directed pairs (i != j, r < R): fluid rows x all sources + solid rows x fluid."""
    import numpy as np
    from scipy.spatial import cKDTree

    def pos(pa):
        return np.column_stack([pa.get("x"), pa.get("y"), pa.get("z")])

    fl = [pa for pa in arrays if pa.name in fluids]
    so = [pa for pa in arrays if pa.name not in fluids]
    xf = np.concatenate([pos(pa) for pa in fl])
    r = R * (1.0 - 1e-12)  # cKDTree counts r <= R; the kernel vanishes at R
    tf = cKDTree(xf)
    ff = int(tf.count_neighbors(tf, r)) - xf.shape[0]
    fs = 0
    if so:
        xs = np.concatenate([pos(pa) for pa in so])
        fs = int(tf.count_neighbors(cKDTree(xs), r))
    return {"pairs": ff + 2 * fs, "pairs_fluid_fluid": ff, "pairs_fluid_solid": fs}


def worker(a) -> dict:
    import importlib

    import numpy as np

    case = a.case
    mod = importlib.import_module("pysph.examples." + case)
    outdir = tempfile.mkdtemp(prefix=f"pysph_{case}_")
    if case == "dam_break_2d":
        mod.h = mod.hdx * a.dx   # see the module docstring: the example's create_particles
        mod.m = mod.ro * a.dx**2  # uses these module constants, not self.h / self.dx
        app = mod.DamBreak2D(fname=case, output_dir=outdir)
    elif case == "dam_break_3d":
        app = mod.DamBreak3D(fname=case, output_dir=outdir)
    else:
        raise SystemExit(f"unknown case {case}")
    argv = ["--dx", repr(a.dx), "--disable-output", "-q", "-d", outdir,
            "--max-steps", str(10**9)]
    argv += ["--openmp"] if a.openmp else ["--no-openmp"]
    t0 = time.perf_counter()
    app.setup(argv)
    setup_s = time.perf_counter() - t0

    arrays = app.particles
    n_by = {pa.name: int(pa.get_number_of_particles()) for pa in arrays}
    fluids = set(app.scheme.scheme.fluids if hasattr(app.scheme, "scheme")
                 else app.scheme.fluids)
    kernel = app.solver.kernel
    hs = np.concatenate([pa.get("h") for pa in arrays])
    R = kernel.radius_scale * float(hs.max())
    pc = count_pairs(arrays, fluids, R)
    integ = type(app.solver.integrator).__name__

    solver = app.solver
    stamps: list[float] = []
    cpu: list[float] = []  # process CPU time (all threads) at the same instants
    state = {"end": None}

    def cb(s):
        stamps.append(time.perf_counter())
        cpu.append(time.process_time())
        k = len(stamps)
        if k == a.warmup and state["end"] is None:
            # per-step time of the warm-up's second half, to size the timed blocks
            h = max(1, a.warmup // 2)
            per = (stamps[-1] - stamps[-1 - h]) / h if k > h else a.block_seconds
            steps = max(a.min_steps, int(round(a.block_seconds / max(per, 1e-9))))
            state["steps"] = steps
            state["end"] = k + a.blocks * steps
            s.set_max_steps(s.count + 1 + a.blocks * steps)

    solver.add_post_step_callback(cb)
    t1 = time.perf_counter()
    app.solve()
    solve_s = time.perf_counter() - t1
    steps = state["steps"]
    blocks = []
    cblocks = []
    for b in range(a.blocks):
        i0 = a.warmup - 1 + b * steps
        i1 = i0 + steps
        if i1 < len(stamps):
            blocks.append((stamps[i1] - stamps[i0]) / steps)
            cblocks.append((cpu[i1] - cpu[i0]) / steps)
    step_s = min(blocks)
    cpu_step_s = min(cblocks)
    n_total = sum(n_by.values())
    nf = sum(v for k, v in n_by.items() if k in fluids)
    evals = EVALS_PER_STEP.get(integ, 1)
    fin_ok = all(np.isfinite(pa.get("rho")).all() for pa in arrays)
    return {
        "code": "pysph", "case": case, "dx": a.dx, "threads": a.threads,
        "openmp": a.openmp, "n_fluid": nf, "n_total": n_total, "n_by_array": n_by,
        "kernel": f"{type(kernel).__name__}(dim={kernel.dim})", "support_R": R,
        "h": float(hs.max()),
        "h_uniform": bool(np.ptp(hs) < 1e-12 * hs.max()),
        "integrator": integ, "evals_per_step": evals,
        "nnps": type(app.nnps).__name__ if getattr(app, "nnps", None) else None,
        **pc,
        "setup_s": setup_s, "solve_s": solve_s, "warmup_steps": a.warmup,
        "steps_per_block": steps, "blocks": len(blocks), "block_step_s": blocks,
        "step_s": step_s,
        "cpu_step_s": cpu_step_s, "block_cpu_step_s": cblocks,
        "particle_steps_per_s": n_total / step_s,
        "cpu_particle_steps_per_s": n_total / cpu_step_s,
        "pairs_per_s": pc["pairs"] / step_s,
        "pair_evals_per_s": pc["pairs"] * evals / step_s,
        "finite_after_run": bool(fin_ok),
        "omp_num_threads_env": os.environ.get("OMP_NUM_THREADS"),
        "loadavg_end": loadavg(),
    }


# ------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------
def run_one(python, case, dx, threads, openmp=True, warmup=6, blocks=3, block_seconds=2.0,
            min_steps=3, timeout=3600) -> dict:
    """Run one worker in a fresh process (``python``: the PySPH venv's interpreter)."""
    env = dict(os.environ)
    env["OMP_NUM_THREADS"] = str(threads)
    cmd = [python, os.path.abspath(__file__), "--worker", "--case", case, "--dx", repr(dx),
           "--threads", str(threads), "--warmup", str(warmup), "--blocks", str(blocks),
           "--block-seconds", str(block_seconds), "--min-steps", str(min_steps)]
    if not openmp:
        cmd.append("--no-openmp")
    la0 = loadavg()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError(f"PySPH worker failed ({' '.join(cmd)}):\n{p.stderr[-4000:]}")
    line = [ln for ln in p.stdout.splitlines() if ln.startswith("{")][-1]
    r = json.loads(line)
    r["loadavg_start"] = la0
    r["command"] = f"OMP_NUM_THREADS={threads} " + " ".join(cmd)
    return r


def pysph_version(python) -> dict:
    code = ("import json, pysph, compyle, numpy, Cython; print(json.dumps({'pysph': "
            "pysph.__version__, 'compyle': compyle.__version__, 'numpy': numpy.__version__,"
            " 'cython': Cython.__version__}))")
    p = subprocess.run([python, "-c", code], capture_output=True, text=True)
    try:
        return json.loads(p.stdout.strip().splitlines()[-1])
    except Exception:  # noqa: BLE001
        return {"error": p.stderr[-500:]}


def fmt_row(r) -> str:
    return (f"| {r['case']} | {r['dx']:g} | {r['n_fluid']} | {r['n_total']} | {r['threads']}"
            f"{'' if r['openmp'] else ' (serial build)'} | {r['steps_per_block']}x"
            f"{r['blocks']} | {r['step_s'] * 1e3:.1f} | {r['particle_steps_per_s']:.3e} | "
            f"{r['pairs'] / r['n_total']:.1f} | {r['pairs_per_s']:.3e} | "
            f"{r['pair_evals_per_s']:.3e} | {r['loadavg_start']} |")


TABLE_HEAD = ("| case | dx | fluid | total | threads | steps | ms/step | particle-steps/s | "
              "pairs/particle | pairs/s | pair-evals/s | load avg (start) |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--case", nargs="+", default=["dam_break_2d", "dam_break_3d"])
    ap.add_argument("--dx", type=float, nargs="+", default=None,
                    help="spacings (default per case: 2D 0.01 and 0.0045, 3D 0.02)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--no-openmp", dest="openmp", action="store_false")
    ap.add_argument("--serial-too", action="store_true",
                    help="also run the non-OpenMP build for 1 thread")
    ap.add_argument("--warmup", type=int, default=6)
    ap.add_argument("--blocks", type=int, default=3)
    ap.add_argument("--block-seconds", type=float, default=2.0)
    ap.add_argument("--min-steps", type=int, default=3)
    ap.add_argument("--python", default=sys.executable, help="the PySPH venv's python")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    if a.worker:
        a.case = a.case[0]
        a.dx = a.dx[0]
        a.threads = a.threads[0]
        print(json.dumps(worker(a)), flush=True)
        return
    runs = []
    print(TABLE_HEAD, flush=True)
    for case in a.case:
        for dx in (a.dx or DEFAULT_DX[case]):
            confs = [(t, a.openmp) for t in a.threads]
            if a.serial_too and 1 in a.threads:
                confs.insert(0, (1, False))
            for t, omp in confs:
                r = run_one(a.python, case, dx, t, omp, a.warmup, a.blocks,
                            a.block_seconds, a.min_steps)
                runs.append(r)
                print(fmt_row(r), flush=True)
    out = {"versions": pysph_version(a.python), "runs": runs}
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()
