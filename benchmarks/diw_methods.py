"""PSO (thesis), CMA-ES and DE on the same evaluation budget, through the Dask machinery.

    python benchmarks/diw_methods.py SCENE --budget 200 --population 10 --seeds 0 1 2 \\
        [--evaluator lag-model] [--workers 1] --out DIR

Prints, per method and seed, the best objective, its maximum deviation (in nozzle
diameters) against the naive toolpath's, and the evaluations computed; writes
``methods.json`` and ``methods.png`` (best objective so far against evaluations).  Each
run has its own cache folder, so every method pays for all of its evaluations.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--out", required=True)
    ap.add_argument("--budget", type=int, default=200)
    ap.add_argument("--population", type=int, default=10)
    ap.add_argument("--seeds", type=int, nargs="*", default=[0, 1, 2])
    ap.add_argument("--methods", nargs="*", default=["pso", "cma", "de"])
    ap.add_argument("--evaluator", default=None, choices=("lag-model", "extrusion"))
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--processes", action="store_true",
                    help="worker processes (default: threads in this process)")
    args = ap.parse_args(argv)

    import shutil

    from sphfem.diw.driver import optimize_job
    from sphfem.diw.evaluate import ResultCache, job_hash, point_key, start_client
    from sphfem.diw.job import load_job

    job, _, _ = load_job(args.scene, evaluator=args.evaluator)
    key = job_hash(job.describe())
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    client = start_client(workers=args.workers, processes=args.processes,
                          env={"NUMBA_NUM_THREADS": "1"})
    rows = []
    try:
        res0, _ = job.evaluate(None)
        naive = {k: res0[k] for k in ("objective", "max_dev_D", "mean_dev_D", "gap_D")}
        print(json.dumps({"naive": naive}), flush=True)
        for method in args.methods:
            for seed in args.seeds:
                run = out / f"{method}-{seed}"
                if run.exists():
                    shutil.rmtree(run)
                s = optimize_job(job, run, method=method, budget=args.budget,
                                 population=args.population, seed=seed, progress=False,
                                 report=False, client=client, stream=None)
                x = list(s["parameters"].values())
                best = ResultCache(run / "cache").get(point_key(key, x))["result"]
                hist = json.loads((run / "history.json").read_text())["rows"]
                row = {"method": method, "seed": seed, "evaluations": s["evaluations"],
                       "computed": s["computed"], "failed": s["failed"],
                       "wall_s": round(s["wall_s"], 1), "objective": s["objective"],
                       "max_dev_D": best["max_dev_D"], "mean_dev_D": best["mean_dev_D"],
                       "gap_D": best["gap_D"],
                       "max_dev_ratio": naive["max_dev_D"] / best["max_dev_D"],
                       "history": [(r["n_eval"], r["best"]) for r in hist]}
                rows.append(row)
                print(json.dumps({k: v for k, v in row.items() if k != "history"}),
                      flush=True)
    finally:
        cl = client.cluster
        client.close()
        cl.close()
    (out / "methods.json").write_text(json.dumps({"scene": args.scene, "naive": naive,
                                                  "budget": args.budget,
                                                  "population": args.population,
                                                  "rows": rows}, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    colours = {"pso": "C0", "cma": "C1", "de": "C2"}
    for r in rows:
        n, f = zip(*r["history"], strict=True)
        ax.semilogy(n, f, color=colours.get(r["method"], "k"), alpha=0.8,
                    label=r["method"] if r["seed"] == args.seeds[0] else None)
    ax.axhline(naive["objective"], color="k", ls=":", label="naive toolpath")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best objective (thesis eq. 3.47)")
    ax.set_title(f"{job.case}, {job.evaluator}: {len(args.seeds)} seeds per method",
                 fontsize=9)
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "methods.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
