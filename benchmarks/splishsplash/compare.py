"""sphfem against SPlisHSPlasH on SPlisHSPlasH's DamBreakModel, paired, in one run.

For each round and each pressure method (DFSPH, IISPH) the two codes run one after the
other as separate processes (SPlisHSPlasH first, then each sphfem variant), so every
sphfem run has a SPlisHSPlasH run beside it on the machine's load of that moment; the
ratios are taken pair by pair.  Same geometry, particle positions and count (particle
radius), density-error tolerance, DFSPH divergence tolerance, viscosity, step rule and
physical end time (see ``run_splishsplash.py`` and ``run_sphfem.py``).

    python benchmarks/splishsplash/compare.py --splash-python /work/venvs/splash/bin/python \
        --radius 0.0125 --stop-at 0.25 --rounds 3

Writes ``results.json`` (every run) and ``RESULTS.md`` (min / median / max per figure and
the paired ratios) into ``--out`` (default: this folder).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
#: sphfem variants: name -> (kernel, R / (2 r))
VARIANTS = {"wendland-3dx": ("wendland_c2", 3.0), "cubic-2dx": ("cubic_spline", 2.0)}
#: the preload that lets the pysplishsplash wheel import on Debian (see README.md)
GL_PRELOAD = "/lib/x86_64-linux-gnu/libGLdispatch.so.0"


def _last_json(text: str) -> dict:
    for line in reversed(text.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    raise RuntimeError("no JSON line in the output:\n" + text[-2000:])


def run_splash(py: str, method: str, a, stop_at: float) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS=str(a.threads))
    if os.path.exists(GL_PRELOAD):
        env["LD_PRELOAD"] = GL_PRELOAD
    cmd = [py, str(HERE / "run_splishsplash.py"), "--method", method, "--radius",
           str(a.radius), "--stop-at", str(stop_at), "--max-error", str(a.max_error),
           "--max-error-v", str(a.max_error_v), "--workdir", str(a.workdir)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    out = _last_json(r.stdout)
    for line in r.stdout.splitlines():  # SPlisHSPlasH's own timer of its steps
        if line.startswith("Time sum: SimStep:"):
            out["simstep_s"] = float(line.split()[3]) / 1e3
    return out


def run_ours(method: str, variant: str, a, stop_at: float) -> dict:
    kernel, support = VARIANTS[variant]
    env = dict(os.environ, NUMBA_NUM_THREADS=str(a.threads))
    cmd = [sys.executable, str(HERE / "run_sphfem.py"), "--method", method, "--radius",
           str(a.radius), "--stop-at", str(stop_at), "--max-error", str(a.max_error),
           "--max-error-v", str(a.max_error_v), "--kernel", kernel, "--support",
           str(support), "--threads", str(a.threads)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    out = _last_json(r.stdout)
    out["variant"] = variant
    return out


def _mmm(v) -> str:
    v = np.asarray(v, float)
    return f"{v.min():.3g} / {np.median(v):.3g} / {v.max():.3g}"


def report(runs: list, a, loads: list) -> str:
    """RESULTS.md: per method and code the figures (min / median / max over rounds) and
    the paired ratios sphfem / SPlisHSPlasH."""
    lines = [
        "# sphfem vs SPlisHSPlasH, DamBreakModel (written by compare.py)",
        "",
        f"Particle radius {a.radius} m, end time {a.stop_at} s, {a.threads} threads each, "
        f"{a.rounds} rounds (SPlisHSPlasH then sphfem, alternating); density-error "
        f"tolerance {a.max_error} %, DFSPH divergence tolerance {a.max_error_v} %.  "
        f"Load average (1 min) at each round's start: {', '.join(f'{x:.1f}' for x in loads)} "
        f"on 2 cores.  Figures: min / median / max over the rounds.  particle-steps/s "
        f"counts fluid particles (SPlisHSPlasH has no wall particles; sphfem's are listed).",
        "",
    ]
    for method in ("dfsph", "iisph"):
        sp = [r for r in runs if r["code"] == "SPlisHSPlasH" and r["method"] == method]
        if not sp:
            continue
        lines += [f"## {method.upper()}", "",
                  "| code | fluid (wall) particles | steps | mean dt [ms] | it/step | "
                  "div it/step | wall s to t_end | particle-steps/s |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]
        groups = [("SPlisHSPlasH (cubic, R = 2 dx, volume maps)", sp)]
        for v in VARIANTS:
            ours = [r for r in runs if r["code"] == "sphfem" and r["method"] == method
                    and r["variant"] == v]
            if ours:
                groups.append((f"sphfem {v}", ours))
        for name, rs in groups:
            walls = rs[0].get("wall_particles")
            lines.append(
                f"| {name} | {rs[0]['fluid_particles']:,}"
                + (f" ({walls:,})" if walls else "") + " | "
                + f"{_mmm([r['steps'] for r in rs])} | "
                + f"{_mmm([1e3 * r['mean_dt'] for r in rs])} | "
                + f"{_mmm([r['it_mean'] for r in rs])} | "
                + (f"{_mmm([r['div_it_mean'] for r in rs])}" if "div_it_mean" in rs[0]
                   else "-") + " | "
                + f"{_mmm([r['wall_s'] for r in rs])} | "
                + f"{_mmm([r['particle_steps_per_s'] for r in rs])} |")
        lines += ["", "Paired ratios sphfem / SPlisHSPlasH (goal: particle-steps/s >= 2):", ""]
        for v in VARIANTS:
            pairs = [(r, s) for r in runs if r["code"] == "sphfem" and r["method"] == method
                     and r["variant"] == v
                     for s in sp if s["round"] == r["round"]]
            if not pairs:
                continue
            ps = [r["particle_steps_per_s"] / s["particle_steps_per_s"] for r, s in pairs]
            tt = [s["wall_s"] / r["wall_s"] for r, s in pairs]
            cpu = [s["cpu_s"] / r["cpu_s"] for r, s in pairs]
            lines.append(f"* {v}: particle-steps/s {_mmm(ps)}; speed to reach t_end "
                         f"(SPlisHSPlasH wall s / sphfem wall s) {_mmm(tt)}; CPU-seconds "
                         f"ratio (SPlisHSPlasH / sphfem) {_mmm(cpu)}")
        lines.append("")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--splash-python", default="/work/venvs/splash/bin/python")
    ap.add_argument("--radius", type=float, default=0.0125)
    ap.add_argument("--stop-at", type=float, default=0.25)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--methods", nargs="+", default=["dfsph", "iisph"])
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS))
    ap.add_argument("--max-error", type=float, default=0.05)
    ap.add_argument("--max-error-v", type=float, default=0.1)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/splash_dambreak"))
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("--report-only", action="store_true",
                    help="write RESULTS.md from --out/results.json (e.g. of a stopped run)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.report_only:
        saved = json.loads((a.out / "results.json").read_text())
        runs = saved["runs"]
        a.rounds = len({r["round"] for r in runs})
        (a.out / "RESULTS.md").write_text(report(runs, a, saved["loads"]))
        print((a.out / "RESULTS.md").read_text())
        return 0
    for m in a.methods:  # untimed: SPlisHSPlasH's volume map into its cache, numba caches
        run_splash(a.splash_python, m, a, 0.01)
    runs, loads = [], []
    for k in range(a.rounds):
        loads.append(os.getloadavg()[0])
        for m in a.methods:
            s = run_splash(a.splash_python, m, a, a.stop_at)
            s.update(round=k, load=os.getloadavg()[0])
            runs.append(s)
            print(json.dumps(s), flush=True)
            for v in a.variants:
                r = run_ours(m, v, a, a.stop_at)
                r.update(round=k, load=os.getloadavg()[0])
                runs.append(r)
                print(json.dumps(r), flush=True)
            (a.out / "results.json").write_text(json.dumps(
                {"args": {k2: str(v2) for k2, v2 in vars(a).items()}, "loads": loads,
                 "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "runs": runs},
                indent=1))
    (a.out / "RESULTS.md").write_text(report(runs, a, loads))
    print((a.out / "RESULTS.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
