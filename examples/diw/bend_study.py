"""Naive-bend overshoot and its resolution study (issue 18 part B; docs/diw_extrusion.md).

Runs a named extrusion scene (default examples/diw/bend90.toml) along its naive toolpath
(the desired path itself, sphfem.diw.toolpath) at several spacings D/dx and prints, per
resolution, the particles, steps, mean step, wall seconds and the deviation of the deposit
from the desired path in nozzle diameters (sphfem.diw.fitness), plus the corner overshoot:
how far the deposit reaches past the corner along the first leg's direction.

    python examples/diw/bend_study.py [scene.toml] [D/dx ...] [--out DIR]

With ``--out DIR``: each run's deposit (``<scene>_D<ratio>.npz``: positions, h, D) and a
top view of all of them over the desired path (``<scene>_top.png``).  Importable:
``study(scene_path, ratios, out)`` returns the rows.
"""

from __future__ import annotations

import json
import resource
import sys
import tomllib
from pathlib import Path

import numpy as np

from sphfem.diw.extrusion import simulate_deposit
from sphfem.diw.fitness import deposit_fitness
from sphfem.diw.toolpath import Toolpath, named_case
from sphfem.scene import parse_scene

HERE = Path(__file__).resolve().parent


def scene_at(path, ratio: float):
    """The scene at D/dx = ``ratio``, its substrate plate 3 spacings thick (= R)."""
    data = tomllib.loads(Path(path).read_text())
    D = data["extrusion"]["nozzle_diameter"]
    dx = D / ratio
    data["sph"]["dx"] = dx
    for b in data["blocks"]:
        if b["kind"] == "wall":
            b["lo"][2] = b["hi"][2] - data["sph"].get("support_factor", 3.0) * dx
    return parse_scene(data, source=str(path))


def run(path, ratio: float, out=None) -> dict:
    scene = scene_at(path, ratio)
    desired, _ = named_case(scene.extrusion.toolpath)
    tool = Toolpath(desired, scene.extrusion.nozzle_speed)
    res = simulate_deposit(scene, tool)
    D = res.nozzle_diameter
    fit = deposit_fitness(res.positions, res.h, D, desired)
    info = res.info
    x = res.positions
    npz = None
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        npz = str(Path(out) / f"{scene.name}_D{ratio:g}.npz")
        np.savez(npz, positions=x, h=res.h, D=D)
    return {
        "D_over_dx": ratio, "dx": info["dx"], "particles": info["particles"],
        "steps": info["steps"], "dt_mean_s": info["dt_s"]["mean"],
        "wall_s": round(info["wall_s"], 1), "cpu_s": round(info["cpu_s"], 1),
        "stopped_reason": info["stopped_reason"],
        "max_deviation_D": fit["max_dev_D"],
        "mean_deviation_D": fit["mean_dev_D"],
        # the practitioner's figures against the bead's own width (sphfem.diw.fitness)
        **{k: fit[k] for k in ("width_nominal_D", "edge_dev_max_D", "edge_dev_s",
                               "edge_dev_mean_D", "edge_excess_max_D", "edge_short_max_D",
                               "centre_dev_max_D", "centre_dev_mean_D")},
        # bend90: the corner is at the origin after the leg along +x
        "corner_overshoot_D": (float(x[:, 0].max() / D) if len(x) and
                               scene.extrusion.toolpath == "bend90" else None),
        "fitness": fit["thesis"],
        "emitted_over_Qt": info["emitted_volume_m3"] / info["expected_emitted_volume_m3"],
        "controlling_limit_counts": info["controlling_limit_counts"],
        "leaked": info["particles"].get("leaked"), "npz": npz,
        # peak resident memory of this process so far (runs in one process: the largest)
        "max_rss_MB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


def study(path, ratios=(4, 6, 8), out=None):
    rows = []
    for r in ratios:
        row = run(path, r, out=out)
        print(json.dumps(row), flush=True)
        rows.append(row)
    if out is not None:
        top_view(path, rows, out)
    return rows


def top_view(path, rows, out) -> Path:
    """Deposits of ``rows`` (their npz files) over the desired path, top view."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = scene_at(path, rows[0]["D_over_dx"])
    desired, _ = named_case(scene.extrusion.toolpath)
    line = desired.point(np.linspace(0.0, 1.0, 400))
    fig, axes = plt.subplots(1, len(rows), figsize=(4.2 * len(rows), 4.2), squeeze=False)
    for ax, row in zip(axes[0], rows, strict=True):
        d = np.load(row["npz"])
        x, D = d["positions"], float(d["D"])
        ax.scatter(x[:, 0] * 1e3, x[:, 1] * 1e3, s=1.5, c=x[:, 2] / D, cmap="viridis")
        ax.plot(line[:, 0] * 1e3, line[:, 1] * 1e3, "r--", lw=1)
        ax.set_aspect("equal")
        ax.set_title(f"D/dx = {row['D_over_dx']:g}: max dev {row['max_deviation_D']:.2f} D, "
                     f"edge {row['edge_dev_max_D']:.2f} D", fontsize=9)
        ax.set_xlabel("x [mm]")
    axes[0][0].set_ylabel("y [mm]")
    fig.tight_layout()
    png = Path(out) / f"{scene.name}_top.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png


if __name__ == "__main__":
    args = sys.argv[1:]
    out = None
    if "--out" in args:
        i = args.index("--out")
        out = args[i + 1]
        del args[i:i + 2]
    scene_path = args[0] if args and args[0].endswith(".toml") else HERE / "bend90.toml"
    ratios = [float(a) for a in args if not a.endswith(".toml")] or [4, 6, 8]
    study(scene_path, ratios, out)
