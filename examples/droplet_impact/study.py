"""Droplet-impact study (Park 2019 sec. 2.4.6): run the coupled scene, draw the pictures.

    python examples/droplet_impact/study.py --out DIR [--scene droplet_impact.toml]
    python examples/droplet_impact/study.py --out DIR --plots-only      # redraw an old run
    python examples/droplet_impact/study.py --out DIR --sweep speed=25,50 temperature=60,100 \\
        material=alumina,silicon                                       # table of peak stress

One run writes, into DIR (next to the run's particle series, summary.json and
``substrate/`` folder of the coupling):

* ``droplet_shape.png`` -- droplet side view (slice |y| < dx) coloured by temperature at
  t/tc = 0.25, 0.75, 1.25, 1.75 (tc = D / v), thesis figure 2.10;
* ``surface_maps.png`` -- substrate surface temperature and von Mises stress at the last
  output (1.75 tc), figures 2.11-2.12;
* ``depth_profiles.png`` -- stress components and temperature against depth under the
  impact point at the last coupling step, figure 2.13;
* ``surface_temperature.png`` -- temperature of the impact point and the largest
  substrate temperature against time, figure 2.14;
* ``summary.json`` gains a ``study`` entry: peak von Mises stress (value, place, time),
  contact-patch diameter / D (the heated patch, where the surface temperature rise exceeds
  half its maximum), wetted diameter / D, maximum spreading ratio (largest lateral extent
  of the fluid / D over the outputs), heat transferred to the substrate, wall time.

Sweep mode runs one case per combination (impact speed [m/s], droplet temperature [C],
substrate material from MATERIALS) under DIR/case_*, with a progress bar, and writes
``sweep.csv`` / ``sweep.json`` with the peak von Mises stress of each.
"""

from __future__ import annotations

import argparse
import copy
import itertools
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # run from a checkout without installing

MATERIALS = {  # substrate materials for the sweep (rho0, c, k, E, nu, alpha)
    "alumina": dict(rho0=3950.0, c=900.0, k=10.0, E=300e9, nu=0.21, alpha=8.1e-6),
    "silicon": dict(rho0=2330.0, c=700.0, k=150.0, E=130e9, nu=0.28, alpha=2.6e-6),
    "glass": dict(rho0=2500.0, c=840.0, k=1.0, E=70e9, nu=0.22, alpha=9.0e-6),
}


def run_case(data: dict, out: Path, source: str = "<study>") -> dict:
    import coupling  # noqa: F401  (registers the coupling module)
    from coupling.driver import run_scene
    from sphfem.scene import parse_scene

    scene = parse_scene(data, source=source)
    t0 = time.perf_counter()
    sim, summary = run_scene(scene, out, progress=True, source=source)
    summary["study_wall_s"] = time.perf_counter() - t0
    return summary


def _droplet(data):
    return next(b for b in data["blocks"] if b["kind"] == "fluid")


def _read_particles(out: Path):
    from sphfem.fem.substrate import read_quiet

    pvd = out / "particles.pvd"
    frames = []
    for line in pvd.read_text().splitlines():
        if "<DataSet" in line:
            t = float(line.split('timestep="')[1].split('"')[0])
            f = line.split('file="')[1].split('"')[0]
            frames.append((t, out / f))
    return [(t, read_quiet(f)) for t, f in frames]


