"""Memory of a run: resident memory per set-up stage, peak, and bytes per particle.

Each measurement runs one scene in a new process (``Simulation(scene).run``, a few steps,
outputs to a temporary folder) and reads, from inside it, the resident memory after each
set-up stage (``Simulation.stage_log``: particles, first neighbour list, each module's
set-up), after the steps, and the peak (``getrusage``, which includes transients inside
numba kernels that no sampling sees).  numba's kernels are loaded from the cache of an
earlier run (the first run of a scene compiles: its compiler's ~150-300 MB would count).

Scenes:

* ``dambreak``: a 3D dam break (Wendland C2, R = 3 dx): a column a x a x 2a of ``n``
  fluid particles on a lattice in a 2a x a x 2.2a tank of 3-layer wall particles, module
  ``fluid`` (delta-SPH WCSPH), or ``fluid`` + ``heat`` with ``--heat``.
* any scene file, optionally with every resolution length times ``--scale`` (as the
  numba warm-up coarsens a scene, :func:`sphfem.resolution.scaled_resolution`).

A scene whose modules all read the same pairs (the fluid alone: its view, wall-wall pairs
left out) has its list built with that pair filter; "listed pairs" counts those.

Bytes per particle of a module = its set-up stage's resident step / particles (arrays it
allocates and keeps) and, between two sizes of one scene, the slope of the peak
(``(peak2 - peak1) / (n2 - n1)``: everything that grows with the particles).

    python benchmarks/memory.py dambreak --n 20000 100000 [--heat] [--steps 3]
    python benchmarks/memory.py dambreak --n 1000000 --steps 3
    python benchmarks/memory.py examples/droplet_impact/droplet_impact.toml --scale 1.5 1.0
    python benchmarks/memory.py forms --n 20000 100000 --repeat 11   # compacted-row forms
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

G = 9.81


def dambreak(n_fluid: int, heat: bool = False, a: float = 0.146) -> dict:
    """The 3D dam break scene (a dict for :func:`sphfem.scene.parse_scene`) with about
    ``n_fluid`` fluid particles."""
    k = max(2, round((n_fluid / 2.0) ** (1.0 / 3.0)))
    dx = a / k
    w = 3 * dx  # wall thickness = R
    water = {"rho0": 1000.0, "mu": 1.0e-3, "c0": 10.0 * (2 * G * a) ** 0.5}
    steel = {"rho0": 7850.0}
    if heat:
        water.update(c=4180.0, k=0.6)
        steel.update(c=500.0, k=16.0)
    L, B, H = 2 * a, a, 2.2 * a

    def wall(name, lo, hi):
        return {"name": name, "shape": "box", "kind": "wall", "material": "steel",
                "lo": lo, "hi": hi, "temperature": 300.0}

    blocks = [
        {"name": "column", "shape": "box", "kind": "fluid", "material": "water",
         "lo": [0.0, 0.0, 0.0], "hi": [a, a, 2 * a], "temperature": 350.0},
        wall("floor", [-w, -w, -w], [L + w, B + w, 0.0]),
        wall("x0", [-w, -w, 0.0], [0.0, B + w, H]),
        wall("x1", [L, -w, 0.0], [L + w, B + w, H]),
        wall("y0", [0.0, -w, 0.0], [L, 0.0, H]),
        wall("y1", [0.0, B, 0.0], [L, B + w, H]),
    ]
    modules = ["fluid", "heat"] if heat else ["fluid"]
    d = {"scene": {"name": f"dambreak3d_{n_fluid}", "dim": 3},
         "domain": {"lo": [-2 * w] * 3, "hi": [L + 2 * w, B + 2 * w, H + 2 * w]},
         "sph": {"kernel": "wendland_c2", "dx": dx, "support_factor": 3.0},
         "materials": {"water": water, "steel": steel},
         "blocks": blocks,
         "physics": {"modules": modules},
         "fluid": {"gravity": [0.0, 0.0, -G], "alpha": 0.02},
         "time": {"t_end": 10.0, "max_steps": 3},
         "output": {"every": 100.0}}
    if heat:
        d["heat"] = {"laplacian": "cleary"}
    return d


def _child(job: str) -> int:
    """Run the scene of ``job`` (JSON), print one JSON line of memory figures."""
    import time

    from sphfem.progress import peak_rss_mb, rss_mb

    j = json.loads(Path(job).read_text())
    base = rss_mb()
    from sphfem.resolution import scaled_resolution
    from sphfem.scene import load_scene, parse_scene
    from sphfem.simulation import Simulation

    if "file" in j:
        scene = load_scene(j["file"])
        d = scaled_resolution(scene, j["scale"]) if j["scale"] != 1.0 else scene.to_dict()
        d["time"]["max_steps"] = j["steps"]
        scene = parse_scene(d, source=j["file"])
    else:
        j["scene"]["time"]["max_steps"] = j["steps"]
        scene = parse_scene(j["scene"], source="<memory benchmark>")
    imports = rss_mb()
    t0 = time.perf_counter()
    sim = Simulation(scene)
    setup_s = time.perf_counter() - t0
    after_setup = rss_mb()
    peak_setup = peak_rss_mb()
    t0 = time.perf_counter()
    sim.run(j["out"], progress=False)
    print(json.dumps({
        "n": int(sim.particles.n), "n_fluid": int((sim.particles.kind == 0).sum()),
        "pairs": int(sim.nbrs.indices.shape[0]), "index_dtype": str(sim.nbrs.indices.dtype),
        "pair_filter": sim.ctx.pair_filter is not None,
        "rss_start_mb": base, "rss_imports_mb": imports, "setup_s": setup_s,
        "stages": [{"stage": s["stage"], "rss_mb": s["rss_mb"], "s": s["s"]}
                   for s in sim.stage_log.stages],
        "rss_after_setup_mb": after_setup, "peak_setup_mb": peak_setup,
        "rss_after_steps_mb": rss_mb(), "peak_mb": peak_rss_mb(),
        "steps": sim.step_count, "steps_s": time.perf_counter() - t0,
        "numba_compilations": sim.stage_log.compiles}))
    return 0


def compare_forms(n_fluid: int, repeats: int) -> None:
    """Seconds of the density-gradient and force passes with the compacted rows in the
    index form (int32, 4 B per listed pair) and the position form (uint16 positions in the
    list row, 2 B; what the solver uses), interleaved in one process, after 3 steps of the
    dam break; checks that both give the same accelerations and density rates."""
    import time

    import numpy as np

    from sphfem.fluid import passes
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    sim = Simulation(parse_scene(dambreak(n_fluid), source="<memory benchmark>"))
    for _ in range(3):
        sim.step(sim.stable_dt()[0])
    fl = sim.modules[0].solver
    p, s, pa, nl = fl.p, fl._scratch, fl.params, fl.nbrs
    g = fl.body_force(fl.t)
    forms = {"index": np.empty_like(nl.indices),
             "position": (np.empty(nl.indices.shape[0], np.uint16), nl.indices)}

    def run(nb):
        t0 = time.perf_counter()
        passes.density_gradient(p.x, p.rho, s.V, p.kind, nl.offsets, nl.indices, fl.R,
                                fl.sigma, fl.kernel_code, fl.period, pa.cond_max, s.grad,
                                s.ok, nb, s.cnt)
        t1 = time.perf_counter()
        passes.fluid_forces(s.P, p.kind, nl.offsets, s.cnt, nb, fl.R, fl.sigma,
                            fl.kernel_code, fl.period, g, pa.eps_visc * fl.h**2,
                            pa.delta * fl.h * pa.c0, pa.alpha * fl.h * pa.c0, p.acc, p.drho,
                            p.f_fluid)
        return t1 - t0, time.perf_counter() - t1, p.acc.copy(), p.drho.copy()

    times = {k: [] for k in forms}
    out = {}
    for nb in forms.values():
        run(nb)  # compile / warm up
    for _ in range(repeats):
        for k, nb in forms.items():
            a, b, acc, drho = run(nb)
            times[k].append((a, b))
            out[k] = (acc, drho)
    same = all(np.array_equal(x, y) for x, y in zip(out["index"], out["position"],
                                                     strict=True))
    print(f"{p.n} particles, {nl.n_pairs} listed pairs, {repeats} repeats, "
          f"{numba_threads()} threads; index and position forms give identical results: "
          f"{same}")
    for k, t in times.items():
        t = np.asarray(t) * 1e3
        print(f"  {k:8s} density gradient min {t[:, 0].min():7.1f} median "
              f"{np.median(t[:, 0]):7.1f} ms; forces min {t[:, 1].min():7.1f} median "
              f"{np.median(t[:, 1]):7.1f} ms")


def numba_threads() -> int:
    import numba

    return numba.get_num_threads()


def measure(job: dict) -> dict:
    with tempfile.TemporaryDirectory(prefix="sphfem-mem-") as tmp:
        job = dict(job, out=str(Path(tmp) / "out"))
        path = Path(tmp) / "job.json"
        path.write_text(json.dumps(job))
        r = subprocess.run([sys.executable, __file__, "--child", str(path)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            raise SystemExit(r.stderr[-3000:])
        return json.loads(r.stdout.strip().splitlines()[-1])


def report(r: dict, label: str) -> None:
    view = ", the modules' pair filter" if r.get("pair_filter") else ""
    print(f"{label}: {r['n']} particles ({r['n_fluid']} fluid), {r['pairs']} listed pairs "
          f"({r['index_dtype']}{view}), set-up {r['setup_s']:.1f} s, {r['steps']} steps "
          f"{r['steps_s']:.1f} s, compilations {r['numba_compilations']}")
    prev = r["rss_imports_mb"]
    print(f"  {prev:8.0f} MB  imports")
    for s in r["stages"]:
        step = s["rss_mb"] - prev
        print(f"  {s['rss_mb']:8.0f} MB  {step:+7.0f} MB = {step * 2**20 / r['n']:7.0f} B/particle"
              f"  {s['stage']}")
        prev = s["rss_mb"]
    print(f"  peak {r['peak_mb']:.0f} MB (set-up peak {r['peak_setup_mb']:.0f}; after the "
          f"steps {r['rss_after_steps_mb']:.0f}); peak above imports: "
          f"{(r['peak_mb'] - r['rss_imports_mb']) * 2**20 / r['n']:.0f} B/particle")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene", help="'dambreak', a scene file, or 'forms' (seconds of the "
                                 "fluid passes with either form of the compacted rows)")
    p.add_argument("--n", type=float, nargs="+", default=[2e4, 1e5],
                   help="dambreak: fluid particle counts")
    p.add_argument("--scale", type=float, nargs="+", default=[1.0],
                   help="scene file: resolution factors (>1 coarser)")
    p.add_argument("--heat", action="store_true", help="dambreak: modules fluid + heat")
    p.add_argument("--steps", type=int, default=3)
    p.add_argument("--repeat", type=int, default=11, help="forms: interleaved repeats")
    p.add_argument("--json", type=Path)
    a = p.parse_args(argv)
    if a.scene == "forms":
        for n in a.n:
            compare_forms(int(n), a.repeat)
        return 0
    runs = []
    if a.scene == "dambreak":
        for n in a.n:
            r = measure({"scene": dambreak(int(n), a.heat), "steps": a.steps})
            report(r, f"dambreak n_fluid~{int(n)}{' +heat' if a.heat else ''}")
            runs.append(r)
    else:
        for s in a.scale:
            r = measure({"file": str(Path(a.scene).resolve()), "scale": s, "steps": a.steps})
            report(r, f"{a.scene} scale {s}")
            runs.append(r)
    if len(runs) >= 2:
        r1, r2 = runs[0], runs[-1]
        slope = (r2["peak_mb"] - r1["peak_mb"]) * 2**20 / (r2["n"] - r1["n"])
        print(f"peak slope between {r1['n']} and {r2['n']} particles: {slope:.0f} B/particle")
    if a.json:
        a.json.write_text(json.dumps(runs, indent=1))
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        sys.exit(_child(sys.argv[2]))
    sys.exit(main())
