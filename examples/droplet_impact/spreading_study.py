"""Why the 3D SPH droplet spreads too little: small fluid-only impact runs vs the correlations.

    python examples/droplet_impact/spreading_study.py --out DIR                # every case
    python examples/droplet_impact/spreading_study.py --out DIR --cases a02,a0  # some cases
    python examples/droplet_impact/spreading_study.py --out DIR --report docs/validation/spreading

A water droplet (D = 0.1 mm, rho = 1000 kg/m^3, mu = 3e-4 Pa s, sigma = 0.072 N/m, the
default scene's water) hits a flat rigid wall (Adami walls, 3 layers) at v; fluid only, no
heat, no substrate.  Each case varies one numerical choice from the base case
(D / dx = 12, alpha = 0.02, c0 = 500 m/s, delta = 0.1, no-slip wall, CSF surface tension):

* ``alpha``: the artificial viscosity alpha h c0 (h = R / 2 = 1.5 dx), whose kinematic
  viscosity alpha h c0 / (2 (d + 2)) (Monaghan 2005) is ~30x water's at dx = D / 12;
  alpha = 0 leaves the physical (Morris) viscosity and the delta-SPH diffusive term;
* ``wall``: ``noslip`` (Adami et al. 2012: ghost velocity 2 v_w - v~) or ``slip`` (free
  slip: the ghost velocity's tangential part is the extrapolated fluid velocity v~, its
  normal part mirrored as before).  The slip wall exists only in this study: it wraps
  :func:`sphfem.fluid.walls_adami2012.adami_wall_state` for the run;
* ``n``: particles across the droplet (D / dx);
* ``v``: impact speed (50 and 10 m/s).

The droplet starts gap = R above the wall; time is counted from contact, t_contact = gap / v,
in units of tc = D / v; each run goes to 4 tc after contact.  Every 0.05 tc the wetted
diameter (:func:`sphfem.fluid.spreading.contact_diameter`: fluid particles within one
spacing of the wall) is recorded three ways: ``edge`` (the outermost such particle),
``sheet`` (the outermost particle of the largest sheet joined by gaps < 2 dx: the lamella
without the particles and fingers that broke off it; the figure used below) and ``area``
(the disc of the wetted area, N dx^2); D_max is the largest value over time.  Fluid
particles beyond the wall's edge (3.5 D from the axis, less a support radius), 4 D above
the wall or below its bottom (ejecta sliding off the edge, leaks) are taken out of the run
(kind GHOST, at rest, counted), so they cannot stop it by leaving the domain.  One JSON per case
(``DIR/<case>.json``; an existing one is kept, so an interrupted study resumes).
``--report`` writes ``results.json``, ``table.md`` and ``spreading.png`` (D_max / D against
Re with the correlations at the physical We) into the given folder.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # run from a checkout without installing

D = 0.1e-3
RHO, MU, SIGMA = 1000.0, 3.0e-4, 0.072
T_TC = 4.0          # run length after contact [tc]
EVERY_TC = 0.05     # measurement interval [tc]
WALL_HALF = 3.5 * D  # half-width of the wall: it covers D_max / D <= 7

BASE = dict(v=50.0, n=12, alpha=0.02, c0=500.0, delta=0.1, wall="noslip", st="csf")
CASES = {
    "base": {},
    "a01": dict(alpha=0.01),
    "a005": dict(alpha=0.005),
    "a0": dict(alpha=0.0),
    "slip": dict(wall="slip"),
    "a0-slip": dict(alpha=0.0, wall="slip"),
    "n8": dict(n=8),
    "n16": dict(n=16),
    "a0-n8": dict(alpha=0.0, n=8),
    "a0-n16": dict(alpha=0.0, n=16),
    "nost": dict(st="none"),
    "v10": dict(v=10.0),
    "v10-a0": dict(v=10.0, alpha=0.0),
    "v10-a0-slip": dict(v=10.0, alpha=0.0, wall="slip"),
}


def case_params(name: str) -> dict:
    return {**BASE, **CASES[name]}


def scene_dict(c: dict) -> dict:
    """The fluid-only impact scene of case parameters ``c``."""
    dx = D / c["n"]
    R = 3.0 * dx
    layers = 3           # R / dx: the support of the first fluid layer is covered
    half = 6.0 * D
    return {
        "scene": {"name": "spreading", "dim": 3, "seed": 1,
                  "description": f"fluid-only droplet impact, {c}"},
        "domain": {"lo": [-half, -half, -D], "hi": [half, half, 5.0 * D]},
        "sph": {"kernel": "wendland_c2", "dx": dx, "support_factor": 3.0},
        "materials": {
            "water": {"rho0": RHO, "mu": MU, "c0": c["c0"], "sigma": SIGMA},
            "wall": {"rho0": RHO},
        },
        "blocks": [
            {"name": "wall", "shape": "box", "kind": "wall", "material": "wall",
             "lo": [-WALL_HALF, -WALL_HALF, -layers * dx], "hi": [WALL_HALF, WALL_HALF, 0.0]},
            {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
             "sampling": "poisson", "center": [0.0, 0.0, 0.0], "radius": D / 2,
             "above": "wall", "gap": R, "velocity": [0.0, 0.0, -c["v"]]},
        ],
        "physics": {"modules": ["fluid"]},
        "fluid": {"alpha": c["alpha"], "delta": c["delta"], "surface_tension": c["st"]},
        "time": {"t_end": R / c["v"] + T_TC * D / c["v"]},
    }


class _SlipWalls:
    """Context: free-slip Adami walls (tangential ghost velocity = extrapolated fluid
    velocity; the wall normal is the last axis), by wrapping the wall-state function the
    fluid solver calls."""

    def __enter__(self):
        import sphfem.fluid.wcsph as wcsph
        from sphfem.particles import WALL

        self._mod, self._orig = wcsph, wcsph.adami_wall_state
        orig = self._orig

        def slip_state(x, v, rho, p, acc, kind, *args):
            orig(x, v, rho, p, acc, kind, *args)
            vg = args[-1]
            w = kind == WALL
            # no slip: vg = 2 v_w - v~  ->  free slip (tangential): vg_t = v~_t = 2 v_w - vg
            vg[w, :-1] = 2.0 * v[w, :-1] - vg[w, :-1]

        wcsph.adami_wall_state = slip_state
        return self

    def __exit__(self, *exc):
        self._mod.adami_wall_state = self._orig


def run_case(name: str) -> dict:
    """Run one case; the wetted-diameter history and figures as a dict."""
    import contextlib

    from sphfem.fluid.spreading import (
        area_diameter,
        artificial_nu,
        contact_diameter,
        correlation_table,
        effective_reynolds,
        reynolds,
        weber,
    )
    from sphfem.particles import FLUID, GHOST
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation, SimulationStopped

    c = case_params(name)
    scene = parse_scene(scene_dict(c), source=f"<spreading {name}>")
    dx = scene.sph.dx
    v = c["v"]
    tc = D / v
    t_contact = scene.support_radius / v
    t0 = time.perf_counter()
    with _SlipWalls() if c["wall"] == "slip" else contextlib.nullcontext():
        sim = Simulation(scene)
        setup_s = time.perf_counter() - t0
        ps = sim.particles
        times, diam = [], {"edge": [], "sheet": [], "area": []}
        layer = {"rho_mean": [], "rho_min": [], "p_neg": [], "n_layer": [], "n_fluid": [],
                 "n_below": []}
        removed = 0
        r_off = WALL_HALF - scene.support_radius
        z_off = -3.0 * dx  # the wall's bottom
        next_m = t_contact
        status, message = "completed", ""
        t_end = scene.time.t_end
        wall0 = time.perf_counter()
        try:
            while sim.t < t_end * (1 - 1e-12):
                dt, _ = sim.stable_dt()
                dt = min(dt, t_end - sim.t, max(next_m - sim.t, 1e-300))
                sim.step(dt)
                sim.check_state()
                x = ps.x
                out = (ps.kind == FLUID) & ((x[:, 0] ** 2 + x[:, 1] ** 2 > r_off ** 2)
                                            | (x[:, 2] > 4 * D) | (x[:, 2] < z_off))
                if out.any():
                    ps.kind[out] = GHOST
                    ps.v[out] = 0.0
                    removed += int(out.sum())
                if sim.t >= next_m * (1 - 1e-12):
                    times.append((sim.t - t_contact) / tc)
                    diam["edge"].append(contact_diameter(x, 0.0, dx, ps.kind) / D)
                    diam["sheet"].append(contact_diameter(x, 0.0, dx, ps.kind, link=2.0) / D)
                    diam["area"].append(area_diameter(x, 0.0, dx, ps.kind) / D)
                    # the state of the wall layer: density ratio and tension (p < 0)
                    fl = ps.kind == FLUID
                    lay = fl & (x[:, 2] >= -0.5 * dx) & (x[:, 2] < dx)
                    rr = ps.rho[lay] / RHO
                    layer["rho_mean"].append(float(rr.mean()) if rr.size else None)
                    layer["rho_min"].append(float(rr.min()) if rr.size else None)
                    layer["p_neg"].append(float((ps.p[lay] < 0).mean()) if rr.size else None)
                    layer["n_layer"].append(int(lay.sum()))
                    layer["n_fluid"].append(int(fl.sum()))
                    layer["n_below"].append(int((fl & (x[:, 2] < 0.0)).sum()))
                    next_m += EVERY_TC * tc
        except SimulationStopped as e:
            status, message = "stopped", str(e)
        wall_s = time.perf_counter() - wall0
    h = scene.support_radius / 2
    nu = MU / RHO
    nu_art = artificial_nu(c["alpha"], h, c["c0"], 3)
    We = weber(RHO, v, D, SIGMA) if c["st"] != "none" else math.inf
    Re = reynolds(RHO, v, D, MU)
    Re_eff = effective_reynolds(v, D, nu, nu_art)
    res = {
        "case": name, "params": c, "dx": dx, "n_fluid": int((ps.kind == FLUID).sum()),
        "n": int(ps.n), "removed": removed,
        "status": status, "message": message, "steps": sim.step_count,
        "setup_s": setup_s, "wall_s": wall_s,
        "We": We, "Re": Re, "nu_art": nu_art, "Re_eff": Re_eff, "t_over_tc": times,
        "layer": layer}
    for key, series in diam.items():
        a = np.asarray(series)
        k = int(np.argmax(a)) if a.size else -1
        res[f"D_{key}_over_D0"] = a.tolist()
        res[f"beta_{key}"] = float(a[k]) if k >= 0 else None
        res[f"t_{key}_tc"] = float(times[k]) if k >= 0 else None
        res[f"{key}_max_at_end"] = bool(k == len(a) - 1)
    return res | {
        "beta_max": res["beta_sheet"], "t_max_tc": res["t_sheet_tc"],
        "max_at_end": res["sheet_max_at_end"],
        "correlations_physical": correlation_table(We if math.isfinite(We) else 1e12, Re),
        "correlations_effective": correlation_table(We if math.isfinite(We) else 1e12,
                                                    Re_eff),
    }


# --------------------------------------------------------------------------------------
# report


def _load(out: Path) -> list[dict]:
    rows = []
    for name in CASES:
        f = out / f"{name}.json"
        if f.exists():
            rows.append(json.loads(f.read_text()))
    return rows


_SHORT = {"pasandideh-fard-1996": "PF96", "ukiwe-kwok-2005": "UK05", "clanet-2004": "C04",
          "roisman-2009": "R09", "laan-2014": "L14"}


def table(rows: list[dict]) -> str:
    """Markdown tables: the cases (D_max / D three ways, the monolayer bound, the range of
    the correlations at Re_eff) and the correlations at the physical Re of each speed."""
    from sphfem.fluid.spreading import disc_spread_ratio

    head = ("| case | v m/s | D/dx | alpha | wall | ST | Re_eff | D_max/D sheet | t/tc | "
            "edge | area | monolayer | fluid N | out | below | correlations at Re_eff | "
            "steps | wall s |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        p = r["params"]
        stop = " (stopped)" if r["status"] != "completed" else ""
        ce = list(r["correlations_effective"].values())
        mono = float(disc_spread_ratio(1.0 / p["n"]))
        lay = r.get("layer", {})
        below = max(lay["n_below"]) if lay.get("n_below") else None

        def star(key, r=r):
            return "*" if r[f"{key}_max_at_end"] else ""

        lines.append(
            f"| {r['case']}{stop} | {p['v']:g} | {p['n']} | {p['alpha']:g} | {p['wall']} | "
            f"{p['st']} | {r['Re_eff']:.0f} | **{r['beta_sheet']:.2f}**{star('sheet')} | "
            f"{r['t_sheet_tc']:.2f} | {r['beta_edge']:.2f}{star('edge')} | "
            f"{r['beta_area']:.2f}{star('area')} | {mono:.2f} | "
            f"{lay['n_fluid'][0] if lay else r['n_fluid']} | {r['removed']} | {below} | "
            f"{min(ce):.2f}-{max(ce):.2f} | {r['steps']} | {r['wall_s']:.0f} |")
    out = "\n".join(lines) + "\n\n"
    names = list(_SHORT)
    head = "| v m/s | We | Re | " + " | ".join(_SHORT[n] for n in names) + " |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    seen = set()
    for r in rows:
        key = (r["params"]["v"], r["params"]["st"])
        if key in seen or r["params"]["st"] == "none":
            continue
        seen.add(key)
        cp = r["correlations_physical"]
        lines.append(f"| {key[0]:g} | {r['We']:.0f} | {r['Re']:.0f} | "
                     + " | ".join(f"{cp[n]:.2f}" for n in names) + " |")
    return out + "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> None:
    """D_max / D of each case (sheet: filled, wetted area: open) at its Re_eff with the
    correlations at the physical We (panels 50 and 10 m/s; Re_eff and physical Re marked),
    and against D / dx with the monolayer-disc bound sqrt(2 (D/dx) / 3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.fluid.spreading import CORRELATIONS, disc_spread_ratio

    colours = {0.02: "k", 0.01: "tab:gray", 0.005: "tab:brown", 0.0: "tab:red"}
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    Re = np.logspace(1.5, 4.6, 200)
    for ax, v in zip(axes[:2], (50.0, 10.0), strict=True):
        We = RHO * v * v * D / SIGMA
        for name, cor in CORRELATIONS.items():
            ax.plot(Re, cor(We, Re), lw=1.2, label=f"{_SHORT[name]}: {cor.citation}"[:60])
        sel = [r for r in rows if r["params"]["v"] == v]
        for r in sel:
            p = r["params"]
            mk = "o" if p["wall"] == "noslip" else "s"
            col = colours.get(p["alpha"], "tab:purple")
            ax.plot(r["Re_eff"], r["beta_sheet"], mk, color=col, ms=6)
            ax.plot(r["Re_eff"], r["beta_area"], mk, mfc="none", color=col, ms=6)
            ax.annotate(f"{r['case']}", (r["Re_eff"], r["beta_sheet"]), fontsize=7,
                        xytext=(3, 3), textcoords="offset points")
        Re_phys = RHO * v * D / MU
        ax.axvline(Re_phys, color="0.5", ls=":", lw=1)
        ax.text(Re_phys, 1.15, " physical Re", rotation=90, fontsize=7, color="0.4")
        ax.set_xscale("log")
        ax.set_xlabel("Re  (SPH cases at Re_eff = vD / (nu + alpha h c0 / 10))")
        ax.set_title(f"v = {v:g} m/s, We = {We:.0f} (theta = 90 deg in PF96, UK05)",
                     fontsize=9)
        ax.set_ylim(1.0, 8.0)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("D_max / D")
    axes[0].legend(fontsize=6, loc="upper left")
    ax = axes[2]
    n = np.linspace(6, 40, 100)
    ax.plot(n, disc_spread_ratio(1.0 / n), "k--", lw=1,
            label="monolayer disc: sqrt(2 (D/dx) / 3)")
    We50, Re50 = RHO * 2500.0 * D / SIGMA, RHO * 50.0 * D / MU
    vals = [float(c(We50, Re50)) for c in CORRELATIONS.values()]
    ax.axhspan(min(vals), max(vals), color="tab:blue", alpha=0.15,
               label="correlations at 50 m/s (physical Re)")
    for r in rows:
        p = r["params"]
        if p["v"] != 50.0 or p["st"] != "csf":
            continue
        mk = "o" if p["wall"] == "noslip" else "s"
        col = colours.get(p["alpha"], "tab:purple")
        ax.plot(p["n"], r["beta_sheet"], mk, color=col, ms=6)
        ax.plot(p["n"], r["beta_area"], mk, mfc="none", color=col, ms=6)
    ax.set_xlabel("D / dx (particles across the droplet)")
    ax.set_title("50 m/s: against resolution", fontsize=9)
    ax.set_ylim(1.0, 8.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.text(0.01, 0.01, "filled: contact line of the connected sheet; open: wetted-area "
             "diameter; circles no-slip, squares free slip; black alpha = 0.02, grey 0.01, "
             "brown 0.005, red 0 (physical viscosity and delta-SPH only)", fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path, help="folder of the case JSON files")
    ap.add_argument("--cases", default=None, help="comma-separated case names (default all)")
    ap.add_argument("--report", type=Path, default=None,
                    help="write results.json, table.md and spreading.png here (no runs)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.report is not None:
        rows = _load(a.out)
        a.report.mkdir(parents=True, exist_ok=True)
        (a.report / "results.json").write_text(json.dumps(rows, indent=1))
        (a.report / "table.md").write_text(table(rows))
        plot(rows, a.report / "spreading.png")
        print(table(rows))
        return 0
    names = a.cases.split(",") if a.cases else list(CASES)
    for name in names:
        if name not in CASES:
            ap.error(f"unknown case {name!r}; known: {', '.join(CASES)}")
    for name in names:
        f = a.out / f"{name}.json"
        if f.exists():
            print(f"{name}: kept {f}")
            continue
        r = run_case(name)
        f.write_text(json.dumps(r, indent=1))
        print(f"{name}: D_max/D = {r['beta_max']:.3f} at {r['t_max_tc']:.2f} tc "
              f"({r['status']}; {r['steps']} steps, {r['wall_s']:.0f} s; Re_eff = "
              f"{r['Re_eff']:.0f}, Re = {r['Re']:.0f})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
