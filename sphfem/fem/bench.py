"""FEM substrate benchmark: set-up (mesh, assembly, factorisation) and seconds per re-solve.

``python -m sphfem.fem.bench [--quick] [--json FILE] [--sizes default 1e5 1e6]``

Meshes: the default droplet-impact substrate (2 x 2 x 0.26 mm alumina block, refined
within 0.25 mm of the top centre) and finer versions of the same block with ~1e5 and ~1e6
displacement unknowns (P1 tetrahedra).  A re-solve is one coupling step: a thermal load
from a nodal temperature field (a Gaussian hot spot), point forces from 400 sensor
particles on the top surface under the droplet, and the back-substitution (direct) or the
warm-started CG (cg-amg).  Timings are the minimum over repeats (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from sphfem.machine import machine_info

#: name -> (h_fine, h_coarse, solvers)
SIZES = {
    "default": (20e-6, 150e-6, ("direct", "cg-amg")),
    "1e5": (10e-6, 50e-6, ("direct", "cg-amg")),
    "1e6": (4.5e-6, 22e-6, ("cg-amg",)),
}
QUICK = {"quick": (40e-6, 200e-6, ("direct", "cg-amg"))}
MATERIAL = dict(E=300e9, nu=0.21, alpha=7.0e-6, T0=293.15)  # alumina


def _steps(sub, n_sensors=400, seed=0):
    """Loads of a few coupling steps: nodal dT hot spot and sensor forces under the drop."""
    rng = np.random.default_rng(seed)
    p = sub.mesh.p
    r2 = p[0] ** 2 + p[1] ** 2
    out = []
    for k in range(4):
        dT = 80.0 * (1 + 0.05 * k) * np.exp(-r2 / (0.1e-3) ** 2 - (p[2] / 50e-6) ** 2)
        rad = 0.1e-3 * np.sqrt(rng.uniform(0, 1, n_sensors))
        th = rng.uniform(0, 2 * np.pi, n_sensors)
        X = np.column_stack([rad * np.cos(th), rad * np.sin(th), np.zeros(n_sensors)])
        F = np.column_stack([rng.normal(0, 1e-4, (n_sensors, 2)),
                             -np.abs(rng.normal(1e-3, 2e-4, n_sensors))])
        out.append((dT, X, F))
    return out


def bench_one(name, h_fine, h_coarse, solver, repeats=3) -> dict:
    from sphfem.fem.meshing import substrate_block
    from sphfem.fem.substrate import FEMSubstrate

    t0 = time.perf_counter()
    path = substrate_block(h_fine=h_fine, h_coarse=h_coarse)
    t_mesh = time.perf_counter() - t0
    sub = FEMSubstrate(path, **MATERIAL, clamps=["bottom"], solver=solver)
    steps = _steps(sub)
    solve_s, load_s, total_s, its = [], [], [], []
    for _rep in range(repeats):
        for dT, X, F in steps:
            t = time.perf_counter()
            r = sub.solve(dT_nodal=dT, point_forces=(X, F))
            total_s.append(time.perf_counter() - t)
            solve_s.append(r.info["solve_s"])
            load_s.append(r.info["assemble_load_s"])
            if "cg_iterations" in r.info:
                its.append(int(r.info["cg_iterations"]))
    t = time.perf_counter()
    vm = r.von_mises_nodes
    t_stress = time.perf_counter() - t
    res = {
        "mesh": name, "h_fine": h_fine, "h_coarse": h_coarse, "solver": solver,
        "backend": sub.backend, "n_dofs": sub.n_dofs, "n_nodes": int(sub.mesh.nvertices),
        "n_elements": int(sub.mesh.t.shape[1]), "mesh_s_or_cache": t_mesh,
        "load_mesh_s": sub.timings["load_mesh"], "assemble_K_s": sub.timings["assemble_K"],
        "factorize_s": sub.timings["factorize"],
        "resolve_s_min": min(total_s), "resolve_s_median": float(np.median(total_s)),
        "backsolve_s_min": min(solve_s), "load_assembly_s_min": min(load_s),
        "stress_recovery_s": t_stress, "n_factorizations": sub.n_factorizations,
        "n_solves": sub.n_solves, "max_von_mises_Pa": float(vm.max()),
    }
    if its:
        res["cg_iterations"] = its
    if getattr(sub, "factor", None) is not None:
        res.update(ordering=sub.factor.ordering, nnz_K_II=sub.factor.nnz,
                   nnz_factor=sub.factor.nnz_factor)
    return res


def run_fem_bench(quick: bool = False, sizes=None, repeats: int = 3, log=print) -> dict:
    """Time set-up and re-solves for each mesh size and solver; returns a JSON-able dict."""
    table = QUICK if quick else {k: SIZES[k] for k in (sizes or SIZES)}
    results = []
    for name, (hf, hc, solvers) in table.items():
        for solver in solvers:
            r = bench_one(name, hf, hc, solver, repeats=1 if quick else repeats)
            log(json.dumps(r, default=lambda o: o.item() if hasattr(o, "item") else str(o)))
            results.append(r)
    return {"machine": machine_info(), "results": results}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m sphfem.fem.bench", description=__doc__)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--sizes", nargs="+", choices=tuple(SIZES), default=None)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--json", metavar="FILE")
    a = p.parse_args(argv)
    res = run_fem_bench(a.quick, a.sizes, a.repeats)
    if a.json:
        from sphfem.output import write_json

        write_json(a.json, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
