"""Time the axisymmetric droplet job (the droplet-impact validation's scene) per step, and
compare two runs' results bit for bit.

    python benchmarks/axisymmetric_droplet.py run V N TEND OUT
        the scene of sphfem.validation.droplet_impact.scene_at(V, N, TEND) (V m/s, D/dx = N,
        to TEND t_c) run into OUT; prints and writes OUT/bench.json: steps, particles, the
        stepping loop's wall and process-CPU seconds, s/step, particle-steps/s, wall and
        process-CPU seconds per module and of the coupling's parts (``_cpu_probes``), the
        coupling's CPU share, the CPU of one stress / heat re-solve as a fraction of the
        SPH (fluid + heat) CPU between two coupling steps, numba threads and the load
        average before and after.
    python benchmarks/axisymmetric_droplet.py compare A B
        summary.json (timings left out), the coupling's history.json and probes.csv, and
        every particle and substrate VTU of runs A and B: the differences, if any, then
        the largest relative changes per group: each figure of summary.json and of
        history.json (list entries pooled: a history figure over all records) and each
        VTU array (over all files) as max |a - b| / max |a|.

Threads: NUMBA_NUM_THREADS; to time code of another commit, run from a ``git archive`` copy
with PYTHONPATH pointing at it (benchmarks/README.md, "Axisymmetric droplet job").
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

#: summary keys that hold timings, machine or run-bookkeeping figures (not results)
TIMING_KEYS = {"wall_s", "setup_s", "process_s", "total_s", "peak_rss_mb", "setup",
               "wall_s_per_module", "particle_steps_per_s", "neighbor_lists", "timings",
               "coupling_s", "scene_file", "versions", "threads", "timing_scope",
               "checkpoint"}


def run(V: float, N: int, t_end_tc: float, out: Path) -> dict:
    import numba

    from sphfem.output import prepare_output_dir
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation
    from sphfem.validation import droplet_impact as di

    scene = parse_scene(di.scene_at(V, N, t_end_tc), source="benchmarks/axisymmetric_droplet")
    prepare_output_dir(out, overwrite=True)
    sim = Simulation(scene, source="benchmarks/axisymmetric_droplet")
    cpu = _cpu_probes(sim)
    load0 = os.getloadavg()
    w0, c0 = time.perf_counter(), time.process_time()
    s = sim.run(out, progress=False)
    w1, c1 = time.perf_counter(), time.process_time()
    n, steps = s["particles"]["total"], s["steps"]
    rec = {"V": V, "N": N, "t_end_tc": t_end_tc, "threads": numba.get_num_threads(),
           "particles": n, "steps": steps, "stepping_wall_s": s["wall_s"],
           "run_wall_s": w1 - w0, "run_cpu_s": c1 - c0,
           "s_per_step": s["wall_s"] / steps, "cpu_s_per_step": (c1 - c0) / steps,
           "particle_steps_per_s": n * steps / s["wall_s"],
           "per_module_s": s["wall_s_per_module"], "setup_s": s["setup_s"],
           "load_before": load0, "load_after": os.getloadavg()}
    modules = {m.name: cpu.get(m.name, 0.0) for m in sim.modules}
    if "coupling.stress.backend" in cpu:
        cpu["coupling.stress.recovery"] = cpu["coupling.stress.backend"] - cpu["stress.resolve"]
    rec["per_module_cpu_s"] = modules
    rec["coupling_cpu_s"] = {k: v for k, v in cpu.items() if k not in modules
                             and k[:-6] not in modules}
    solves = s["diagnostics"]["coupling"]["solves"]
    sph = modules.get("fluid", 0.0) + modules.get("heat", 0.0)
    if solves > 1 and sph > 0:
        per = sph / (solves - 1)  # the SPH work between two coupling steps
        rec["sph_cpu_s_between_couplings"] = per
        rec["coupling_share_cpu"] = modules.get("coupling", 0.0) / sum(modules.values())
        for k in ("stress.resolve", "heat.resolve"):
            if k in cpu:
                rec[f"{k}_fraction_of_sph"] = cpu[k] / cpu[k + "_calls"] / per
    (out / "bench.json").write_text(json.dumps(rec, indent=1))
    return rec


def _cpu_probes(sim) -> dict:
    """Process-CPU seconds [s] of each physics module's step and of the coupling's parts,
    accumulated into the returned dict while ``sim`` runs (instance methods wrapped; the
    arithmetic is untouched): ``stress.resolve`` the substrate's solve (load vector and
    back-substitution), ``stress.recovery`` the backend's solve less that (stresses at
    the quadrature points, nodal projection, element averages), ``heat.exchange`` the
    contact interface with ``heat.resolve`` its FEM heat step inside, ``records`` the VTU
    and history writes; ``<part>_calls`` the calls."""
    cpu: dict = {}

    def wrap(obj, name, key):
        f = getattr(obj, name)

        def timed(*a, **k):
            t0 = time.process_time()
            try:
                return f(*a, **k)
            finally:
                cpu[key] = cpu.get(key, 0.0) + time.process_time() - t0
                cpu[key + "_calls"] = cpu.get(key + "_calls", 0) + 1

        setattr(obj, name, timed)

    for mod in sim.modules:
        wrap(mod, "step", mod.name)
        drv = getattr(mod, "driver", None)
        if drv is None:
            continue
        wrap(drv.backend, "solve", "coupling.stress.backend")
        wrap(drv.backend.sub, "solve", "stress.resolve")
        wrap(drv.backend, "write", "coupling.records")
        wrap(drv, "write_history", "coupling.records")
        if drv.thermal is not None:
            wrap(drv.thermal, "exchange", "coupling.heat.exchange")
            wrap(drv.thermal.heat, "step", "heat.resolve")
    return cpu


def _walk(a, b, path, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in TIMING_KEYS:
                continue
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'B' if k not in a else 'A'}")
            else:
                _walk(a[k], b[k], f"{path}/{k}", out)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _walk(x, y, f"{path}[{i}]", out)
    elif a != b:
        out.append(f"{path}: {a!r} vs {b!r}")


def _numbers(a, b, path, out):
    """Every pair of numbers at the same place of two JSON trees (timing keys left out)
    into ``out`` {path with list indices as [*]: [(a, b), ...]}."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in set(a) & set(b) - TIMING_KEYS:
            _numbers(a[k], b[k], f"{path}/{k}", out)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for x, y in zip(a, b, strict=True):
            _numbers(x, y, f"{path}[*]", out)
    elif (isinstance(a, (int, float)) and isinstance(b, (int, float))
          and not isinstance(a, bool)):
        out.setdefault(path, []).append((a, b))


