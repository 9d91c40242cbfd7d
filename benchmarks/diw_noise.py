"""The noise floor of the deposit's deviation figures: the naive toolpath of an extrusion
scene run again under changes that should not matter.

    python benchmarks/diw_noise.py SCENE.toml --out DIR [--offsets 0,0 0.25,0.25 ...]
                                   [--cfl 0.2 0.3] [--dx DX] [--best BEST_PARAMETERS.json]

Each variant is the scene's naive toolpath (nozzle on the desired path), or with ``--best``
the toolpath of a `sphfem optimize` run's best parameters (its ``best_parameters.json``),
with

* ``offset fx,fy``: the substrate plate's particle lattice moved by (fx dx, fy dx) in the
  substrate plane (its block's ``lo`` and ``hi`` shifted; the path stays put), so the path
  crosses the lattice elsewhere;
* ``cfl c``: the time step's CFL number (the step size of every limit that is CFL-scaled).

The extrusion solver has no random input (the same scene reproduces its deposit to all
digits), so these are the perturbations it has.  ``--dx`` replaces ``[sph] dx`` (and makes
the substrate plate 3 dx thick, as benchmarks/diw/bend90_d4.toml).  One JSON per variant
in DIR (skipped when present: an interrupted study resumes), then a Markdown table of the
figures of sphfem.diw.fitness with their spread (max - min) over the variants.
"""

from __future__ import annotations

import argparse
import copy
import json
import time
import tomllib
from pathlib import Path

import numpy as np

from sphfem.diw.extrusion import simulate_deposit
from sphfem.diw.fitness import deposit_fitness
from sphfem.diw.toolpath import Toolpath, named_case
from sphfem.scene import parse_scene

KEYS = ("edge_dev_max_D", "edge_dev_s", "centre_dev_max_D", "edge_dev_mean_D",
        "centre_dev_mean_D", "max_dev_D", "width_nominal_D", "edge_excess_max_D",
        "edge_short_max_D", "objective")


def variant_data(data: dict, offset=(0.0, 0.0), cfl: float | None = None,
                 dx: float | None = None) -> dict:
    """The scene dict with the substrate lattice shifted by ``offset`` spacings, the CFL
    number and the spacing replaced (None: kept)."""
    d = copy.deepcopy(data)
    d.pop("optimize", None)
    if dx is not None:
        d["sph"]["dx"] = dx
    h = d["sph"]["dx"]
    sub = next(b for b in d["blocks"] if b["kind"] == "wall")
    if dx is not None:
        sub["lo"][2] = sub["hi"][2] - 3 * h
    for k in (0, 1):
        sub["lo"][k] += offset[k] * h
        sub["hi"][k] += offset[k] * h
    if cfl is not None:
        d["time"]["cfl"] = cfl
    return d


def run(data: dict, source: str, params: dict | None = None) -> dict:
    """Deposit of the toolpath of ``data``'s case with the named parameters ``params``
    (None: the naive toolpath), scored on the desired path."""
    scene = parse_scene(data, source=source)
    ex = scene.extrusion
    path, space = named_case(ex.toolpath)
    if params is None:
        tool = Toolpath.naive(path, ex.nozzle_speed)
    else:
        x = [params[n] for n in space.names]
        tool = Toolpath.from_parameters(path, space, x, ex.nozzle_speed)
    dep = simulate_deposit(scene, tool)
    if dep.info.get("stopped_reason"):
        return {"failed": dep.info["stopped_reason"]}
    res = deposit_fitness(dep.positions, dep.h, dep.nozzle_diameter, path, objective="edge")
    res["cpu_s"] = dep.info["cpu_s"]
    res["wall_s"] = dep.info["wall_s"]
    res["steps"] = dep.info["steps"]
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--out", required=True)
    ap.add_argument("--offsets", nargs="*", default=["0,0", "0.25,0.25", "0.5,0", "0,0.5",
                                                      "0.5,0.5"])
    ap.add_argument("--cfl", nargs="*", type=float, default=[0.2, 0.3])
    ap.add_argument("--dx", type=float, default=None)
    ap.add_argument("--best", default=None, help="best_parameters.json of sphfem optimize")
    a = ap.parse_args(argv)
    params = None if a.best is None else json.loads(Path(a.best).read_text())["parameters"]
    data = tomllib.loads(Path(a.scene).read_text())
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    variants = [(f"offset {o}", tuple(float(v) for v in o.split(",")), None)
                for o in a.offsets]
    variants += [(f"cfl {c}", (0.0, 0.0), c) for c in a.cfl]
    results = {}
    for name, off, cfl in variants:
        f = out / (name.replace(" ", "_").replace(",", "_") + ".json")
        if not f.exists():
            t0 = time.perf_counter()
            res = run(variant_data(data, off, cfl, a.dx), f"{a.scene} ({name})", params)
            res["variant"] = name
            f.write_text(json.dumps(res, indent=1))
            print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)
        results[name] = json.loads(f.read_text())
    ok = {k: r for k, r in results.items() if "failed" not in r}
    print("| variant | " + " | ".join(KEYS) + " | CPU s |")
    print("|---" * (len(KEYS) + 2) + "|")
    for name, r in results.items():
        if "failed" in r:
            print(f"| {name} | failed: {r['failed']} |")
            continue
        print(f"| {name} | " + " | ".join(f"{r[k]:.3g}" for k in KEYS)
              + f" | {r['cpu_s']:.1f} |")
    if ok:
        v = {k: np.array([r[k] for r in ok.values()]) for k in KEYS}
        print("| spread (max - min) | " + " | ".join(f"{np.ptp(v[k]):.3g}" for k in KEYS)
              + " | |")
        print("| mean +- std | " + " | ".join(f"{v[k].mean():.3g} +- {v[k].std(ddof=1):.2g}"
                                              if len(ok) > 1 else "-" for k in KEYS) + " | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
