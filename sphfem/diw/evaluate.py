"""Evaluations of toolpath candidates as Dask tasks, cached on disk.

Every evaluation is one task, keyed ``diw-<key>-a<attempt>`` with ``key`` the SHA-256 of
the job (scene and fitness settings: :func:`job_hash`) and the parameter vector (the exact
float64 values).  Its result is written to ``<cache>/<key>.json`` (temp file + rename,
atomic) the moment it arrives, so a driver killed mid-optimisation loses only the
evaluations still running; a rerun with the same job finds the others in the cache and
recomputes none of them.  The optimisers are deterministic for a given seed and see the
same values from the cache, so a resumed run retraces the interrupted one exactly.

A failed evaluation (an exception in the task, a guard stop of the simulation, a worker
lost twice: ``KilledWorker``) is retried once; failing again, it is recorded with its
errors (``status = "failed"``) and scored :data:`FAILED_OBJECTIVE`, which every optimiser
here ranks last (they compare values, never difference them); the run goes on.

Progress: a tqdm bar (evaluations done of the budget; iteration, best objective, queued,
cached and failed counts) and the Dask dashboard link, printed at the start.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
import traceback
from collections.abc import Callable
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["FAILED_OBJECTIVE", "DaskEvaluator", "ResultCache", "job_hash", "point_key",
           "start_client"]

#: objective of an evaluation that failed twice (finite: CMA-ES and DE rank it last)
FAILED_OBJECTIVE = 1e30
#: tries per evaluation: the first run and one retry
ATTEMPTS = 2


def job_hash(job: dict) -> str:
    """SHA-256 of a JSON-able description of what an evaluation depends on (canonical:
    sorted keys, so key order in the scene file does not matter)."""
    text = json.dumps(job, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def point_key(job_key: str, x) -> str:
    """Key of one evaluation: the job hash and the exact float64 bytes of ``x``."""
    h = hashlib.sha256(job_key.encode())
    h.update(np.ascontiguousarray(np.asarray(x, dtype="<f8")).tobytes())
    return h.hexdigest()[:32]


class ResultCache:
    """One JSON file per evaluation key in ``folder``; writes are atomic."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def get(self, key: str) -> dict | None:
        try:
            return json.loads(self.path(key).read_text())
        except FileNotFoundError:
            return None
        except (json.JSONDecodeError, UnicodeDecodeError):  # cannot happen with os.replace
            logger.warning("unreadable cache record %s: recomputing", self.path(key))
            return None

    def put(self, key: str, record: dict) -> None:
        from sphfem.output import write_json

        write_json(self.path(key), record)  # temp file + rename

    def __len__(self) -> int:
        return sum(1 for _ in self.folder.glob("*.json"))


def _timed(fn: Callable, x) -> dict:
    """Worker side: run ``fn(x)`` (a dict with at least ``objective``) and time it."""
    t_start = time.time()
    t0 = time.perf_counter()
    out = dict(fn(np.asarray(x, dtype=float)))
    out.setdefault("wall_s", time.perf_counter() - t0)
    out["task_s"] = time.perf_counter() - t0
    out["t_start"], out["t_end"] = t_start, time.time()  # epoch s: the cluster's timeline
    if not np.isfinite(out["objective"]):
        raise FloatingPointError(f"objective is {out['objective']}")
    return out


def start_client(scheduler: str | None = None, workers: int = 1, processes: bool = True,
                 env: dict | None = None):
    """A ``distributed.Client``: to ``scheduler`` (an address) if given, else to a new
    ``LocalCluster`` of ``workers`` single-threaded workers (``env``: their environment,
    e.g. ``NUMBA_NUM_THREADS``)."""
    from distributed import Client, LocalCluster

    if not logging.getLogger().isEnabledFor(logging.INFO):
        logging.getLogger("distributed").setLevel(logging.WARNING)  # no start/stop chatter
    if scheduler:
        return Client(scheduler)
    kw = {"env": env} if (processes and env) else {}
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=processes,
                           dashboard_address=":0", **kw)
    return Client(cluster)


