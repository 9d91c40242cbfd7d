"""Cost growth with the particle count: neighbour search, fluid passes and heat per step of
a 3D dam break, and the FEM substrate's factorisation and solve per unknown (issue 19,
"Scale").

    python benchmarks/scaling.py fluid --n 3e4 1e5 3e5 1e6 --steps 4 --threads 1 \
        --out benchmarks/scaling
    python benchmarks/scaling.py fem --dofs 1e4 3e4 1e5 --out benchmarks/scaling
    python benchmarks/scaling.py report --out benchmarks/scaling   # fit, table and plot

``fluid``: for each N a new process builds the 3D dam break of ``benchmarks/memory.py``
(Wendland C2, R = 3 dx, delta-SPH WCSPH, and with the ``heat`` module: a 350 K column in a
300 K steel tank, Cleary's Laplacian), takes two warm-up steps, then ``--steps`` steps of
the scene's stable dt on the same list (a step between two rebuilds: "fluid", "heat") and
``--steps`` steps each after a forced rebuild of the list ("search": the build; "fluid
rebuilt", "heat rebuilt": a step whose module takes the new list, e.g. the heat module's
system rebuild).  A run's cost per step is then plain + (rebuilt - plain + search) /
(steps per rebuild).  The report takes the minimum over the steps (the first rebuild of
a run allocates its arrays and is 2-4x slower; the records keep every step's seconds).
Resident memory: the process peak (``getrusage``).

``fem``: ``benchmarks/fem_speed.py factorize`` (the droplet-impact substrate block, P1 tets,
the substrate's direct solver with ``auto`` backend, one back-substitution) at each size,
one process each.

``report``: least-squares fit of log(seconds) against log(N) per part (cost ~ N^b), a
Markdown table (``SCALING.md``) and a log-log plot (``scaling.png``) in ``--out``.  Records:
``fluid.jsonl`` and ``fem.jsonl`` (one JSON line per size; a size measured again replaces
the older line).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from sphfem.output import atomic_write_text

HERE = Path(__file__).resolve().parent
PARTS_FLUID = {"search": "neighbour list build", "fluid": "fluid step (passes, integration)",
               "heat": "heat step", "fluid_rebuilt": "fluid step after a rebuild",
               "heat_rebuilt": "heat step after a rebuild"}
PARTS_FEM = {"factorize": "K factorisation", "solve": "one back-substitution"}


def _child_fluid(n: int, steps: int) -> dict:
    """One size in this process (see the module docstring)."""
    import resource

    import numpy as np

    sys.path.insert(0, str(HERE))
    from memory import dambreak

    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    d = dambreak(n, heat=True)
    d["time"]["max_steps"] = 10**9
    t0 = time.perf_counter()
    sim = Simulation(parse_scene(d, source="<scaling benchmark>"))
    setup = time.perf_counter() - t0
    for _ in range(2):  # warm-up: numba's cache loaded, first lists built
        sim.step(sim.stable_dt()[0])
    rows = {k: [] for k in ("search", "fluid", "heat", "fluid_rebuilt", "heat_rebuilt")}
    for rebuild in (False, True):
        for _ in range(steps):
            if rebuild:
                t0 = time.perf_counter()
                sim.update_neighbors()
                rows["search"].append(time.perf_counter() - t0)
            before = dict(sim.wall)
            sim.step(sim.stable_dt()[0])
            for k in ("fluid", "heat"):
                rows[k + ("_rebuilt" if rebuild else "")].append(sim.wall[k] - before[k])
    p = sim.particles
    return {"n": int(p.n), "n_fluid": int(np.count_nonzero(p.kind == 0)),
            "listed_pairs": int(sim.nbrs.indices.shape[0]), "steps": steps,
            "threads": int(os.environ.get("NUMBA_NUM_THREADS", "0") or 0),
            "setup_s": setup,
            **{f"{k}_s": float(np.median(v)) for k, v in rows.items()},
            **{f"{k}_s_all": [float(x) for x in v] for k, v in rows.items()},
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _run(cmd: list[str], env: dict | None = None) -> dict:
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def _append(path: Path, rec: dict, key: str) -> None:
    """Add ``rec`` to the JSON-lines file ``path``, replacing a line with the same ``key``
    value (written atomically)."""
    old = [json.loads(x) for x in path.read_text().splitlines()] if path.exists() else []
    old = [r for r in old if r.get(key) != rec[key]] + [rec]
    old.sort(key=lambda r: r[key])
    atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in old))


def fit(ns, secs) -> tuple[float, float]:
    """(b, c) of the least-squares line log s = log c + b log n."""
    import numpy as np

    b, logc = np.polyfit(np.log(ns), np.log(secs), 1)
    return float(b), float(np.exp(logc))


def _seconds(rec: dict, part: str) -> float:
    """A record's figure for ``part``: the minimum over its steps where they are recorded."""
    return min(rec[f"{part}_s_all"]) if f"{part}_s_all" in rec else rec[f"{part}_s"]


