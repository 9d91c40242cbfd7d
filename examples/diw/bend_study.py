"""Naive-bend overshoot and its resolution study (issue 18 part B; docs/diw_extrusion.md).

Runs a named extrusion scene (default examples/diw/bend90.toml) along its naive toolpath
(the desired path itself, sphfem.diw.toolpath) at several spacings D/dx and prints, per
resolution, the particles, steps, mean step, wall seconds and the deviation of the deposit
from the desired path in nozzle diameters (sphfem.diw.fitness), plus the corner overshoot:
how far the deposit reaches past the corner along the first leg's direction.

    python examples/diw/bend_study.py [scene.toml] [D/dx ...]

Importable: ``study(scene_path, ratios)`` returns the rows.
"""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

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


def run(path, ratio: float, out_dir=None) -> dict:
    scene = scene_at(path, ratio)
    desired, _ = named_case(scene.extrusion.toolpath)
    tool = Toolpath(desired, scene.extrusion.nozzle_speed)
    res = simulate_deposit(scene, tool, out_dir=out_dir)
    D = res.nozzle_diameter
    fit = deposit_fitness(res.positions, res.h, D, desired)
    info = res.info
    x = res.positions
    return {
        "D_over_dx": ratio, "dx": info["dx"], "particles": info["particles"],
        "steps": info["steps"], "dt_mean_s": info["dt_s"]["mean"],
        "wall_s": round(info["wall_s"], 1), "cpu_s": round(info["cpu_s"], 1),
        "stopped_reason": info["stopped_reason"],
        "max_deviation_D": fit["max_dev_D"],
        "mean_deviation_D": fit["mean_dev_D"],
        "corner_overshoot_D": float(x[:, 0].max() / D) if len(x) else None,
        "fitness": fit["thesis"],
        "emitted_over_Qt": info["emitted_volume_m3"] / info["expected_emitted_volume_m3"],
        "controlling_limit_counts": info["controlling_limit_counts"],
    }


def study(path, ratios=(4, 6, 8)):
    rows = []
    for r in ratios:
        row = run(path, r)
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


if __name__ == "__main__":
    args = sys.argv[1:]
    scene_path = args[0] if args and args[0].endswith(".toml") else HERE / "bend90.toml"
    ratios = [float(a) for a in args if not a.endswith(".toml")] or [4, 6, 8]
    study(scene_path, ratios)
