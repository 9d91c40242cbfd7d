"""The results of one axisymmetric droplet run as a small, committable folder with a picture.

    python examples/droplet_impact/reference_results.py RUN_DIR DEST [--speed V]

Reads RUN_DIR (the output of ``sphfem run`` on an axisymmetric droplet scene, e.g.
``droplet_impact_reference.toml``) and writes to DEST:

* ``summary.json`` -- the run's summary (scene, diagnostics, histories);
* ``figures.json`` -- the droplet-impact validation's figures of the run
  (:func:`sphfem.validation.droplet_impact.figures`: maximum spreading, heat into the
  substrate, impact-point rise and its strained-contact reference, peak von Mises with its
  time and place, Wagner ratio, correlations' band);
* ``probes.csv`` -- the substrate probes (stress components, von Mises, temperature) on the
  axis, every ``--probe-stride``-th coupling step;
* ``reference.png`` -- four panels against t / t_c after contact: the spreading ratio with the
  correlations' band and Wagner's sqrt(6 t / t_c); the impact point's surface rise with the
  strained-contact reference and the static contact rise; the heat into the substrate with
  the ideal contact's; the substrate's peak von Mises;
* ``frames.png`` -- the droplet's rings coloured by temperature at a few times.

The impact speed defaults to the droplet block's velocity.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
from pathlib import Path


def write_probes(src: Path, dest: Path, stride: int) -> None:
    """Every ``stride``-th row of the probes CSV (header kept, last row kept)."""
    lines = src.read_text().splitlines()
    rows = lines[1:]
    keep = rows[::stride]
    if rows and keep[-1] != rows[-1]:
        keep.append(rows[-1])
    dest.write_text("\n".join([lines[0], *keep]) + "\n")


def plot_histories(path: Path, summary: dict, figs: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from sphfem.validation.droplet_impact import T_WINDOW, strained_reference

    dg = summary["diagnostics"]
    cp = dg["coupling"]
    sh = cp["substrate_heat"]
    tc = figs["tc"]
    t0 = cp.get("t_contact_s") or 0.0
    sp = dg["fluid"]["spreading"]
    ts = (np.array(sp["history_t_s"]) - t0) / tc
    fig, ax = plt.subplots(1, 4, figsize=(17, 3.8))
    ax[0].plot(ts, sp["history_ratio"], label="contact diameter / D")
    tw = np.linspace(0.0, 1.0, 50)
    ax[0].plot(tw, np.sqrt(6.0 * tw), "k--", lw=0.8, label="Wagner sqrt(6 t/t_c)")
    lo, hi = figs["correlations"]
    ax[0].axhspan(lo, hi, color="tab:green", alpha=0.25, label="correlations")
    ax[0].set_ylabel("D_c / D")
    hist = sh["history"]
    th = np.array([h["t"] for h in hist])
    T_s0 = sh["substrate_initial_temperature_K"]
    ax[1].plot((th - t0) / tc, [h["T_impact"] - T_s0 for h in hist], label="impact point")
    ax[1].axhline(sh["ideal_contact_temperature_K"] - T_s0, color="k", lw=0.8,
                  label="static contact (semi-infinite bodies)")
    lo_w, hi_w = t0 + T_WINDOW[0] * tc, t0 + T_WINDOW[1] * tc
    win = [h for h in hist if lo_w <= h["t"] <= hi_w]
    ref = strained_reference(summary, t0, win)
    if ref is not None:
        ax[1].plot((np.array([h["t"] for h in win]) - t0) / tc, ref, "k--", lw=0.8,
                   label="strained contact (run's strain)")
    ax[1].set_ylabel("surface rise [K]")
    ax[2].plot((th - t0) / tc, [h["heat_to_substrate_J"] * 1e6 for h in hist],
               label="into the substrate")
    ax[2].plot((th - t0) / tc, [h["ideal_contact_heat_J"] * 1e6 for h in hist], "k--",
               lw=0.8, label="ideal contact over the wetted area")
    ax[2].set_ylabel("heat [uJ]")
    probes = np.genfromtxt(path.parent / "probes.csv", delimiter=",", names=True)
    ax[3].plot((probes["t"] - t0) / tc, probes["peak_von_mises"] / 1e6, label="peak")
    ax[3].plot((probes["t"] - t0) / tc, probes["p0_von_mises"] / 1e6, lw=0.8,
               label="impact point, 1 nm deep")
    ax[3].set_ylabel("von Mises [MPa]")
    for a in ax:
        a.set_xlabel("t / t_c after contact")
        a.legend(fontsize=7)
    D = figs["tc"] * figs.get("speed", 0.0)
    fig.suptitle(f"{summary['scene']['scene']['name']}: D_max/D {figs['spread']:.2f}, heat "
                 f"{figs['heat'] * 1e6:.1f} uJ, rise {figs['T_impact']:.2f} K, peak von Mises "
                 f"{figs['vm_peak'] / 1e6:.1f} MPa" + (f" (D = {D * 1e3:.2f} mm)" if D else ""))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_frames(path: Path, run_dir: Path, tc: float, t0: float, r_max: float, z_max: float,
                n: int = 4) -> None:
    """The fluid rings at ``n`` output times spread over the run, coloured by temperature,
    in the window r <= ``r_max``, z <= ``z_max`` [m] (rings flung further are left out)."""
    import xml.etree.ElementTree as ET

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import meshio

    pvd = ET.parse(run_dir / "particles.pvd").getroot()
    sets = [(float(e.get("timestep")), e.get("file")) for e in pvd.iter("DataSet")]
    picks = [sets[round(k * (len(sets) - 1) / (n - 1))] for k in range(n)]
    fig, ax = plt.subplots(n, 1, figsize=(7.5, 2.3 * n), sharex=True, layout="constrained")
    sc = None
    for a, (t, name) in zip(ax, picks, strict=True):
        m = meshio.read(run_dir / name)
        kind = m.point_data["kind"].ravel()
        x = m.points[kind == 0]
        T = m.point_data["T"].ravel()[kind == 0] - 273.15
        sc = a.scatter(x[:, 0] * 1e6, x[:, 1] * 1e6, c=T, s=0.3, cmap="inferno", vmin=20.0,
                       vmax=100.0)
        a.set_xlim(0.0, r_max * 1e6)
        a.set_ylim(-2.0, z_max * 1e6)
        a.set_aspect("equal")
        a.set_ylabel("z [um]")
        a.set_title(f"t = {(t - t0) / tc:.2f} t_c after contact", fontsize=8)
    ax[-1].set_xlabel("r [um]")
    fig.colorbar(sc, ax=ax, label="T [C]", shrink=0.8)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("dest", type=Path)
    ap.add_argument("--speed", type=float, default=None)
    ap.add_argument("--probe-stride", type=int, default=5)
    a = ap.parse_args(argv)

    from sphfem.output import write_json
    from sphfem.validation import droplet_impact as di

    summary = json.loads((a.run_dir / "summary.json").read_text())
    drop = next(b for b in summary["scene"]["blocks"] if b["kind"] == "fluid")
    speed = a.speed or abs(float(drop["velocity"][-1]))
    figs = di.figures(summary, speed, 2.0 * drop["radius"])
    figs = {k: (float(v) if isinstance(v, (int, float)) else v) for k, v in figs.items()}
    figs["speed"] = speed
    figs = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in figs.items()}
    a.dest.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(a.run_dir / "summary.json", a.dest / "summary.json")
    write_json(a.dest / "figures.json", figs)
    write_probes(a.run_dir / "substrate" / "probes.csv", a.dest / "probes.csv", a.probe_stride)
    plot_histories(a.dest / "reference.png", summary, figs)
    t0 = summary["diagnostics"]["coupling"].get("t_contact_s") or 0.0
    D = 2.0 * drop["radius"]
    plot_frames(a.dest / "frames.png", a.run_dir, figs["tc"], t0,
                r_max=0.65 * figs["spread"] * D, z_max=1.05 * D)
    print(json.dumps({k: figs[k] for k in ("spread", "spread_t_tc", "heat", "T_impact",
                                           "T_impact_dev", "vm_peak", "vm_t_tc",
                                           "wagner_ratio", "steps", "wall_s")}, indent=1))


if __name__ == "__main__":
    main()
