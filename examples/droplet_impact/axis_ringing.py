#!/usr/bin/env python
"""The impact point's acoustics in axisymmetric droplet runs: the wall pressure next to the
axis, the film's lowest ring at the axis and the largest fluid pressure, frame by frame.

Reads the particle series (``particles.pvd`` and its VTU frames) of one or more runs of
``convergence.py`` (a level folder such as ``OUT/V10_n256``; write frames densely, e.g.
``--override 'output.every=0.02 tc'``) and writes, per run and frame,

* ``p_wall``: the mean pressure of the fluid rings within ``--axis-dx`` dx of the axis and
  2 dx of the wall surface z = 0 [rho V^2];
* ``z_low``: the height of the lowest fluid ring within 2 dx of the axis above the wall
  surface [dx] (the lattice's first row sits at ~0.5 dx: more is fluid lifted off the wall);
* ``p_max``, ``r_at_p_max``: the largest fluid pressure above the wall [rho V^2] and its
  ring's r [dx];

as JSON (``--json``) and a figure (``--png``).  Inert debris (written with the fluid's kind)
below the wall surface is left out.  Session 34 (docs/validation/droplet_impact/README.md)::

    python examples/droplet_impact/axis_ringing.py RUN_A/V10_n256 RUN_B/V10_n128 \\
        --label "256, CSF" "128" --speed 10 --diameter 1e-4 --png axis.png --json axis.json
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from sphfem.api import Result


def per_diameter(run: Path) -> int:
    """D/dx from a level folder's name (``V10_n256`` -> 256)."""
    tail = run.name.rpartition("_n")[2]
    if not tail.isdigit():
        raise ValueError(f"{run}: expected a level folder named like V10_n256 (D/dx after _n)")
    return int(tail)


def frame_figures(path: Path, dx: float, rho_v2: float, axis_dx: float) -> dict:
    """The figures of one frame (module docstring)."""
    import meshio

    m = meshio.read(path)
    x = m.points[:, :2] / dx
    fluid = (m.point_data["kind"] == 0) & (x[:, 1] > -0.25)
    p = m.point_data["p"] / rho_v2
    wall = fluid & (x[:, 0] < axis_dx) & (x[:, 1] < 2.0)
    axis = fluid & (x[:, 0] < 2.0)
    above = fluid & (x[:, 1] > 0.0)
    i = int(np.argmax(np.where(above, p, -np.inf))) if above.any() else -1
    return {"p_wall": float(p[wall].mean()) if wall.any() else math.nan,
            "z_low": float(x[axis, 1].min()) if axis.any() else math.nan,
            "p_max": float(p[i]) if i >= 0 else math.nan,
            "r_at_p_max": float(x[i, 0]) if i >= 0 else math.nan}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", type=Path, help="level folders (OUT/V10_n256)")
    ap.add_argument("--from-json", nargs="+", type=Path, default=[],
                    help="earlier --json outputs whose runs join the table and figure "
                         "(e.g. docs/validation/droplet_impact/session34/axis_ringing.json)")
    ap.add_argument("--only", nargs="+", default=None,
                    help="of the --from-json runs, only these labels")
    ap.add_argument("--label", nargs="+", default=None, help="one label per run")
    ap.add_argument("--speed", type=float, default=10.0, help="impact speed V [m/s]")
    ap.add_argument("--diameter", type=float, default=1e-4, help="droplet diameter D [m]")
    ap.add_argument("--rho0", type=float, default=1000.0, help="fluid density [kg/m^3]")
    ap.add_argument("--axis-dx", type=float, default=3.0,
                    help="wall rings within this many dx of the axis count [dx]")
    ap.add_argument("--t-max-tc", type=float, default=math.inf, help="last frame [t_c]")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--png", type=Path, default=None)
    a = ap.parse_args(argv)
    labels = a.label or [str(r) for r in a.runs]
    if len(labels) != len(a.runs):
        ap.error(f"--label: {len(labels)} labels for {len(a.runs)} runs")
    tc = a.diameter / a.speed
    rho_v2 = a.rho0 * a.speed**2
    res = {"speed": a.speed, "diameter": a.diameter, "axis_dx": a.axis_dx, "runs": {}}
    for path in a.from_json:
        old = json.loads(path.read_text())
        for key in ("speed", "diameter", "axis_dx"):
            if old[key] != res[key]:
                ap.error(f"--from-json {path}: {key} {old[key]} differs from {res[key]}")
        for lab, rr in old["runs"].items():
            if a.only is None or lab in a.only:
                res["runs"][lab] = {**rr, "frames": [r for r in rr["frames"]
                                                     if r["t_tc"] <= a.t_max_tc]}
    if not a.runs and not res["runs"]:
        ap.error("no runs: give level folders or --from-json")
    for run, lab in zip(a.runs, labels, strict=True):
        if not (run / "particles.pvd").is_file():
            ap.error(f"{run}: no particles.pvd (a level folder of convergence.py)")
        dx = a.diameter / per_diameter(run)
        rows = []
        for t, f in Result(run, {}).frames():  # a stopped run has no summary.json
            if t <= 0.0:  # the set-up frame: no contact yet
                continue
            if t / tc > a.t_max_tc:
                break
            rows.append({"t_tc": t / tc, **frame_figures(f, dx, rho_v2, a.axis_dx)})
        res["runs"][lab] = {"folder": str(run), "per_diameter": per_diameter(run),
                            "frames": rows}
        print(f"{lab}: " + " ".join(f"{r['t_tc']:.2f}:{r['p_wall']:+.2f}/{r['z_low']:.1f}"
                                    for r in rows))
    if a.json:
        a.json.write_text(json.dumps(res, indent=1))
    if a.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
        for lab, rr in res["runs"].items():
            t = [r["t_tc"] for r in rr["frames"]]
            ax[0].plot(t, [r["p_wall"] for r in rr["frames"]], ".-", label=lab)
            ax[1].plot(t, [r["z_low"] for r in rr["frames"]], ".-", label=lab)
            ax[2].plot(t, [r["p_max"] for r in rr["frames"]], ".-", label=lab)
        ax[0].axhline(0.0, color="k", lw=0.6)
        ax[0].set_ylabel(f"wall p, r < {a.axis_dx:g} dx [rho V^2]")
        ax[1].set_ylabel("lowest ring at the axis [dx]")
        ax[2].set_ylabel("largest fluid p [rho V^2]")
        ax[2].set_yscale("log")
        ax[2].set_xlabel("t / t_c")
        ax[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(a.png, dpi=110)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
