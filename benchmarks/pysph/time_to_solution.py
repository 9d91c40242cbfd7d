#!/usr/bin/env python
"""Time to solution: sphfem against PySPH on PySPH's own dam-break examples, in one run.

Run from the repository root with the project's Python and a PySPH venv (README.md)::

    python benchmarks/pysph/time_to_solution.py --pysph-python /tmp/pysph-venv/bin/python

Each case is run to a physical end time by both codes, interleaved (PySPH, ours, PySPH,
ours, ... for ``--rounds``), every run a fresh process with 2 threads
(``OMP_NUM_THREADS`` / ``NUMBA_NUM_THREADS``):

* PySPH: the example's ``Application`` built as ``pysph run <case> --openmp`` builds it
  (``--dx``, ``--tf``, ``--disable-output``; its recommended scheme, kernel, integrator and
  adaptive step), in a worker process of the PySPH venv (``--pysph-worker``);
* ours: a :class:`sphfem.fluid.wcsph.FluidSolver` on the same geometry and spacing, with
  the project's recommended settings (the ``dambreak`` validation case's: Wendland C2,
  support R = 3 dx, delta = 0.1, mu = 1e-3 Pa s, artificial viscosity alpha = 0.02, Adami
  walls, the symplectic scheme of Gomez-Gesteira et al. 2012 with one force evaluation per
  step, [time] cfl = 0.25 of h = R/2) and PySPH's c0 (10 times the dam-break speed
  sqrt(2 g H)), in a worker process of this Python (``--ours-worker``).

Neither code writes output in the timed part: both record the surge front (the largest
x of the fluid) in a post-step callback whenever a sample time (``--sample`` s) is passed.
The timed part is the stepping loop (PySPH: ``app.solve()``; ours: the adaptive-dt loop of
``FluidSolver.run``); set-up (PySPH: code generation and Cython compilation, cached in
``~/.pysph``; ours: numba, cached) is reported apart.

Front error (2D): Z = (front - left wall face + dx/2) / L against T = t sqrt(2 g / L), L the
column width (1 m): PySPH's own post-processing (``x.max()``, its wall face at dx/2) and
the ``dambreak`` validation case's definition, compared with Koshizuka & Oka (1996) and
Martin & Moyce (1952, n^2 = 2) as digitised in ``pysph/examples/db_exp_data.py`` at the
experiments' sample times (relative L2).  3D (SPHERIC test 2, Kleefsman et al. 2005): the
time the front reaches the obstacle's face x = 2.42 m against the experiment's pressure
rise at probe P1 on that face (T = t sqrt(g/H) = 1.575-1.672 in PySPH's digitised data).

End times: PySPH's ``dam_break_2d`` (1.0b2, as shipped, OpenMP or serial build) ends in a
segmentation fault at t ~ 0.94 s of its tf = 2.5 s here (its step falls from 1.8e-4 to
~3e-5 s once the surge has hit the right wall at t ~ 0.71 s; the same crash at 36 % of tf
is pypr/pysph issue 384), so the 2D comparison stops at t = 0.76 s (T = 3.37: every
experimental point).  At dx = 0.01 it crashes earlier, at t ~ 0.41 s, its step collapsing
from t ~ 0.37 s (during the surge, before any wall impact).  Its ``dam_break_3d`` takes
hours to its tf = 6 s ("14 hours" in its docstring); the 3D comparison runs to a stated
shorter time past the obstacle impact.

Threads: ``--threads`` for both codes (``OMP_NUM_THREADS`` / ``NUMBA_NUM_THREADS``; ours
also ``FluidParams.threads``, ``--ours-threads 0`` for the automatic choice).  Both
OpenMP runtimes get ``OMP_WAIT_POLICY=PASSIVE`` by default: on this shared machine GNU
OpenMP's spinning default made PySPH's 2-thread run 5-30x slower (threads spinning at
barriers while their partner waits for a core), which would flatter us.

Writes ``tts.json``, ``TIME_TO_SOLUTION.md`` and ``tts_front.png`` (``--out``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from run_pysph import loadavg  # noqa: E402  (no sphfem import: usable in the PySPH venv)

G = 9.81

#: Koshizuka & Oka (1996): Z = x/L against T = t sqrt(2 g / L), column L x 2L (PySPH's
#: db_exp_data.ko_data; also sphfem.validation.fluid.KOSHIZUKA_OKA)
KOSHIZUKA_OKA = [(0.0, 1.000), (0.381, 1.111), (0.769, 1.252), (1.153, 1.505),
                 (1.537, 1.892), (1.935, 2.241), (2.323, 2.615), (2.719, 3.003),
                 (3.096, 3.624)]
#: Martin & Moyce (1952), n^2 = 2, a = 2.25 in, up to Z = 4 (db_exp_data.mm_data_2)
MARTIN_MOYCE = [(0.832, 1.217), (1.219, 1.474), (1.997, 2.292), (2.547, 2.995),
                (3.345, 4.134)]
#: Kleefsman et al. (2005) probe P1 (x = 2.42 m, z = 0.021 m): last sample before the
#: pressure rise and first one on it, T = t sqrt(g / H) (db_exp_data.kleefsman_exp_data_p1)
KLEEFSMAN_P1_RISE = (1.575, 1.672)

#: the cases: PySPH example, its default tf, column height H and width L, front target
CASES = {
    "2d": {"example": "dam_break_2d", "dx": 0.03, "tf": 2.5, "H": 2.0, "L": 1.0},
    "3d": {"example": "dam_break_3d", "dx": 0.02, "tf": 6.0, "H": 0.55, "L": 1.228},
}


def _front_recorder(samples: list, every: float):
    """A closure recording (t, front) whenever t passed the next multiple of ``every``."""
    state = {"next": every}

    def record(t: float, front_fn) -> None:
        if t >= state["next"] * (1 - 1e-12):
            samples.append((t, front_fn()))
            while state["next"] <= t * (1 + 1e-12):
                state["next"] += every

    return record


# ------------------------------------------------------------------------------------------
# PySPH worker (runs in the PySPH venv; imports nothing of sphfem)
# ------------------------------------------------------------------------------------------
def pysph_worker(a) -> dict:
    import importlib
    import tempfile

    import numpy as np

    case = CASES[a.case]
    name = case["example"]
    mod = importlib.import_module("pysph.examples." + name)
    outdir = tempfile.mkdtemp(prefix=f"pysph_tts_{name}_")
    if name == "dam_break_2d":
        # the example gives its particles the module constants h and m (from its default
        # dx = 0.03), not self.h: set them from --dx (a no-op at the default spacing)
        mod.h = mod.hdx * a.dx
        mod.m = mod.ro * a.dx**2
        app = mod.DamBreak2D(fname=name, output_dir=outdir)
    else:
        app = mod.DamBreak3D(fname=name, output_dir=outdir)
    argv = ["--dx", repr(a.dx), "--tf", repr(a.t_end), "--disable-output", "-q",
            "-d", outdir, "--openmp"]
    if a.pysph_scheme[0] != "wcsph":  # dam_break_2d's SchemeChooser (3D: WCSPH only)
        argv += ["--scheme", a.pysph_scheme[0]]
    t0 = time.perf_counter()
    app.setup(argv)
    setup_s = time.perf_counter() - t0
    fluid = [pa for pa in app.particles if pa.name == "fluid"][0]
    n_by = {pa.name: int(pa.get_number_of_particles()) for pa in app.particles}
    x_face = 0.5 * a.dx  # left wall face: its inner layer at x = 0, the fluid from dx
    samples: list = [(0.0, float(fluid.x.max()) - x_face + 0.5 * a.dx)]
    record = _front_recorder(samples, a.sample)
    dts: list = []

    progress = os.environ.get("TTS_PROGRESS")  # print t, front every N steps (debugging)

    def cb(s):  # called before s.t += s.dt
        dts.append(s.dt)
        if progress and len(dts) % int(progress) == 0:
            print(f"step {len(dts)} t {s.t + s.dt:.4f} front {fluid.x.max():.4f} "
                  f"ymax {fluid.y.max():.3f}", file=sys.stderr, flush=True)
        record(s.t + s.dt, lambda: float(fluid.x.max()) - x_face + 0.5 * a.dx)

    app.solver.add_post_step_callback(cb)
    t1 = time.perf_counter()
    c1 = time.process_time()
    app.solve()
    solve_s = time.perf_counter() - t1
    cpu_s = time.process_time() - c1
    solver = app.solver
    dt = np.asarray(dts)
    return {
        "code": "pysph", "case": a.case, "example": name, "scheme": a.pysph_scheme[0],
        "dx": a.dx,
        "n_by_array": n_by, "n_fluid": n_by["fluid"], "n_total": sum(n_by.values()),
        "integrator": type(solver.integrator).__name__,
        "h": float(fluid.h.max()), "kernel": type(solver.kernel).__name__,
        "setup_s": setup_s, "solve_s": solve_s, "cpu_s": cpu_s, "steps": int(solver.count),
        "t_end": float(solver.t), "dt_mean": float(solver.t) / max(1, solver.count),
        "dt_min": float(dt.min()), "dt_max": float(dt.max()), "front": samples,
        "finite": bool(np.isfinite(fluid.x).all()),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "loadavg_end": loadavg(),
    }


# ------------------------------------------------------------------------------------------
# our worker (the project's Python)
# ------------------------------------------------------------------------------------------
def build_ours_2d(dx: float, R_over_dx: float = 3.0, alpha: float = 0.02, cfl: float = 0.25,
                  threads: int = 0, pressure: str = "wcsph", skin: float | None = None):
    """PySPH dam_break_2d in sphfem: its column (1/dx + 1) x (2/dx + 1) particles, spacing
    dx, standing on the floor at the left wall of a 4 x 4 tank (3 Adami layers);
    ``pressure``: the [fluid] pressure method (:func:`_fluid_start`); ``skin``: the Verlet
    skin (None: FluidParams' default)."""
    import numpy as np

    from sphfem.fluid.setup import box_walls, hydrostatic_density, lattice, make_particles
    from sphfem.fluid.wcsph import FluidParams, FluidSolver

    H = CASES["2d"]["H"]
    nx, ny = int(1.0 / dx) + 1, int(H / dx) + 1  # as pysph.tools.geometry.get_2d_block
    xf = lattice([0.0, 0.0], [nx * dx, ny * dx], dx)
    layers = int(np.ceil(R_over_dx))
    xw = box_walls([0.0, 0.0], [4.0, 4.0], dx, layers)
    c0 = 10.0 * math.sqrt(2 * G * H)  # PySPH's co
    rhof = (hydrostatic_density(ny * dx - xf[:, 1], 1000.0, c0, G) if pressure == "wcsph"
            else None)
    ps = make_particles(xf, xw, dx, 1000.0, rhof)
    par = FluidParams(c0=c0, mu=1e-3, gravity=(0.0, -G), alpha=alpha, cfl=cfl,
                      threads=threads, pressure=pressure,
                      **({} if skin is None else {"skin": skin}))
    m = (layers + 1) * dx
    s = FluidSolver(ps, R_over_dx * dx, [-m, -m], [4.0 + m, 8.0], params=par)
    return _fluid_start(s, ny * dx, pressure), 0.0


def _fluid_start(s, top: float, pressure: str):
    """A projection method (IISPH, DFSPH) starts from the lattice at rho0 with the
    hydrostatic pressure rho0 g (top - z) as its first solve's initial guess (the
    ``dambreak-dfsph`` validation's start); WCSPH from the hydrostatic density (set by the
    builder)."""
    if pressure != "wcsph":
        from sphfem.particles import FLUID

        fl = s.p.kind == FLUID
        s.p.p[fl] = 1000.0 * G * (top - s.p.x[fl, -1])
    return s


def pysph_3d_boxes(dx: float) -> dict:
    """Boxes (lo, hi) of PySPH dam_break_3d's particle sets on its lattice (points at
    multiples of dx in x and z, at -0.5 + k dx in y; each box reaches dx/2 beyond its
    outer points): the tank's inside (its inner wall layer on x = 0, 3.22, y = +-0.5,
    z = 0), the fluid column (0 < x <= 1.228, |y| < 0.5, 0 < z <= 0.55) and the obstacle
    (2.42 <= x <= 2.58, |y| <= 0.2, 0 < z <= 0.161)."""
    eps = 1e-9 * dx

    def span(a, b, off=0.0, open_a=True, open_b=False):
        k0 = math.floor((a - off) / dx + eps) + (1 if open_a else 0)
        if not open_a and abs((a - off) / dx - round((a - off) / dx)) > 1e-9:
            k0 = math.ceil((a - off) / dx)
        k1 = math.ceil((b - off) / dx - eps) - (1 if open_b else 0)
        if not open_b and abs((b - off) / dx - round((b - off) / dx)) > 1e-9:
            k1 = math.floor((b - off) / dx)
        return off + (k0 - 0.5) * dx, off + (k1 + 0.5) * dx

    fx, fy, fz = span(0.0, 1.228), span(-0.5, 0.5, -0.5, True, True), span(0.0, 0.55)
    ox = span(2.42, 2.58, 0.0, False, False)
    oy = span(-0.2, 0.2, -0.5, False, False)
    oz = span(0.0, 0.161)
    tx, ty = span(0.0, 3.22, 0.0, True, True), span(-0.5, 0.5, -0.5, True, True)
    return {"fluid": ([fx[0], fy[0], fz[0]], [fx[1], fy[1], fz[1]]),
            "obstacle": ([ox[0], oy[0], oz[0]], [ox[1], oy[1], oz[1]]),
            "tank": ([tx[0], ty[0], 0.5 * dx], [tx[1], ty[1], 1.0])}


def build_ours_3d(dx: float, R_over_dx: float = 3.0, alpha: float = 0.02, cfl: float = 0.25,
                  threads: int = 0, pressure: str = "wcsph", skin: float | None = None):
    """PySPH dam_break_3d (SPHERIC test 2) in sphfem, in the example's coordinates: the
    same fluid and obstacle particles (:func:`pysph_3d_boxes`; the obstacle filled with
    wall particles), the tank's inside bounded by 3 Adami layers whose inner one sits where
    PySPH's single layer sits."""
    import numpy as np

    from sphfem.fluid.setup import box_walls, hydrostatic_density, lattice, make_particles
    from sphfem.fluid.wcsph import FluidParams, FluidSolver

    H = CASES["3d"]["H"]
    b = pysph_3d_boxes(dx)
    xf = lattice(*b["fluid"], dx)
    layers = int(np.ceil(R_over_dx))
    xw = box_walls(*b["tank"], dx, layers)
    xo = lattice(*b["obstacle"], dx)
    c0 = 10.0 * math.sqrt(2 * G * H)  # the example's c0 = 10 sqrt(2 g H)
    top = b["fluid"][1][2]
    rhof = (hydrostatic_density(top - xf[:, 2], 1000.0, c0, G) if pressure == "wcsph"
            else None)
    ps = make_particles(xf, np.vstack([xw, xo]), dx, 1000.0, rhof)
    par = FluidParams(c0=c0, mu=1e-3, gravity=(0.0, 0.0, -G), alpha=alpha, cfl=cfl,
                      threads=threads, pressure=pressure,
                      **({} if skin is None else {"skin": skin}))
    m = (layers + 1) * dx
    lo, hi = b["tank"]
    s = FluidSolver(ps, R_over_dx * dx, [lo[0] - m, lo[1] - m, lo[2] - m],
                    [hi[0] + m, hi[1] + m, 2.0], params=par)
    return _fluid_start(s, top, pressure), lo[0]


def ours_worker(a) -> dict:
    import numba
    import numpy as np

    from sphfem.particles import FLUID

    t0 = time.perf_counter()
    build = build_ours_2d if a.case == "2d" else build_ours_3d
    s, x_face = build(a.dx, a.R_over_dx, a.alpha, a.cfl, a.ours_threads, a.pressure[0],
                      a.skin)
    setup_s = time.perf_counter() - t0
    fl = s.p.kind == FLUID

    def front():
        p = s.p  # a cell sort permutes the set: take the kind mask anew
        return float(p.x[p.kind == FLUID, 0].max()) - x_face + 0.5 * a.dx

    samples: list = [(0.0, front())]
    record = _front_recorder(samples, a.sample)
    wall0 = dict(s.wall)
    rebuilds0 = s.n_rebuilds
    dts: list = []
    limits: dict = {}
    t_end = a.t_end
    t1 = time.perf_counter()
    c1 = time.process_time()
    while s.t < t_end * (1 - 1e-12):  # FluidSolver.run's loop, the front sampled
        dt, name = s.stable_dt()
        dt = min(dt, t_end - s.t)
        s.step(dt)
        s.check()
        dts.append(dt)
        limits[name] = limits.get(name, 0) + 1
        record(s.t, front)
    solve_s = time.perf_counter() - t1
    cpu_s = time.process_time() - c1
    wall = {k: s.wall[k] - wall0.get(k, 0.0) for k in s.wall}
    wall["dt_and_loop"] = solve_s - sum(wall.values())
    dt = np.asarray(dts)
    d = s.diagnostics()
    return {
        "code": "sphfem", "case": a.case, "pressure": a.pressure[0], "dx": a.dx,
        "R_over_dx": a.R_over_dx, "skin": s.params.skin,
        "alpha": a.alpha, "cfl": a.cfl, "c0": s.params.c0,
        "n_fluid": int(fl.sum()), "n_total": int(s.p.n), "threads_fluid": s.nthreads,
        "numba_threads": numba.get_num_threads(), "setup_s": setup_s, "solve_s": solve_s,
        "cpu_s": cpu_s, "steps": len(dts), "t_end": float(s.t),
        "dt_mean": float(s.t) / max(1, len(dts)), "dt_min": float(dt.min()),
        "dt_max": float(dt.max()), "controlling_limit_counts": limits,
        "front": samples, "wall_s": wall,
        "neighbor_rebuilds": s.n_rebuilds - rebuilds0,
        "neighbor_share": wall["neighbors"] / solve_s,
        "rho_ratio_range": d["rho_ratio_range"], "max_speed": d["max_speed"],
        "pressure_solve": d.get("pressure_solve"),  # projection: iterations, density error
        "loadavg_end": loadavg(),
    }


# ------------------------------------------------------------------------------------------
# front errors
# ------------------------------------------------------------------------------------------
def _interp(x, xp, fp):
    """Linear interpolation (numpy-free, for both interpreters); xp ascending."""
    out = []
    for xi in x:
        if xi <= xp[0]:
            out.append(fp[0])
            continue
        if xi >= xp[-1]:
            out.append(fp[-1])
            continue
        k = next(j for j in range(1, len(xp)) if xp[j] >= xi)
        w = (xi - xp[k - 1]) / (xp[k] - xp[k - 1])
        out.append(fp[k - 1] + w * (fp[k] - fp[k - 1]))
    return out


def front_errors_2d(front, L: float) -> dict:
    """Relative L2 distance of Z(T) to Koshizuka & Oka and Martin & Moyce at their times."""
    scale = math.sqrt(2 * G / L)
    T = [t * scale for t, _ in front]
    Z = [x / L for _, x in front]
    out = {}
    for key, data in (("koshizuka_oka", KOSHIZUKA_OKA), ("martin_moyce", MARTIN_MOYCE)):
        te = [d[0] for d in data if d[0] <= T[-1]]
        ze = [d[1] for d in data if d[0] <= T[-1]]
        if not te:
            out[key] = out[key + "_max_abs"] = float("nan")
            continue
        zc = _interp(te, T, Z)
        num = sum((c - e) ** 2 for c, e in zip(zc, ze, strict=True))
        den = sum(e * e for e in ze)
        out[key] = math.sqrt(num / den) if den else float("nan")
        out[key + "_max_abs"] = max(abs(c - e) for c, e in zip(zc, ze, strict=True))
    out["Z_at_T3"] = _interp([3.0], T, Z)[0] if T[-1] >= 3.0 else None
    return out


def arrival_3d(front, x_target: float, H: float) -> dict:
    """Time the front reaches ``x_target`` (linear between samples) against the pressure
    rise at Kleefsman's probe P1 (midpoint of the two samples bracketing it)."""
    t_arr = None
    for (t0, x0), (t1, x1) in zip(front[:-1], front[1:], strict=True):
        if x0 < x_target <= x1:
            t_arr = t0 + (x_target - x0) / (x1 - x0) * (t1 - t0)
            break
    s = math.sqrt(G / H)
    lo, hi = (T / s for T in KLEEFSMAN_P1_RISE)
    t_exp = 0.5 * (lo + hi)
    return {"t_arrival": t_arr, "t_exp": t_exp, "t_exp_window": [lo, hi],
            "arrival_rel_err": (None if t_arr is None else abs(t_arr - t_exp) / t_exp)}


# ------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------
def _run(cmd, env_extra, timeout) -> dict:
    env = dict(os.environ)
    env.update(env_extra)
    la0 = loadavg()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError(f"worker failed ({' '.join(cmd)}):\n{p.stderr[-4000:]}")
    r = json.loads([ln for ln in p.stdout.splitlines() if ln.startswith("{")][-1])
    r["loadavg_start"] = la0
    r["command"] = " ".join(f"{k}={v}" for k, v in env_extra.items()) + " " + " ".join(cmd)
    return r


def run_pysph(python, case, dx, t_end, sample, threads, wait_policy, scheme="wcsph",
              timeout=7200) -> dict:
    cmd = [python, os.path.abspath(__file__), "--pysph-worker", "--case", case,
           "--dx", repr(dx), "--t-end", repr(t_end), "--sample", repr(sample),
           "--pysph-scheme", scheme]
    env = {"OMP_NUM_THREADS": str(threads)}
    if wait_policy:
        env["OMP_WAIT_POLICY"] = wait_policy
    return _run(cmd, env, timeout)


def run_ours(case, dx, t_end, sample, threads, R_over_dx, alpha, cfl, wait_policy,
             ours_threads, pressure="wcsph", timeout=7200, skin=None) -> dict:
    cmd = [sys.executable, os.path.abspath(__file__), "--ours-worker", "--case", case,
           "--dx", repr(dx), "--t-end", repr(t_end), "--sample", repr(sample),
           "--R-over-dx", repr(R_over_dx), "--alpha", repr(alpha), "--cfl", repr(cfl),
           "--ours-threads", str(ours_threads), "--pressure", pressure]
    if skin is not None:
        cmd += ["--skin", repr(skin)]
    env = {"NUMBA_NUM_THREADS": str(threads)}
    if wait_policy:  # numba's threading layer is OpenMP here too: the same policy
        env["OMP_WAIT_POLICY"] = wait_policy
    return _run(cmd, env, timeout)


def add_errors(r, case) -> None:
    c = CASES[case]
    if case == "2d":
        r["front_error"] = front_errors_2d(r["front"], c["L"])
    else:
        r["front_error"] = arrival_3d(r["front"], obstacle_front_3d(r["dx"]), c["H"])


def obstacle_front_3d(dx: float) -> float:
    """The front value (largest fluid x, PySPH's convention: the leading particle's edge
    measured from the left wall face at dx/2) at which the fluid touches the obstacle's
    face (its lattice box starts dx/2 before its first particles)."""
    return pysph_3d_boxes(dx)["obstacle"][0][0] - 0.5 * dx


def summarise(runs) -> dict:
    """Per label: min / median wall and CPU seconds; per sphfem label the ratios to PySPH
    (wall time, steps, cost per step)."""
    out = {}
    for lab in dict.fromkeys(r["label"] for r in runs):
        rs = [r for r in runs if r["label"] == lab]
        w = [r["solve_s"] for r in rs]
        c = [r["cpu_s"] for r in rs]
        out[lab] = {"min_s": min(w), "median_s": statistics.median(w), "all_s": w,
                    "cpu_min_s": min(c), "steps": rs[0]["steps"]}
    p = out.get("pysph")
    for lab, o in out.items():
        if lab.startswith("pysph") or p is None:
            continue
        o["speedup_min_vs"] = {q: out[q]["min_s"] / o["min_s"] for q in out
                               if q.startswith("pysph")}
        o["speedup_min"] = p["min_s"] / o["min_s"]
        o["speedup_median"] = p["median_s"] / o["median_s"]
        o["speedup_cpu"] = p["cpu_min_s"] / o["cpu_min_s"]
        o["steps_ratio"] = p["steps"] / o["steps"]
        o["per_step_cost_ratio"] = o["speedup_min"] / o["steps_ratio"]
    return out


def markdown(res) -> str:
    L = ["# Time to solution: sphfem vs PySPH dam-break examples\n",
         f"Generated by `benchmarks/pysph/time_to_solution.py` on {res['date']} (git "
         f"`{res['git_head'][:12]}`), {res['threads']} threads per code "
         f"(OMP_WAIT_POLICY={res['omp_wait_policy'] or 'unset'}), runs interleaved "
         f"(PySPH, ours, ...).  Load average (1/5/15 min) at start {res['loadavg_start']}, "
         f"at end {res['loadavg_end']}.\n", f"Command: `{res['command']}`\n"]
    for case, cr in res["cases"].items():
        L.append(f"## {case}: PySPH `{CASES[case]['example']}`, dx = {cr['dx']:g}, "
                 f"t_end = {cr['t_end']:g} s\n")
        if case == "2d":
            L.append("| code | round | particles (fluid / total) | wall s | CPU s | steps | "
                     "mean dt [s] | front err vs K&O | vs M&M | Z(T=3) | load start |")
            L.append("|---|---|---|---|---|---|---|---|---|---|---|")
        else:
            L.append("| code | round | particles (fluid / total) | wall s | CPU s | steps | "
                     "mean dt [s] | front at the obstacle [s] | err vs Kleefsman P1 rise | "
                     "load start |")
            L.append("|---|---|---|---|---|---|---|---|---|---|")
        for r in cr["runs"]:
            e = r["front_error"]
            head = (f"| {r['label']} | {r['round']} | {r['n_fluid']} / {r['n_total']} | "
                    f"{r['solve_s']:.1f} | {r['cpu_s']:.1f} | {r['steps']} | "
                    f"{r['dt_mean']:.3e} | ")
            if case == "2d":
                z3 = "-" if e["Z_at_T3"] is None else f"{e['Z_at_T3']:.3f}"
                L.append(head + f"{100 * e['koshizuka_oka']:.1f} % | "
                         f"{100 * e['martin_moyce']:.1f} % | {z3} | {r['loadavg_start']} |")
            else:
                ta = "-" if e["t_arrival"] is None else f"{e['t_arrival']:.3f}"
                er = ("-" if e["arrival_rel_err"] is None
                      else f"{100 * e['arrival_rel_err']:.1f} %")
                L.append(head + f"{ta} | {er} | {r['loadavg_start']} |")
        L.append("")
        for lab, o in cr["summary"].items():
            if "speedup_min" not in o:
                continue
            L.append(f"* PySPH / {lab}: wall **{o['speedup_min']:.2f}x** (minima), "
                     f"{o['speedup_median']:.2f}x (medians), CPU seconds "
                     f"{o['speedup_cpu']:.2f}x; steps ratio {o['steps_ratio']:.2f}, wall "
                     f"cost per step ratio {o['per_step_cost_ratio']:.2f}"
                     + "".join(f"; {q} / {lab}: {v:.2f}x"
                               for q, v in o.get("speedup_min_vs", {}).items() if q != "pysph")
                     + ".")
        L.append("")
        for lab in dict.fromkeys(r["label"] for r in cr["runs"] if r["code"] == "sphfem"):
            r = min((r for r in cr["runs"] if r["label"] == lab), key=lambda r: r["solve_s"])
            w = r["wall_s"]
            L.append(f"{lab}, fastest run, where the stepping time goes (the fluid module's "
                     "timers): " + ", ".join(f"{k} {v:.2f} s ({100 * v / r['solve_s']:.1f} %)"
                                             for k, v in w.items())
                     + (f"; pressure solve {json.dumps(r['pressure_solve'])}"
                        if r.get("pressure_solve") else "")
                     + f"; {r['neighbor_rebuilds']} list rebuilds in {r['steps']} steps "
                     f"(one per {r['steps'] / max(1, r['neighbor_rebuilds']):.1f}); "
                     f"controlling dt limit: {r['controlling_limit_counts']}.\n")
    return "\n".join(L)


def plot(res, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(res["cases"])
    fig, axes = plt.subplots(1, len(cases), figsize=(6 * len(cases), 4.5), squeeze=False)
    for ax, case in zip(axes[0], cases, strict=True):
        cr = res["cases"][case]
        c = CASES[case]
        for lab in dict.fromkeys(r["label"] for r in cr["runs"]):
            rs = [r for r in cr["runs"] if r["label"] == lab]
            style = "-" if lab == "pysph" else "--"
            code = lab
            f = rs[0]["front"]
            if case == "2d":
                s = math.sqrt(2 * G / c["L"])
                ax.plot([t * s for t, _ in f], [x / c["L"] for _, x in f], style,
                        label=f"{code} ({rs[0]['steps']} steps)")
            else:
                ax.plot([t for t, _ in f], [x for _, x in f], style,
                        label=f"{code} ({rs[0]['steps']} steps)")
        if case == "2d":
            ax.plot(*zip(*KOSHIZUKA_OKA, strict=True), "o", label="Koshizuka & Oka (1996)")
            ax.plot(*zip(*MARTIN_MOYCE, strict=True), "s", label="Martin & Moyce (1952)")
            ax.set_xlabel("T = t sqrt(2g/L)")
            ax.set_ylabel("Z = front / L")
            ax.set_xlim(0, 3.5)
            ax.set_ylim(1, 4.5)
        else:
            lo, hi = (T / math.sqrt(G / c["H"]) for T in KLEEFSMAN_P1_RISE)
            ax.axvspan(lo, hi, color="0.8", label="Kleefsman P1 pressure rise")
            ax.axhline(obstacle_front_3d(cr["dx"]), color="k", lw=0.8,
                       label="fluid touches the obstacle")
            ax.set_xlabel("t [s]")
            ax.set_ylabel("front: largest fluid x [m]")
        ax.set_title(f"{c['example']}, dx = {cr['dx']:g}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pysph-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--ours-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--case", default="2d", choices=list(CASES), help=argparse.SUPPRESS)
    ap.add_argument("--cases", nargs="+", default=["2d"], choices=list(CASES))
    ap.add_argument("--dx", nargs="+", default=[],
                    help="spacing, CASE=DX or DX (default: the example's, 2D 0.03, 3D 0.02)")
    ap.add_argument("--t-end", nargs="+", default=[],
                    help="physical end time, CASE=T or T (default: the example's tf, 2D "
                         "2.5 s, 3D 6 s)")
    ap.add_argument("--sample", type=float, default=0.005, help="front sample interval [s]")
    ap.add_argument("--threads", type=int, default=2, help="threads of each code")
    ap.add_argument("--ours-threads", type=int, default=None,
                    help="FluidParams.threads of ours (default: --threads; 0: automatic, "
                         "one thread below 20,000 particles)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--R-over-dx", type=float, default=3.0)
    ap.add_argument("--skin", type=float, default=None,
                    help="Verlet skin of ours as a fraction of R (default: FluidParams')")
    ap.add_argument("--alpha", type=float, default=0.02)
    ap.add_argument("--cfl", type=float, nargs="+", default=[0.25],
                    help="[time] cfl of ours; several: one sphfem variant each (the first "
                         "is the recommended setting)")
    ap.add_argument("--pressure", nargs="+", default=["wcsph"],
                    choices=["wcsph", "iisph", "dfsph"],
                    help="[fluid] pressure method(s) of ours; one sphfem variant per method "
                         "and cfl (a projection method's cfl bounds h / |v|max, not the "
                         "acoustic limit)")
    ap.add_argument("--pysph-scheme", nargs="+", default=["wcsph"],
                    help="PySPH schemes of dam_break_2d (its --scheme: wcsph, the example's "
                         "default, iisph, ...); one PySPH variant each, the first the "
                         "baseline of the ratios; dam_break_3d has WCSPH only")
    ap.add_argument("--pysph-python", default="/tmp/pysph-venv/bin/python")
    ap.add_argument("--omp-wait-policy", default="PASSIVE",
                    help="OMP_WAIT_POLICY of both codes' workers ('' = unset: GNU OpenMP's "
                         "spinning default, which collapses on a loaded machine)")
    ap.add_argument("--out", default=HERE)
    ap.add_argument("--from-json", help="rewrite the report (errors, markdown, PNG) of a "
                    "tts.json without running anything")
    a = ap.parse_args(argv)
    if a.from_json:
        with open(a.from_json) as f:
            res = json.load(f)
        for case, cr in res["cases"].items():
            for r in cr["runs"]:
                add_errors(r, case)
            cr["summary"] = summarise(cr["runs"])
        write_report(res, a.out)
        return
    if a.ours_threads is None:
        a.ours_threads = a.threads

    def per_case(vals, case, key):
        out = CASES[case][key]
        for v in vals:
            c, _, x = v.rpartition("=")
            if c in ("", case):
                out = float(x)
        return out

    if a.pysph_worker or a.ours_worker:
        a.dx = per_case(a.dx, a.case, "dx")
        a.t_end = per_case(a.t_end, a.case, "tf")
        a.cfl = a.cfl[0]
        r = pysph_worker(a) if a.pysph_worker else ours_worker(a)
        print(json.dumps(r), flush=True)
        return

    from compare import git_head  # the driver only: compare imports sphfem and numba

    from sphfem.machine import machine_info

    res = {"date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
           "machine": machine_info(), "git_head": git_head(), "loadavg_start": loadavg(),
           "threads": a.threads,
           "ours_threads": a.ours_threads, "omp_wait_policy": a.omp_wait_policy,
           "command": " ".join(["python"] + sys.argv), "cases": {}}
    for case in a.cases:
        dx = per_case(a.dx, case, "dx")
        t_end = per_case(a.t_end, case, "tf")
        runs = []
        for rnd in range(a.rounds):
            schemes = a.pysph_scheme if case == "2d" else ["wcsph"]
            for code, cfl, pm in [("pysph", None, sc) for sc in schemes] + [
                    ("sphfem", c, m) for m in a.pressure for c in a.cfl]:
                if code == "pysph":
                    r = run_pysph(a.pysph_python, case, dx, t_end, a.sample, a.threads,
                                  a.omp_wait_policy, pm)
                    r["label"] = "pysph" if pm == schemes[0] else f"pysph {pm}"
                else:
                    r = run_ours(case, dx, t_end, a.sample, a.threads, a.R_over_dx,
                                 a.alpha, cfl, a.omp_wait_policy, a.ours_threads, pm,
                                 skin=a.skin)
                    r["label"] = ("sphfem " + ("" if pm == "wcsph" else pm + " ")
                                  + f"cfl={cfl:g}")
                r["round"] = rnd
                add_errors(r, case)
                runs.append(r)
                err = {k: v for k, v in r["front_error"].items()
                       if k in ("koshizuka_oka", "martin_moyce", "arrival_rel_err")}
                print(f"[{case} r{rnd}] {r['label']:16s} n={r['n_total']:>7} {r['solve_s']:8.1f} s "
                      f"{r['steps']:>7} steps dt {r['dt_mean']:.3e} err {json.dumps(err)} "
                      f"load {r['loadavg_start']}", flush=True)
        res["cases"][case] = {"dx": dx, "t_end": t_end, "runs": runs,
                              "summary": summarise(runs)}
    res["loadavg_end"] = loadavg()
    write_report(res, a.out)


def write_report(res, out) -> None:
    """tts.json, TIME_TO_SOLUTION.md and tts_front.png in ``out``."""
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "tts.json"), "w") as f:
        json.dump(res, f, indent=1)
    md = markdown(res)
    with open(os.path.join(out, "TIME_TO_SOLUTION.md"), "w") as f:
        f.write(md)
    plot(res, os.path.join(out, "tts_front.png"))
    print(md)


if __name__ == "__main__":
    main()