def _plot_fits(ax, ns, recs, parts, style, xlabel, ylabel, title) -> list[str]:
    """Plot each part's seconds against ``ns`` on ``ax`` (log-log) and return one Markdown
    line per part with its fitted exponent and its value at 1e6 from the fit."""
    lines = []
    for k, label in parts.items():
        s = [_seconds(r, k) for r in recs]
        ax.loglog(ns, s, style, label=label)
        if len(ns) >= 2:
            b, c = fit(ns, s)
            lines.append(f"* {label}: b = {b:.2f} (fit at 1e6: {c * 1e6 ** b:.3g} s)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    return lines


def report(out: Path) -> str:
    """Fit each part, write ``SCALING.md`` and ``scaling.png``; returns the Markdown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lines = ["# Cost growth with size (written by benchmarks/scaling.py report)", ""]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    fl = out / "fluid.jsonl"
    if fl.exists():
        recs = sorted((json.loads(x) for x in fl.read_text().splitlines()),
                      key=lambda r: r["n"])
        ns = [r["n"] for r in recs]
        lines += ["## 3D dam break with heat (seconds per step or per list build)", "",
                  "| particles | fluid | listed pairs | threads | search s | fluid s | heat s "
                  "| fluid s, rebuilt | heat s, rebuilt | peak MB |",  # PARTS_FLUID's order
                  "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in recs:
            cols = " | ".join(f"{_seconds(r, k):.3g}" for k in PARTS_FLUID)
            lines.append(f"| {r['n']:,} | {r['n_fluid']:,} | {r['listed_pairs']:,} | "
                         f"{r['threads']} | {cols} | {r['peak_mb']:.0f} |")
        lines += ["", "Fits s = c N^b over the sizes above:", ""]
        lines += _plot_fits(axes[0], ns, recs, PARTS_FLUID, "o-", "particles",
                            "seconds per step", "3D dam break + heat")
        if len(ns) >= 2:
            b, c = fit(ns, [r["peak_mb"] for r in recs])
            lines.append(f"* peak resident memory: b = {b:.2f}; "
                         f"{recs[-1]['peak_mb'] * 1e6 / recs[-1]['n']:.0f} bytes per particle "
                         f"at N = {recs[-1]['n']:,} (MB scale: 1e6 bytes)")
        lines.append("")
    fe = out / "fem.jsonl"
    if fe.exists():
        recs = sorted((json.loads(x) for x in fe.read_text().splitlines()),
                      key=lambda r: r["unknowns"])
        ns = [r["unknowns"] for r in recs]
        lines += ["## FEM substrate (droplet-impact block, P1 tets, the substrate's direct "
                  "solver)", "",
                  "| unknowns | nonzeros of L | factorise s | solve s | peak MB |",
                  "|---:|---:|---:|---:|---:|"]
        for r in recs:
            lines.append(f"| {r['unknowns']:,} | {r.get('nnz_factor', 0):,} | "
                         f"{r['factorize_s']:.3g} | {r['solve_s']:.3g} | "
                         f"{r.get('peak_rss_MB', 0):.0f} |")
        lines += ["", "Fits s = c N^b:", ""]
        lines += _plot_fits(axes[1], ns, recs, PARTS_FEM, "s-", "unknowns", "seconds",
                            "FEM substrate")
        lines.append("")
    fig.tight_layout()
    fig.savefig(out / "scaling.png", dpi=120)
    text = "\n".join(lines)
    (out / "SCALING.md").write_text(text + "\n")
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("fluid", "fem", "report", "child"))
    ap.add_argument("--n", nargs="+", type=float, default=[3e4, 1e5, 3e5, 1e6])
    ap.add_argument("--dofs", nargs="+", default=["1e4", "3e4", "1e5"])
    ap.add_argument("--steps", type=int, default=4)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=HERE / "scaling")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.what == "child":
        print(json.dumps(_child_fluid(int(a.n[0]), a.steps)))
        return 0
    if a.what == "fluid":
        env = dict(os.environ, NUMBA_NUM_THREADS=str(a.threads))
        for n in a.n:
            rec = _run([sys.executable, __file__, "child", "--n", str(n), "--steps",
                        str(a.steps)], env)
            rec["requested_n"] = int(n)
            _append(a.out / "fluid.jsonl", rec, "requested_n")
            print(f"N = {rec['n']:,}: search {rec['search_s']:.3g} s, fluid "
                  f"{rec['fluid_s']:.3g} s, heat {rec['heat_s']:.3g} s per step, peak "
                  f"{rec['peak_mb']:.0f} MB", flush=True)
    elif a.what == "fem":
        for dofs in a.dofs:
            rec = _run([sys.executable, str(HERE / "fem_speed.py"), "factorize", "--cells",
                        "tet", "--dofs", dofs, "--backend", "auto"])
            rec["requested_dofs"] = dofs
            _append(a.out / "fem.jsonl", rec, "requested_dofs")
            print(json.dumps(rec), flush=True)
    print(report(a.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
