"""``sphfem optimize``: optimise the toolpath of an extrusion scene on Dask, with resume.

Output folder::

    job.json              the job (what results depend on) and its hash
    cache/<key>.json      one record per evaluation (sphfem.diw.evaluate), written at once
    history.json          per iteration: evaluations, best of the iteration, best so far
    evaluations.csv       every evaluation: iteration, key, objective, status
    batches.json          per iteration: when the batch was called, submitted, returned
    best_parameters.json  best parameters, waypoints, naive and optimised metrics
    naive/, best/         the two runs again with their VTU (extrusion evaluator) and
                          final.json (result and deposit; kept by a later --resume)
    fitness_history.png, toolpath_naive.png, toolpath_best.png   (sphfem.diw.report)

An existing folder is refused unless ``resume``; resuming checks that the job is the same
(else the cached results would not belong to it) and reruns the seeded optimiser, which
takes every finished evaluation from the cache.
"""

from __future__ import annotations

import json
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

from sphfem.diw.evaluate import DaskEvaluator, ResultCache, job_hash, point_key
from sphfem.diw.job import ToolpathJob
from sphfem.diw.optimize import minimize
from sphfem.errors import OutputExistsError

logger = logging.getLogger(__name__)

__all__ = ["optimize_job"]


def _write_json(path: Path, data) -> None:
    from sphfem.output import write_json

    write_json(path, data)


def _final_run(job: ToolpathJob, x, out_dir):
    """Worker side: the run of parameters x (None: naive) with its VTU; the result and the
    deposit's positions, or the error text."""
    try:
        res, dep = job.evaluate(None if x is None else np.asarray(x), out_dir=out_dir)
        return {"status": "ok", "result": res,
                "positions": np.asarray(dep.positions).tolist()}
    except Exception as e:  # noqa: BLE001  (reported, the optimisation result stands)
        return {"status": "failed", "error": f"{type(e).__name__}: {e}"}