def relative_changes(A: Path, B: Path) -> dict:
    """The relative changes of run B against run A ([``compare``'s help): {group: [(change,
    quantity), ...] largest first}; a quantity is a JSON number's path with list indices as
    [*] (its scale: the largest |a| over its entries: a history's figure over all records)
    or a VTU array's name (its scale: the largest |a| over all files of the group)."""
    import meshio
    import numpy as np

    out = {}
    for name, f in (("summary", "summary.json"), ("history", "substrate/history.json")):
        if (A / f).exists() and (B / f).exists():
            pairs: dict = {}
            _numbers(json.loads((A / f).read_text()), json.loads((B / f).read_text()),
                     name, pairs)
            rows = []
            for k, v in pairs.items():
                x = np.array(v, float)
                scale = float(np.abs(x[:, 0]).max())
                if scale > 0:
                    rows.append((float(np.abs(x[:, 0] - x[:, 1]).max()) / scale, k))
            out[name] = sorted(rows, reverse=True)
    for group, files in (("particles", sorted(A.glob("particles_*.vtu"))),
                         ("substrate", sorted((A / "substrate").glob("substrate_*.vtu")))):
        diff: dict = {}
        scale: dict = {}
        for f in files:
            ma, mb = meshio.read(f), meshio.read(B / f.relative_to(A))
            arrays = [("points", ma.points, mb.points)] + [
                (k, ma.point_data[k], mb.point_data[k]) for k in ma.point_data
                if k in mb.point_data]
            for k, x, y in arrays:
                if x.size and x.shape == y.shape:
                    diff[k] = max(diff.get(k, 0.0), float(np.abs(x - y).max()))
                    scale[k] = max(scale.get(k, 0.0), float(np.abs(x).max()))
        out[group] = sorted(((diff[k] / scale[k], k) for k in diff if scale[k] > 0),
                            reverse=True)
    return out


def compare(A: Path, B: Path) -> list[str]:
    import meshio
    import numpy as np

    out: list[str] = []
    _walk(json.loads((A / "summary.json").read_text()),
          json.loads((B / "summary.json").read_text()), "summary", out)
    sub = A / "substrate"
    for f in sorted(sub.glob("*.json")) + sorted(sub.glob("*.csv")):
        g = B / "substrate" / f.name
        if not g.exists() or f.read_bytes() != g.read_bytes():
            out.append(f"{f.relative_to(A)} differs")
    for f in sorted(A.glob("particles_*.vtu")) + sorted(sub.glob("substrate_*.vtu")):
        ma, mb = meshio.read(f), meshio.read(B / f.relative_to(A))
        if not (np.array_equal(ma.points, mb.points) and set(ma.point_data) == set(mb.point_data)
                and all(np.array_equal(ma.point_data[k], mb.point_data[k])
                        for k in ma.point_data)):
            out.append(f"{f.relative_to(A)} differs")
    return out


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "run":
        print(json.dumps(run(float(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]),
                             Path(sys.argv[5]))))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        diffs = compare(Path(sys.argv[2]), Path(sys.argv[3]))
        print(f"{len(diffs)} differences")
        print("\n".join(diffs[:50]))
        if diffs:
            for g, rows in relative_changes(Path(sys.argv[2]), Path(sys.argv[3])).items():
                print(f"largest relative changes, {g}: " + ", ".join(
                    f"{k} {rel:.2g}" for rel, k in rows[:4]))
        sys.exit(1 if diffs else 0)
    else:
        sys.exit(__doc__)
