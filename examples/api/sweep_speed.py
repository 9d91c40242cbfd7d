"""Sweep the impact speed of a small 2D hot droplet through the Python API (not the CLI).

A water droplet (D = 0.1 mm, 100 C) falls at speed v onto a 20 C alumina substrate
(plane strain, on rollers at its sides and bottom: a frictionless box, so no clamped
corner concentrates stress far from the impact): delta-SPH fluid + SPH heat conduction + a
scikit-fem substrate coupled one-way (docs/api.md).  For each v the scene is built as a
dict, run with ``sphfem.run`` and read back from the returned ``Result``; the script prints
one table row per speed and saves ``sweep_speed.png`` in ``--out``.

The artificial speed of sound is c0 = 10 v, so every run has the same Mach number; for an
inviscid, isothermal droplet the impact force per unit depth then scales as rho v^2 D and
its history as a function of t / t_c (t_c = D / v) is the same at every speed.  The table
reports F_max / (rho v^2 D) to show how far viscosity (Re = rho v D / mu) and the
resolution move it from that scaling (the force is sampled at the substrate solves, every
k SPH steps).  The substrate's stress has two parts.  The impact's, read at the solve of
the largest force ("vM@F_max"), scales as v^2 where it dominates (the thermal part is
already comparable there at the slowest speeds).  The thermal one grows while heat flows
in and sets the peak at the end ("vM end"): slower drops are in contact longer.  The heat
handed over is resolution-limited here: the thermal boundary layers (sqrt(kappa t) ~ 1-2 um
in the water) are thinner than dx.  Time is counted from the
geometric contact (the droplet starts a gap of R + dx above the surface, outside the kernel
support).

    python examples/api/sweep_speed.py --out out/sweep_speed            # 4 speeds, dx = 5 um
    python examples/api/sweep_speed.py --out out/sweep_speed --quick    # 2 speeds, dx = 10 um

At dx = 5 um (20 particles across D) this is a resolution study's coarsest level, not a
converged answer (DESIGN.md, "Scales of the droplet-impact study").
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import sphfem

D = 0.1e-3           # droplet diameter [m]
RHO, MU = 1000.0, 1.0e-3
E, NU, ALPHA = 300e9, 0.21, 8.1e-6


def scene_for(v: float, dx: float, tc_after: float = 1.5) -> tuple[dict, float]:
    """The scene dict at impact speed ``v`` [m/s] and spacing ``dx`` [m], and the time of
    geometric contact [s]."""
    r, R = D / 2, 3.0 * dx
    gap = R + dx                          # outside the kernel support at t = 0
    t_contact = gap / v
    scene = {
        "scene": {"name": f"drop2d_v{v:g}", "dim": 2, "seed": 1,
                  "description": f"2D water droplet D = {D:g} m at {v:g} m/s onto alumina"},
        "domain": {"lo": [-0.45e-3, -0.05e-3], "hi": [0.45e-3, 0.2e-3]},
        "sph": {"dx": dx},
        "materials": {
            "water": {"rho0": RHO, "c": 4000.0, "k": 0.6, "mu": MU, "c0": 10.0 * v},
            "alumina": {"rho0": 3950.0, "c": 900.0, "k": 10.0, "E": E, "nu": NU,
                        "alpha": ALPHA},
        },
        "blocks": [
            {"name": "substrate", "shape": "box", "kind": "wall", "material": "alumina",
             "lo": [-0.4e-3, -0.03e-3], "hi": [0.4e-3, 0.0], "temperature": "20 C"},
            {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
             "sampling": "poisson", "center": [0.0, r + gap], "radius": r,
             "velocity": [0.0, -v], "temperature": "100 C"},
        ],
        "physics": {"modules": ["fluid", "heat", "coupling"]},
        "fluid": {"alpha": 0.02},
        "coupling": {"material": "alumina",
                     "rollers": {"left": "x", "right": "x", "bottom": "y"},
                     "mesh": {"lo": [-0.5e-3, -0.13e-3], "hi": [0.5e-3, 0.0],
                              "h_fine": 2 * dx, "h_coarse": 40e-6, "cells": "quad"}},
        "time": {"t_end": t_contact + tc_after * D / v},
        "output": {"every": 0.25 * D / v, "fields": ["T", "v", "p", "kind"]},
    }
    return scene, t_contact


def run_one(v: float, dx: float, out: Path) -> dict:
    scene, t0 = scene_for(v, dx)
    tc = D / v
    w0 = time.perf_counter()
    res = sphfem.run(scene, out=out / f"v{v:g}", overwrite=True, raise_on_stop=False)
    if not res.ok:  # a stability guard stopped it: report what it reached
        print(f"v = {v:g} m/s: {res.summary['message']}", flush=True)
    wall = time.perf_counter() - w0
    hist = res.history()
    t = np.array([h["t"] for h in hist])
    fy = np.array([-h["force_load"][1] for h in hist])      # downward push on the substrate
    peak = res.peak_von_mises
    vm = np.array([h["peak_von_mises"] for h in hist])
    c = res.coupling
    return {
        "v": v, "status": res.status, "t_reached": (res.summary["t"] - t0) / tc,
        "Re": RHO * v * D / MU, "steps": res.summary["steps"], "wall_s": wall,
        "particles": res.summary["particles"]["total"],
        "F_max": float(fy.max()), "F_star": float(fy.max()) / (RHO * v * v * D),
        "t_F_max": (float(t[np.argmax(fy)]) - t0) / tc,
        "vm_at_F_max": float(vm[np.argmax(fy)]), "vm_end": float(vm[-1]),
        "vm_peak": peak["value"], "vm_x": peak["location"][0], "vm_t": (peak["t"] - t0) / tc,
        "heat_J": c["heat"]["heat_to_solid_J"], "ledger": c["heat"]["residual_rel"],
        "force_res": c["force_residual_rel_max"],
        "t_star": (t - t0) / tc, "F_hist": fy / (RHO * v * v * D),
        "vm_hist": vm,
    }


def table(rows: list[dict]) -> str:
    head = (f"{'v m/s':>6} {'Re':>6} {'steps':>6} {'t/tc end':>9} {'wall s':>7} {'F_max N/m':>10} "
            f"{'F/(rho v2 D)':>12} {'at t/tc':>7} {'vM@F_max':>8} {'vM end':>7} "
            f"{'peak vM MPa':>11} {'at x um':>7} {'at t/tc':>7} {'heat J/m':>9} "
            f"{'ledger':>8} {'F resid':>8}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['v']:>6g} {r['Re']:>6.0f} {r['steps']:>6d} "
            f"{r['t_reached']:>8.2f}{'*' if r['status'] == 'stopped' else ' '} {r['wall_s']:>7.1f} "
            f"{r['F_max']:>10.3g} {r['F_star']:>12.3f} {r['t_F_max']:>7.2f} "
            f"{r['vm_at_F_max'] / 1e6:>8.2f} {r['vm_end'] / 1e6:>7.2f} "
            f"{r['vm_peak'] / 1e6:>11.2f} {r['vm_x'] * 1e6:>7.1f} {r['vm_t']:>7.2f} "
            f"{r['heat_J']:>9.3g} {r['ledger']:>8.1e} {r['force_res']:>8.1e}")
    if any(r["status"] == "stopped" for r in rows):
        lines.append("* stopped by a stability guard before t_end (summary.json: message)")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    for r in rows:
        lab = f"v = {r['v']:g} m/s"
        ax[0].plot(r["t_star"], r["F_hist"], ".-", ms=3, label=lab)
        ax[1].plot(r["t_star"], r["vm_hist"] / 1e6, ".-", ms=3, label=lab)
    ax[0].set_xlabel("(t - t_contact) / t_c")
    ax[0].set_ylabel("F_y / (rho v^2 D)")
    ax[0].set_title("impact force on the substrate")
    ax[1].set_xlabel("(t - t_contact) / t_c")
    ax[1].set_ylabel("peak von Mises [MPa]")
    ax[1].set_title("substrate: peak von Mises")
    v = np.array([r["v"] for r in rows])
    ref = rows[-1]
    ax[2].loglog(v, [r["F_max"] for r in rows], "s-", label="F_max [N/m]")
    ax[2].loglog(v, [r["vm_at_F_max"] / 1e6 for r in rows], "o-",
                 label="peak von Mises at F_max [MPa]")
    ax[2].loglog(v, [r["vm_end"] / 1e6 for r in rows], "^-",
                 label="peak von Mises at the end [MPa]")
    for key, scale in (("F_max", 1.0), ("vm_at_F_max", 1e-6)):
        ax[2].loglog(v, ref[key] * scale * (v / ref["v"]) ** 2, "k--", lw=0.8,
                     label="~ v^2" if key == "F_max" else None)
    ax[2].set_xticks(v, [f"{x:g}" for x in v])
    ax[2].minorticks_off()
    ax[2].set_xlabel("impact speed v [m/s]")
    ax[2].set_title("against impact speed")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (one run folder per speed)")
    p.add_argument("--speeds", type=float, nargs="+", help="impact speeds [m/s]")
    p.add_argument("--dx", type=float, help="particle spacing [m] (default 5e-6)")
    p.add_argument("--quick", action="store_true", help="2 speeds at dx = 10 um")
    a = p.parse_args(argv)
    speeds = a.speeds or ([10.0, 20.0] if a.quick else [5.0, 10.0, 20.0, 40.0])
    dx = a.dx or (10e-6 if a.quick else 5e-6)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for v in speeds:
        rows.append(run_one(v, dx, out))
        print(f"v = {v:g} m/s done in {rows[-1]['wall_s']:.1f} s", flush=True)
    text = table(rows)
    print(f"2D droplet D = {D * 1e3:g} mm, 100 C onto alumina 20 C, dx = {dx * 1e6:g} um, "
          f"c0 = 10 v, t_end = t_contact + 1.5 t_c")
    print(text)
    (out / "sweep_speed.txt").write_text(text + "\n")
    plot(rows, out / "sweep_speed.png")
    print(f"plot: {out / 'sweep_speed.png'}")


if __name__ == "__main__":
    main()