def analyse(out: Path, data: dict) -> dict:
    """Draw the PNGs and add the ``study`` entry to DIR/summary.json."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = json.loads((out / "summary.json").read_text())
    drop = _droplet(data)
    D = 2 * drop["radius"]
    v = float(np.linalg.norm(drop["velocity"]))
    tc = D / v
    dx = data["sph"]["dx"]
    frames = _read_particles(out)
    kind_of = lambda m: np.asarray(m.point_data["kind"]).ravel()  # noqa: E731

    # -- droplet shape and temperature -------------------------------------------------
    want = [0.25, 0.75, 1.25, 1.75]
    fig, axes = plt.subplots(1, len(want), figsize=(4 * len(want), 3.2), sharey=True)
    spread = 0.0
    for _t, m in frames:
        fl = kind_of(m) == 0
        r = np.linalg.norm(m.points[fl, :2], axis=1)
        spread = max(spread, 2 * float(r.max()) / D if fl.any() else 0.0)
    for ax, w in zip(axes, want, strict=True):
        t, m = min(frames, key=lambda f: abs(f[0] / tc - w))
        fl = kind_of(m) == 0
        sl = fl & (np.abs(m.points[:, 1]) < 0.75 * dx)
        T = np.asarray(m.point_data["T"]).ravel() - 273.15
        sc = ax.scatter(m.points[sl, 0] * 1e3, m.points[sl, 2] * 1e3, c=T[sl], s=6,
                        cmap="inferno", vmin=20, vmax=T[fl].max() if fl.any() else 100)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_title(f"t/tc = {t / tc:.2f}")
        ax.set_xlabel("x [mm]")
        ax.set_aspect("equal")
    axes[0].set_ylabel("z [mm]")
    fig.colorbar(sc, ax=axes, label="T [C]", shrink=0.8)
    fig.savefig(out / "droplet_shape.png", dpi=120)
    plt.close(fig)

    # -- substrate surface maps at the last substrate output ----------------------------
    from sphfem.fem.substrate import read_quiet

    sub_dir = out / "substrate"
    vtus = sorted(sub_dir.glob("substrate_*.vtu"))
    hist = json.loads((sub_dir / "history.json").read_text())
    T0 = None
    patch = wetted = None
    if vtus:
        sm = read_quiet(vtus[-1])
        P = sm.points
        top = np.abs(P[:, 2] - P[:, 2].max()) < 1e-12
        dT = np.asarray(sm.point_data["dT"]).ravel()
        vm = np.asarray(sm.point_data["von_mises"]).ravel()
        T0 = summary["scene"]["coupling"].get("T0") or 293.15
        lim = 3 * D
        near = top & (np.abs(P[:, 0]) < lim) & (np.abs(P[:, 1]) < lim)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
        for ax, val, lab, cm in ((axes[0], dT[near] + T0 - 273.15, "T [C]", "inferno"),
                                 (axes[1], vm[near] / 1e6, "von Mises [MPa]", "viridis")):
            tc_ = ax.tricontourf(P[near, 0] * 1e3, P[near, 1] * 1e3, val, 30, cmap=cm)
            fig.colorbar(tc_, ax=ax, label=lab)
            ax.set_aspect("equal")
            ax.set_xlabel("x [mm]")
            ax.set_ylabel("y [mm]")
        axes[0].set_title(f"surface temperature, t/tc = {hist['history'][-1]['t'] / tc:.2f}")
        axes[1].set_title("surface von Mises stress")
        fig.tight_layout()
        fig.savefig(out / "surface_maps.png", dpi=120)
        plt.close(fig)
        r = np.linalg.norm(P[top, :2], axis=1)
        dtop = dT[top]
        if dtop.max() > 0:
            patch = 2 * float(r[dtop >= 0.5 * dtop.max()].max()) / D
    _, m_last = frames[-1]
    fl = kind_of(m_last) == 0
    low = fl & (m_last.points[:, 2] < 1.5 * dx)
    if low.any():
        wetted = 2 * float(np.linalg.norm(m_last.points[low, :2], axis=1).max()) / D

    # -- depth profiles under the impact point ------------------------------------------
    probes = np.asarray(hist["probes"])
    last = hist["history"][-1]
    depth = -probes[:, 2] * 1e6
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.5), sharey=True)
    for c in ("xx", "yy", "zz", "xz", "von_mises"):
        a1.plot([p[c] / 1e6 for p in last["probes"]], depth, "o-", label=c)
    a1.set_xlabel("stress [MPa]")
    a1.set_ylabel("depth under the impact point [um]")
    a1.invert_yaxis()
    a1.legend()
    a1.set_title(f"t/tc = {last['t'] / tc:.2f}")
    a2.plot([p["T"] - 273.15 for p in last["probes"]], depth, "o-", color="C3")
    a2.set_xlabel("T [C]")
    fig.tight_layout()
    fig.savefig(out / "depth_profiles.png", dpi=120)
    plt.close(fig)

    # -- surface temperature against time ------------------------------------------------
    ts = np.array([h["t"] for h in hist["history"]]) / tc
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(ts, [h["probes"][0]["T"] - 273.15 for h in hist["history"]], "o-",
            label="impact point (FEM node field)")
    ax.plot(ts, [h.get("T_region_max", np.nan) - 273.15 for h in hist["history"]], "s--",
            label="hottest substrate particle")
    ax.set_xlabel("t / tc")
    ax.set_ylabel("T [C]")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "surface_temperature.png", dpi=120)
    plt.close(fig)

    c = summary["diagnostics"]["coupling"]
    study = {
        "tc_s": tc, "D_m": D, "impact_speed_m_s": v,
        "peak_von_mises_Pa": c["peak_von_mises_Pa"],
        "peak_von_mises_location_m": c["peak_von_mises_location_m"],
        "peak_von_mises_t_s": c["peak_von_mises_t_s"],
        "peak_von_mises_t_over_tc": (c["peak_von_mises_t_s"] or 0.0) / tc,
        "contact_patch_diameter_over_D": patch,
        "wetted_diameter_over_D": wetted,
        "max_spreading_ratio": spread,
        "heat_transferred_J": (c.get("heat") or {}).get("heat_to_solid_J"),
        "heat_balance_residual_rel": (c.get("heat") or {}).get("residual_rel"),
        "wall_s": summary["wall_s"],
        "pngs": ["droplet_shape.png", "surface_maps.png", "depth_profiles.png",
                 "surface_temperature.png"],
    }
    from sphfem.output import write_json

    summary["study"] = study
    write_json(out / "summary.json", summary)
    return study


def sweep(base: dict, out: Path, specs: list[str]) -> list[dict]:
    from tqdm import tqdm

    axes = {"speed": [50.0], "temperature": [100.0], "material": ["alumina"]}
    for s in specs:
        k, _, vals = s.partition("=")
        if k not in axes or not vals:
            raise SystemExit(f"study: bad sweep item {s!r}; use speed=..., temperature=..., "
                             f"material=... ({', '.join(MATERIALS)})")
        axes[k] = [v if k == "material" else float(v) for v in vals.split(",")]
    for m in axes["material"]:
        if m not in MATERIALS:
            raise SystemExit(f"study: unknown material {m!r}; known: {', '.join(MATERIALS)}")
    cases = list(itertools.product(axes["speed"], axes["temperature"], axes["material"]))
    rows = []
    for speed, temp, mat in tqdm(cases, desc="sweep", unit="case"):
        data = copy.deepcopy(base)
        drop = _droplet(data)
        drop["velocity"] = [0.0, 0.0, -speed]
        drop["temperature"] = f"{temp} C"
        sub_mat = data["coupling"]["material"]
        data["materials"][sub_mat] = {**data["materials"][sub_mat], **MATERIALS[mat]}
        D = 2 * drop["radius"]
        data["time"]["t_end"] = 1.75 * D / speed
        data["output"]["every"] = 0.25 * D / speed
        case = out / f"case_v{speed:g}_T{temp:g}_{mat}"
        s = run_case(data, case)
        st = analyse(case, data)
        rows.append({"speed_m_s": speed, "droplet_T_C": temp, "material": mat,
                     "peak_von_mises_Pa": st["peak_von_mises_Pa"],
                     "peak_t_over_tc": st["peak_von_mises_t_over_tc"],
                     "heat_J": st["heat_transferred_J"], "wall_s": s["wall_s"],
                     "folder": case.name})
    from sphfem.output import atomic_write_text, write_json

    write_json(out / "sweep.json", rows)
    head = list(rows[0])
    atomic_write_text(out / "sweep.csv", "\n".join(
        [",".join(head)] + [",".join(str(r[k]) for k in head) for r in rows]) + "\n")
    print(f"{'speed':>7} {'T [C]':>7} {'material':>9} {'peak vM [MPa]':>14} {'wall s':>8}")
    for r in rows:
        print(f"{r['speed_m_s']:>7g} {r['droplet_T_C']:>7g} {r['material']:>9} "
              f"{r['peak_von_mises_Pa'] / 1e6:>14.4g} {r['wall_s']:>8.1f}")
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default=str(HERE / "droplet_impact.toml"))
    p.add_argument("--out", required=True, help="output folder (must not exist, or --plots-only)")
    p.add_argument("--plots-only", action="store_true", help="redraw an existing run")
    p.add_argument("--sweep", nargs="+", metavar="AXIS=V1,V2",
                   help="speed=..., temperature=... [C], material=...")
    a = p.parse_args(argv)
    base = tomllib.loads(Path(a.scene).read_text())
    out = Path(a.out)
    if a.sweep:
        sweep(base, out, a.sweep)
        return 0
    if not a.plots_only:
        if out.exists() and any(out.iterdir()):
            raise SystemExit(f"study: {out} exists and is not empty (use another --out)")
        run_case(base, out, source=a.scene)
    st = analyse(out, base)
    print(json.dumps(st, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
