"""Throughput of ``sphfem optimize``: evaluations per hour and the scheduler's overhead per
evaluation, on LocalClusters of 1, 2, ... worker processes and on a separate scheduler
with worker processes started by the ``dask`` command (a simulated multi-node cluster:
they talk TCP, as nodes would).

    python benchmarks/diw_throughput.py SCENE --workers 1 2 --external 4 \\
        [--evaluator lag-model --cost 2] [--budget 24 --population 12] --out DIR

With the lag model and ``--cost C`` every evaluation sleeps C seconds (a known cost that
takes no CPU, so the figures do not depend on the machine's load); ``--evaluator
extrusion`` runs the scene's SPH extrusion.  Per configuration: wall seconds of the
optimisation loop, evaluations per hour, the mean task time on the worker, and the
overhead per evaluation = (wall x workers - sum of task times) / evaluations: what the
cluster adds to each evaluation (scheduling, transfer, cache writes, the driver's ask/tell
and the wait for a batch's last member).  The workers' first import of sphfem.diw is done
and timed before (``warmup_s``).  ``independent_*``: the same number of evaluations at
random points submitted at once, without generations: the scheduler's and the cache's own
cost, apart from the optimiser's wait for the last member of each batch.  Keep
``--population`` a multiple of the worker counts, or the idle slots of a batch's last
round count as overhead.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _measure(job, out, client, n_workers, budget, population, method):
    from sphfem.diw.driver import optimize_job

    # warm-up, timed apart: each worker and the scheduler (it unpickles the submitted
    # tasks) import sphfem.diw; without it a separate `dask scheduler` spends its first
    # ~8 s (loaded machine) importing while the first batch waits
    t0 = time.perf_counter()
    client.run(importlib.import_module, "sphfem.diw.job")
    client.run_on_scheduler(importlib.import_module, "sphfem.diw.job")
    warm = time.perf_counter() - t0
    s = optimize_job(job, out, method=method, budget=budget, population=population,
                     progress=False, report=False, client=client, stream=None)
    # the same number of independent evaluations submitted at once (no generations): what
    # the scheduler and the cache cost without the optimiser's wait for each batch
    from sphfem.diw.evaluate import DaskEvaluator, ResultCache, job_hash

    X = np.random.default_rng(1).uniform(job.space.lower, job.space.upper,
                                         (budget, job.space.n_var))
    ind = Path(out) / "independent"
    ev = DaskEvaluator(client, ResultCache(ind), job, job_hash(job.describe()))
    t0 = time.perf_counter()
    ev(X)
    wall_ind = time.perf_counter() - t0
    task_ind = np.array([json.loads(p.read_text())["result"]["task_s"]
                         for p in ind.glob("*.json")])
    over_ind = (wall_ind * n_workers - task_ind.sum()) / len(task_ind)
    recs = [json.loads(p.read_text()) for p in (Path(out) / "cache").glob("*.json")]
    # the driver's timeline: start -> first task started; last task ended -> batch returned
    tl = json.loads((Path(out) / "batches.json").read_text())
    first = min(r["result"]["t_start"] for r in recs)
    lead_in = first - tl["t0"]
    tails = []
    for b in tl["batches"]:
        ends = [r["result"]["t_end"] for r in recs if r["iteration"] == b["iteration"]]
        tails.append(b["returned"] - max(ends))
    submit = [b["submitted"] - b["called"] for b in tl["batches"]]
    task = np.array([r["result"]["task_s"] for r in recs if r["status"] == "ok"])
    # per iteration (epoch stamps of the tasks): its span, the workers' idle time in it
    # (span x workers - task seconds: the wait for the batch's last member) and the gap
    # until the next iteration's first task started (driver: results, tell, ask, submit)
    its = sorted({r["iteration"] for r in recs})
    spans, idle, gaps = [], [], []
    for i in its:
        rs = [r["result"] for r in recs if r["iteration"] == i]
        a, b = min(r["t_start"] for r in rs), max(r["t_end"] for r in rs)
        spans.append(b - a)
        idle.append((b - a) * n_workers - sum(r["task_s"] for r in rs))
        nxt = [r["result"]["t_start"] for r in recs if r["iteration"] == i + 1]
        if nxt:
            gaps.append(min(nxt) - b)
    wall = s["wall_s"]
    n = s["evaluations"]
    over = (wall * n_workers - task.sum()) / n
    return {"workers": n_workers, "evaluations": n, "computed": s["computed"],
            "wall_s": round(wall, 2), "evals_per_hour": round(n / wall * 3600, 1),
            "task_mean_s": round(float(task.mean()), 4),
            "overhead_per_eval_s": round(float(over), 4),
            "overhead_fraction": round(float(over / task.mean()), 4),
            "warmup_s": round(warm, 2),
            "batch_idle_per_eval_s": round(float(np.sum(idle) / n), 4),
            "lead_in_s": round(lead_in, 3),
            "submit_per_iteration_s": round(float(np.mean(submit)), 3),
            "result_to_return_per_iteration_s": round(float(np.mean(tails)), 3),
            "driver_gap_per_iteration_s": round(float(np.mean(gaps)), 4) if gaps else None,
            "independent_wall_s": round(wall_ind, 2),
            "independent_overhead_per_eval_s": round(float(over_ind), 4),
            "independent_overhead_fraction": round(float(over_ind / task_ind.mean()), 4)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--out", required=True)
    ap.add_argument("--workers", type=int, nargs="*", default=[1, 2])
    ap.add_argument("--external", type=int, nargs="*", default=[],
                    help="worker processes of a separate `dask scheduler` (TCP)")
    ap.add_argument("--evaluator", default="lag-model", choices=("lag-model", "extrusion"))
    ap.add_argument("--cost", type=float, default=2.0, help="lag model: seconds per eval")
    ap.add_argument("--budget", type=int, default=24)
    ap.add_argument("--population", type=int, default=12)
    ap.add_argument("--method", default="pso")
    args = ap.parse_args(argv)

    from distributed import Client

    from sphfem.diw.evaluate import start_client
    from sphfem.diw.job import load_job

    job, _, _ = load_job(args.scene, evaluator=args.evaluator)
    if args.evaluator == "lag-model":
        job = dataclasses.replace(job, lag_cost=args.cost)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    env = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    rows = []
    for n in args.workers:
        client = start_client(workers=n, env=env)
        try:
            client.wait_for_workers(n)
            row = _measure(job, tempfile.mkdtemp(dir=out, prefix=f"local{n}-"), client, n,
                           args.budget, args.population, args.method)
        finally:
            cl = client.cluster
            client.close()
            cl.close()
        row["cluster"] = "LocalCluster"
        rows.append(row)
        print(json.dumps(row), flush=True)
    for n in args.external:
        sched_file = out / f"scheduler-{n}.json"
        sched_file.unlink(missing_ok=True)
        penv = {**os.environ, **env}
        procs = [subprocess.Popen(["dask", "scheduler", "--scheduler-file", str(sched_file),
                                   "--port", "0", "--dashboard-address", ":0"], env=penv,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        try:
            t0 = time.time()
            while not sched_file.exists() and time.time() - t0 < 60:
                time.sleep(0.2)
            procs.append(subprocess.Popen(
                ["dask", "worker", "--scheduler-file", str(sched_file), "--nworkers", str(n),
                 "--nthreads", "1"], env=penv,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            client = Client(scheduler_file=str(sched_file))
            client.wait_for_workers(n, timeout=120)
            address = client.scheduler.address
            try:
                row = _measure(job, tempfile.mkdtemp(dir=out, prefix=f"external{n}-"),
                               client, n, args.budget, args.population, args.method)
            finally:
                client.close()
            row["cluster"] = f"dask scheduler + {n} worker processes ({address})"
            rows.append(row)
            print(json.dumps(row), flush=True)
        finally:
            for p in reversed(procs):
                p.terminate()
            for p in procs:
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
    (out / "throughput.json").write_text(json.dumps(
        {"scene": args.scene, "evaluator": args.evaluator, "cost_s": args.cost,
         "budget": args.budget, "population": args.population, "rows": rows}, indent=2))


if __name__ == "__main__":
    sys.exit(main())