def optimize_job(job: ToolpathJob, out, *, method: str = "pso", budget: int = 200,
                 population: int = 20, seed: int = 0, options: dict | None = None,
                 scheduler: str | None = None, workers: int = 1, resume: bool = False,
                 progress: bool = True, report: bool = True, client=None,
                 stream=sys.stderr, start_naive: bool = True) -> dict:
    """Optimise ``job``'s toolpath; returns the summary written to best_parameters.json.

    ``client``: a ``distributed.Client`` to use (else one is started: ``scheduler``
    address, or a LocalCluster of ``workers`` processes, closed at the end).
    ``options``: PSO settings for :func:`sphfem.diw.optimize.make_algorithm`;
    ``start_naive``: the naive toolpath is a member of the first population.
    """
    out = Path(out)
    # a budget below one population runs one smaller population (DE/rand/1 needs 4)
    population = max(min(population, budget), 4 if method == "de" else 2)
    key = job_hash(job.describe())
    job_file = out / "job.json"
    if out.exists() and any(out.iterdir()):
        if not resume:
            raise OutputExistsError(f"{out}: output folder exists and is not empty; pass "
                                    f"--resume to continue the optimisation in it")
        old = json.loads(job_file.read_text()).get("hash") if job_file.exists() else None
        if old != key:
            raise OutputExistsError(f"{out}: holds another job (scene or fitness settings "
                                    f"changed); use a new --out folder")
    out.mkdir(parents=True, exist_ok=True)
    settings = {"method": method, "budget": budget, "population": population, "seed": seed,
                "start_naive": start_naive, **(options or {})}
    _write_json(job_file, {"hash": key, "job": job.describe(), "settings": settings})

    own_client = client is None
    if own_client:
        from sphfem.diw.evaluate import start_client

        client = start_client(scheduler, workers=workers,
                              env={"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    bar = None
    try:
        link = getattr(client, "dashboard_link", None)
        if stream is not None:
            print(f"sphfem optimize: {method}, budget {budget}, {population} per iteration; "
                  f"Dask dashboard: {link}", file=stream, flush=True)
        n_iter = math.ceil(budget / population)
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=n_iter * population, unit="eval", file=stream,
                       desc="evaluations")
        cache = ResultCache(out / "cache")
        ev = DaskEvaluator(client, cache, job, key, progress=bar)
        history = []

        def on_iteration(row):
            history.append(row)
            _write_json(out / "history.json", {"method": method, "rows": history})

        t0, t0_epoch = time.perf_counter(), time.time()
        res = minimize(ev, job.space.lower, job.space.upper, budget, method=method,
                       pop_size=population, seed=seed, callback=on_iteration,
                       start=job.space.naive() if start_naive else None,
                       **(options or {}))
        wall = time.perf_counter() - t0
        if bar is not None:
            bar.close()
            bar = None
        lines = ["iteration,key,objective,status"] + [
            f"{it},{k},{f!r},{st}" for it, k, f, st in ev.log]
        (out / "evaluations.csv").write_text("\n".join(lines) + "\n")
        _write_json(out / "batches.json", {"t0": t0_epoch, "batches": ev.batches})

        summary = {
            "method": method, "budget": budget, "population": population, "seed": seed,
            "evaluations": res.n_eval, "computed": ev.counts["computed"],
            "cached": ev.counts["cached"], "failed": ev.counts["failed"],
            "retried": ev.counts["retried"], "wall_s": wall,
            "objective": res.objective,
            "parameters": dict(zip(job.space.names, map(float, res.x), strict=True)),
        }
        s, d = job.space.waypoints(res.x)
        summary["waypoints"] = {"s": s.tolist(), "delta_m": d.tolist()}
        finals = {}
        if report:
            finals, futs = {}, {}
            for name, x in (("naive", None), ("best", res.x)):
                # a finished run of the same point (an earlier, complete --resume) is kept
                tag = point_key(key, [] if x is None else x)
                rec = out / name / "final.json"
                old = json.loads(rec.read_text()) if rec.exists() else {}
                if old.get("point") == tag and old.get("status") == "ok":
                    finals[name] = old
                else:
                    futs[name] = (tag, client.submit(
                        _final_run, job, x, str(out / name), pure=False,
                        key=f"diw-final-{name}-{tag[:12]}-{time.time_ns()}"))
            for name, (tag, f) in futs.items():
                finals[name] = {**f.result(), "point": tag}
                if finals[name]["status"] == "ok":
                    _write_json(out / name / "final.json", finals[name])
            for name, fr in finals.items():
                summary[name] = (fr["result"] if fr["status"] == "ok"
                                 else {"status": "failed", "error": fr["error"]})
            if all(fr["status"] == "ok" for fr in finals.values()):
                naive, best = finals["naive"]["result"], finals["best"]["result"]
                summary["max_dev_improvement"] = naive["max_dev_D"] / best["max_dev_D"]
                # naive / optimised of the practitioner's figures (sphfem.diw.fitness)
                summary["improvement"] = {
                    k: naive[k] / best[k] for k in ("max_dev_D", "mean_dev_D",
                                                    "edge_dev_max_D", "edge_dev_mean_D",
                                                    "centre_dev_max_D", "centre_dev_mean_D")
                    if naive.get(k) is not None and best.get(k)}
        _write_json(out / "best_parameters.json", summary)
        if report:
            from sphfem.diw.report import write_report

            write_report(out, job, history, res.x, finals)
        return summary
    finally:
        if bar is not None:
            bar.close()
        if own_client:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()


def command(args) -> int:
    """``sphfem optimize`` (arguments declared in :mod:`sphfem.cli`); scene and folder
    errors propagate as SceneError / OutputExistsError."""
    from sphfem.diw.job import load_job

    job, opt, _ = load_job(args.scene, method=args.method, budget=args.budget,
                           evaluator=getattr(args, "evaluator", None))
    options = {}
    if opt.method == "pso":
        options = {"w": opt.inertia, "c1": opt.c1, "c2": opt.c2, "reseed": opt.reseed}
    summary = optimize_job(job, args.out, method=opt.method, budget=opt.budget,
                           population=opt.population, seed=opt.seed, options=options,
                           scheduler=args.scheduler, workers=args.workers,
                           resume=args.resume, progress=not args.no_progress,
                           start_naive=opt.start_naive)
    ratio = summary.get("max_dev_improvement")
    edge = summary.get("improvement", {}).get("edge_dev_max_D")
    print(f"sphfem optimize: {summary['evaluations']} evaluations ({summary['computed']} "
          f"computed, {summary['cached']} from the cache, {summary['failed']} failed) in "
          f"{summary['wall_s']:.1f} s; best objective {summary['objective']:.6g}"
          + (f"; max deviation naive/optimised = {ratio:.2f}" if ratio else "")
          + (f", edge deviation {edge:.2f}" if edge else "")
          + f"; report in {args.out}")
    return 0