class DaskEvaluator:
    """Evaluates batches of parameter vectors with ``fn`` on a Dask client, through the
    cache (module docstring).

    ``fn(x) -> dict`` with ``objective`` (and any metrics) must be picklable (a top-level
    function or a ``functools.partial`` of one); ``job_key``: :func:`job_hash` of what it
    depends on.  ``progress``: a tqdm-like bar (``update``, ``set_postfix``) or None.
    """

    def __init__(self, client, cache: ResultCache, fn: Callable, job_key: str, progress=None):
        self.client = client
        self.cache = cache
        self.fn = fn
        self.job_key = job_key
        self.progress = progress
        self.counts = {"computed": 0, "cached": 0, "failed": 0, "retried": 0}
        self.best = np.inf
        self.iteration = 0
        #: every evaluation of the run in order: (iteration, key, objective, status)
        self.log: list[tuple[int, str, float, str]] = []
        #: per call (epoch s): called, all submitted, returned
        self.batches: list[dict] = []

    def _postfix(self, queued: int) -> None:
        if self.progress is not None:
            self.progress.set_postfix(it=self.iteration, best=f"{self.best:.4g}",
                                      queued=queued, cached=self.counts["cached"],
                                      failed=self.counts["failed"], refresh=False)

    def _submit(self, key: str, x, attempt: int):
        return self.client.submit(_timed, self.fn, x, key=f"diw-{key}-a{attempt}", pure=False)

    def __call__(self, X, iteration: int = 0) -> np.ndarray:
        """Objectives of the rows of ``X`` (failed: :data:`FAILED_OBJECTIVE`)."""
        from distributed import as_completed

        self.iteration = iteration
        stamps = {"iteration": iteration, "called": time.time()}
        X = np.atleast_2d(np.asarray(X, dtype=float))
        keys = [point_key(self.job_key, x) for x in X]
        records: dict[str, dict] = {}
        pending = {}  # future -> (key, row, attempt, errors)
        for i, key in enumerate(keys):
            if key in records or any(k == key for k, *_ in pending.values()):
                continue  # the same point twice in a batch: evaluated once
            rec = self.cache.get(key)
            if rec is not None:
                records[key] = rec
                self.counts["cached"] += 1
                self._done(rec)
            else:
                pending[self._submit(key, X[i], 1)] = (key, i, 1, [])
        self._postfix(len(pending))
        stamps["submitted"] = time.time()
        ac = as_completed(list(pending), with_results=False)
        for fut in ac:
            key, i, attempt, errors = pending.pop(fut)
            if fut.status == "finished":
                try:
                    res = fut.result()
                except Exception as e:  # noqa: BLE001  (a result that cannot be fetched)
                    res, err = None, e
            else:
                res, err = None, fut.exception()
            fut.release()
            if res is not None:
                rec = {"key": key, "x": X[i].tolist(), "status": "ok",
                       "objective": float(res.pop("objective")), "result": res,
                       "attempts": attempt, "errors": errors, "iteration": iteration}
            else:
                tb = "".join(traceback.format_exception(err)) if err is not None else "lost"
                errors = errors + [f"{type(err).__name__}: {err}"]
                logger.warning("evaluation %s attempt %d failed: %s", key, attempt, errors[-1])
                logger.debug("%s", tb)
                if attempt < ATTEMPTS:
                    self.counts["retried"] += 1
                    nf = self._submit(key, X[i], attempt + 1)
                    pending[nf] = (key, i, attempt + 1, errors)
                    ac.add(nf)
                    continue
                rec = {"key": key, "x": X[i].tolist(), "status": "failed",
                       "objective": FAILED_OBJECTIVE, "result": {}, "attempts": attempt,
                       "errors": errors, "iteration": iteration}
                self.counts["failed"] += 1
            self.cache.put(key, rec)
            self.counts["computed"] += 1
            records[key] = rec
            self._done(rec)
            self._postfix(len(pending))
        stamps["returned"] = time.time()
        self.batches.append(stamps)
        F = np.array([records[k]["objective"] for k in keys], dtype=float)
        for k in keys:
            r = records[k]
            self.log.append((iteration, k, r["objective"], r["status"]))
        return F

    def _done(self, rec: dict) -> None:
        if rec["status"] == "ok":
            self.best = min(self.best, rec["objective"])
        if self.progress is not None:
            self.progress.update(1)
