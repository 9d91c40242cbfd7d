"""Cost of the ink solvers on the reduced straight bead (docs/diw_extrusion.md, "Solver").

Runs examples/diw/line_reduced.toml (8 mm line at 30 degrees, D/dx = 4) with the scene's
DFSPH + implicit viscosity, or with WCSPH and a given viscosity model, for at most
``max_steps`` steps, and prints the mean step, CPU seconds per step and the CPU seconds
projected to the whole run (from the simulated time reached).

    python examples/diw/solver_cost.py dfsph
    python examples/diw/solver_cost.py weiler-implicit 400     # WCSPH + implicit viscosity
    python examples/diw/solver_cost.py laminar 200             # WCSPH + explicit viscosity
"""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

import numpy as np

from sphfem.diw.extrusion import simulate_deposit
from sphfem.scene import parse_scene

HERE = Path(__file__).resolve().parent


class Line:
    """Straight toolpath from ``p0`` along ``direction`` at ``speed`` for ``length``."""

    def __init__(self, p0, direction, speed, length):
        self.p0 = np.asarray(p0, float)
        self.d = np.asarray(direction, float) / np.linalg.norm(direction)
        self.speed, self.duration = speed, length / speed

    def position(self, t):
        return self.p0 + self.d * self.speed * t

    def velocity(self, t):
        return self.d * self.speed


def cost(variant: str = "dfsph", max_steps: int | None = None) -> dict:
    data = tomllib.loads((HERE / "line_reduced.toml").read_text())
    if variant != "dfsph":
        data["fluid"]["pressure"] = "wcsph"
        data["fluid"]["viscosity"] = variant
    if max_steps:
        data["time"]["max_steps"] = int(max_steps)
    scene = parse_scene(data, source=f"line_reduced ({variant})")
    ang = math.radians(30.0)
    path = Line([0.0, -1.5e-3], [math.cos(ang), math.sin(ang)],
                scene.extrusion.nozzle_speed, 8e-3)
    info = simulate_deposit(scene, path).info
    full = path.duration + scene.extrusion.settle_time
    return {"variant": variant, "steps": info["steps"], "t_reached_s": info["t_end_s"],
            "dt_mean_s": info["dt_s"]["mean"], "cpu_s": info["cpu_s"],
            "cpu_s_per_step": info["cpu_s"] / info["steps"],
            "cpu_s_projected": info["cpu_s"] * full / info["t_end_s"],
            "limits": info["controlling_limit_counts"],
            "stopped_reason": info["stopped_reason"]}


if __name__ == "__main__":
    args = sys.argv[1:]
    print(cost(args[0] if args else "dfsph", int(args[1]) if len(args) > 1 else None))
