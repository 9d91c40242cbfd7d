"""Toolpath optimisation machinery: the optimisers through the Dask evaluation, the on-disk
cache, failures scored without stopping the run, the thesis PSO's re-seeding, resume after
a killed driver (issue 18)."""

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")
pytest.importorskip("pymoo")

from sphfem.diw.evaluate import (  # noqa: E402
    FAILED_OBJECTIVE,
    DaskEvaluator,
    ResultCache,
    job_hash,
    point_key,
    start_client,
)
from sphfem.diw.job import ToolpathJob  # noqa: E402
from sphfem.diw.optimize import ThesisPSO, minimize  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET = np.array([0.3, -0.2, 0.55, 0.1])
LO, HI = -np.ones(4), np.ones(4)


def quadratic(x):
    """Analytic fitness with its minimum 0 at TARGET."""
    return {"objective": float(np.sum((x - TARGET) ** 2))}


def quadratic_failing_right(x):
    """Raises for x[0] > 0.6 (away from the optimum): a 'simulation' that breaks there."""
    if x[0] > 0.6:
        raise RuntimeError("guard stop: particle left the domain")
    return quadratic(x)


class CountingQuadratic:
    """The quadratic, appending each call's x to a file (calls across processes)."""

    def __init__(self, log):
        self.log = str(log)

    def __call__(self, x):
        with open(self.log, "a") as f:
            f.write(json.dumps(list(map(float, x))) + "\n")
        return quadratic(x)


class FlakyQuadratic:
    """Fails the first time it sees a point (a lost worker), succeeds on the retry."""

    def __init__(self, folder):
        self.folder = Path(folder)

    def __call__(self, x):
        mark = self.folder / (point_key("flaky", x) + ".seen")
        if not mark.exists():
            mark.touch()
            raise ConnectionError("worker lost")
        return quadratic(x)


@pytest.fixture(scope="module")
def client():
    c = start_client(workers=1, processes=False)
    yield c
    cluster = c.cluster
    c.close()
    cluster.close()


def test_pso_finds_known_optimum_through_dask(client, tmp_path):
    """The thesis PSO, evaluating through DaskEvaluator (tasks + cache), finds the minimum
    of the 4-D quadratic: |x - x*|_inf < 0.05 with 400 evaluations, 20 per iteration
    (seeds 0-5 without Dask: worst 0.027)."""
    ev = DaskEvaluator(client, ResultCache(tmp_path), quadratic, "quadratic")
    res = minimize(ev, LO, HI, 400, method="pso", pop_size=20, seed=3)
    assert res.n_eval == 400
    assert np.max(np.abs(res.x - TARGET)) < 0.05
    assert ev.counts["failed"] == 0
    assert len(ResultCache(tmp_path)) == ev.counts["computed"] == 400
    assert res.history[-1]["best"] == res.objective


@pytest.mark.parametrize("method, budget", [("cma", 400), ("de", 1000)])
def test_other_methods_find_known_optimum(method, budget):
    """CMA-ES and DE on the same quadratic through the same ask/tell loop (evaluated in
    place: the Dask path is the PSO test's): |x - x*|_inf < 0.05 with 400 evaluations for
    CMA-ES, 1000 for DE/rand/1/bin, which converges slower here (seeds 0-5: worst 0.008,
    0.014)."""
    res = minimize(lambda X, it: np.array([quadratic(x)["objective"] for x in X]),
                   LO, HI, budget, method=method, pop_size=20, seed=3)
    assert res.n_eval >= budget
    assert np.max(np.abs(res.x - TARGET)) < 0.05


def test_cma_stopping_by_itself_ends_the_loop():
    """CMA-ES converges on the quadratic long before a budget of 1e5 and stops (pymoo's
    has_next): the loop ends there instead of asking a finished algorithm."""
    res = minimize(lambda X, it: np.array([quadratic(x)["objective"] for x in X]),
                   LO, HI, 100_000, method="cma", pop_size=10, seed=1)
    assert res.n_eval < 5000
    assert res.objective < 1e-10


def test_cache_hit_recomputes_nothing(client, tmp_path):
    """A second call with the same points takes all of them from the cache: no new call of
    the function, identical objectives; a different job key misses."""
    log = tmp_path / "calls.log"
    fn = CountingQuadratic(log)
    X = np.random.default_rng(0).uniform(-1, 1, (8, 4))
    ev = DaskEvaluator(client, ResultCache(tmp_path / "cache"), fn, "job-a")
    F1 = ev(X)
    assert len(log.read_text().splitlines()) == 8
    ev2 = DaskEvaluator(client, ResultCache(tmp_path / "cache"), fn, "job-a")
    F2 = ev2(X)
    assert len(log.read_text().splitlines()) == 8
    assert ev2.counts == {"computed": 0, "cached": 8, "failed": 0, "retried": 0}
    np.testing.assert_array_equal(F1, F2)
    np.testing.assert_allclose(F1, [quadratic(x)["objective"] for x in X], rtol=1e-15)
    DaskEvaluator(client, ResultCache(tmp_path / "cache"), fn, "job-b")(X[:2])
    assert len(log.read_text().splitlines()) == 10


def test_failed_evaluation_is_retried_once_then_scored(client, tmp_path):
    """Failing points are tried twice, recorded with both errors and scored
    FAILED_OBJECTIVE; the optimisation runs on and still finds the optimum."""
    cache = ResultCache(tmp_path)
    ev = DaskEvaluator(client, cache, quadratic_failing_right, "failing")
    X = np.array([[0.9, 0, 0, 0], [0.0, 0, 0, 0]])
    F = ev(X)
    assert F[0] == FAILED_OBJECTIVE and F[1] == pytest.approx(quadratic(X[1])["objective"])
    rec = cache.get(point_key("failing", X[0]))
    assert rec["status"] == "failed" and rec["attempts"] == 2
    assert len(rec["errors"]) == 2 and "guard stop" in rec["errors"][0]
    assert ev.counts["failed"] == 1 and ev.counts["retried"] == 1
    res = minimize(ev, LO, HI, 400, method="cma", pop_size=20, seed=1)
    assert ev.counts["failed"] > 1
    assert np.max(np.abs(res.x - TARGET)) < 0.05


def test_lost_worker_retry_succeeds(client, tmp_path):
    """An evaluation failing once (its first attempt) is retried and recorded as ok."""
    cache = ResultCache(tmp_path / "cache")
    ev = DaskEvaluator(client, cache, FlakyQuadratic(tmp_path), "flaky")
    F = ev(np.array([[0.1, 0.2, 0.3, 0.4]]))
    assert F[0] == pytest.approx(quadratic(np.array([0.1, 0.2, 0.3, 0.4]))["objective"])
    rec = cache.get(point_key("flaky", [0.1, 0.2, 0.3, 0.4]))
    assert rec["status"] == "ok" and rec["attempts"] == 2 and "worker lost" in rec["errors"][0]


def test_thesis_pso_reseeds_the_poorest():
    """With the same seed, ThesisPSO(reseed=3) asks the same second iteration as
    reseed=0 except for the 3 members with the poorest objective in the first, which are
    redrawn inside the bounds."""
    from pymoo.core.problem import Problem

    prob = Problem(n_var=4, n_obj=1, xl=LO, xu=HI)
    asks = {}
    for m in (0, 3):
        algo = ThesisPSO(pop_size=10, reseed=m)
        algo.setup(prob, seed=7, verbose=False)
        pop = algo.ask()
        F = np.sum((pop.get("X") - TARGET) ** 2, axis=1)
        pop.set("F", F[:, None])
        algo.tell(infills=pop)
        asks[m] = (F, algo.ask().get("X"))
    F, X0 = asks[0]
    _, X3 = asks[3]
    worst = np.argsort(F)[-3:]
    rest = np.setdiff1d(np.arange(10), worst)
    np.testing.assert_array_equal(X0[rest], X3[rest])
    assert np.all(np.any(X0[worst] != X3[worst], axis=1))
    assert np.all((X3 >= LO) & (X3 <= HI))


def test_job_hash_shares_cache_across_methods_not_scenes():
    """The job hash covers the scene and fitness settings, not the optimiser."""
    a = ToolpathJob("bend90", 0.1, 7e-4, 1e-4, scene_text="[scene]\nname = 'a'\n")
    b = ToolpathJob("bend90", 0.1, 7e-4, 1e-4, scene_text="[scene]\nname = 'b'\n")
    a2 = ToolpathJob("bend90", 0.1, 7e-4, 1e-4,
                     scene_text="[scene]\nname = 'a'\n[optimize]\nmethod = 'cma'\n")
    assert job_hash(a.describe()) == job_hash(a2.describe())
    assert job_hash(a.describe()) != job_hash(b.describe())


def test_edge_objective_is_part_of_the_job(tmp_path):
    """[optimize] objective = "edge" reaches the job and its evaluations (the objective is
    the fitness' edge term) and changes the hash; the default "thesis" leaves the hash of an
    existing job unchanged (its cache stays valid)."""
    from sphfem.diw.job import load_job

    a = ToolpathJob("bend90", 0.1, 7e-4, 1e-4, scene_text="[scene]\nname = 'a'\n")
    e = dataclasses.replace(a, objective="edge")
    assert "objective" not in a.describe()
    assert job_hash(e.describe()) != job_hash(a.describe())
    scene = _lag_scene(tmp_path, 0.0)
    scene.write_text(scene.read_text() + 'objective = "edge"\n')
    job, opt, _ = load_job(scene)
    assert (job.objective, opt.objective) == ("edge", "edge")
    res = job(job.space.naive())
    assert res["objective"] == res["edge"] != res["thesis"]


def test_centre_objective_is_part_of_the_job(tmp_path):
    """[optimize] objective = "centre" and centre_p reach the job and its evaluations (the
    objective is the fitness' centre term) and change the hash; centre_p does not enter the
    hash of a job with another objective (existing caches stay valid)."""
    from sphfem.diw.job import load_job

    a = ToolpathJob("bend90", 0.1, 7e-4, 1e-4, scene_text="[scene]\nname = 'a'\n")
    e = dataclasses.replace(a, objective="edge")
    assert "centre_p" not in a.describe() and "centre_p" not in e.describe()
    assert job_hash(dataclasses.replace(e, centre_p=4.0).describe()) == job_hash(e.describe())
    c = dataclasses.replace(a, objective="centre")
    assert job_hash(c.describe()) not in (job_hash(a.describe()), job_hash(e.describe()))
    assert job_hash(dataclasses.replace(c, centre_p=4.0).describe()) != job_hash(c.describe())
    scene = _lag_scene(tmp_path, 0.0)
    scene.write_text(scene.read_text() + 'objective = "centre"\ncentre_p = 4.0\n')
    job, opt, _ = load_job(scene)
    assert (job.objective, job.centre_p, opt.centre_p) == ("centre", 4.0, 4.0)
    res = job(job.space.naive())
    assert res["objective"] == res["centre"] > 0
    assert res["centre"] <= res["centre_dev_max_D"] * job.nozzle_diameter / res["h"]


def _lag_scene(tmp_path, cost):
    text = (ROOT / "examples/diw/line_reduced.toml").read_text()
    text = text.replace('toolpath = "line"', 'toolpath = "bend90"')
    text += (f'\n[optimize]\nevaluator = "lag-model"\npopulation = 4\nlag_cost = {cost}\n'
             'method = "pso"\n')
    scene = tmp_path / "bend90_lag.toml"
    scene.write_text(text)
    return scene


def _optimize_cmd(scene, out, budget, *extra):
    return [sys.executable, "-m", "sphfem.cli", "optimize", str(scene), "--out", str(out),
            "--budget", str(budget), "--no-progress", *extra]


def test_resume_after_killed_driver_recomputes_nothing(client, tmp_path):
    """Kill `sphfem optimize` (the driver and its LocalCluster worker, SIGKILL) once a few
    evaluations are cached.  The folder is then refused without resume; resuming finishes
    without rewriting any cached record, writes the report, and reaches the same best point
    as an uninterrupted run (the seeded optimiser retraces the interrupted one)."""
    from sphfem.diw.driver import optimize_job
    from sphfem.diw.job import load_job
    from sphfem.errors import OutputExistsError

    scene = _lag_scene(tmp_path, cost=0.25)
    out = tmp_path / "run"
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.Popen(_optimize_cmd(scene, out, 12), env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    cache = out / "cache"
    try:
        t0 = time.time()
        while time.time() - t0 < 60:
            if cache.exists() and len(list(cache.glob("*.json"))) >= 4:
                break
            assert proc.poll() is None, "the driver ended before it was killed"
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(timeout=30)
    before = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in cache.glob("*.json")}
    assert 4 <= len(before) < 12
    assert not (out / "best_parameters.json").exists()
    job, _, _ = load_job(scene)
    with pytest.raises(OutputExistsError, match="--resume"):
        optimize_job(job, out, budget=12, population=4, client=client, stream=None)
    summary = optimize_job(job, out, budget=12, population=4, resume=True, progress=False,
                           client=client, stream=None)
    for name, (mtime, data) in before.items():
        p = cache / name
        assert p.stat().st_mtime_ns == mtime and p.read_bytes() == data
    assert summary["cached"] == len(before)
    assert summary["computed"] == 12 - len(before)
    for png in ("fitness_history.png", "toolpath_naive.png", "toolpath_best.png"):
        assert (out / png).stat().st_size > 0
    # resuming the finished run: nothing computed, the report's two runs kept
    finals = {n: (out / n / "final.json").stat().st_mtime_ns for n in ("naive", "best")}
    again = optimize_job(job, out, budget=12, population=4, resume=True, progress=False,
                         client=client, stream=None)
    assert again["computed"] == 0 and again["objective"] == summary["objective"]
    assert again["best"] == summary["best"]
    assert {n: (out / n / "final.json").stat().st_mtime_ns for n in finals} == finals
    # uninterrupted, from scratch (lag_cost, a sleep, is not part of the job's hash)
    fresh = dataclasses.replace(job, lag_cost=0.0)
    ref = optimize_job(fresh, tmp_path / "ref", budget=12, population=4, progress=False,
                       report=False, client=client, stream=None)
    assert ref["computed"] == 12
    assert ref["objective"] == summary["objective"]
    assert ref["parameters"] == summary["parameters"]


def test_small_budget_runs_one_smaller_population(client, tmp_path):
    """`--budget 3` with 20 members per iteration: 3 evaluations (one batch of 3), not 20."""
    from sphfem.diw.driver import optimize_job

    job = ToolpathJob("bend90", 0.1, 7e-4, 1.75e-4, evaluator="lag-model")
    s = optimize_job(job, tmp_path / "o", budget=3, population=20, progress=False,
                     report=False, client=client, stream=None)
    assert s["evaluations"] == s["computed"] == 3


def test_start_naive_is_evaluated_and_never_beaten_by_worse(client, tmp_path):
    """With start_naive (default) the naive toolpath is evaluated in the first iteration
    and the result is at most its objective; without it, it is not evaluated."""
    from sphfem.diw.driver import optimize_job

    job = ToolpathJob("bend90", 0.1, 7e-4, 1.75e-4, evaluator="lag-model")
    naive = job(job.space.naive())["objective"]
    assert naive == job.evaluate(None)[0]["objective"]  # the naive point is the naive path
    key = point_key(job_hash(job.describe()), job.space.naive())
    s = optimize_job(job, tmp_path / "a", budget=8, population=4, progress=False,
                     report=False, client=client, stream=None)
    assert ResultCache(tmp_path / "a" / "cache").get(key)["iteration"] == 0
    assert s["objective"] <= naive
    optimize_job(job, tmp_path / "b", budget=8, population=4, progress=False, report=False,
                 client=client, stream=None, start_naive=False)
    assert ResultCache(tmp_path / "b" / "cache").get(key) is None


def test_cli_refuses_a_scene_without_extrusion(tmp_path, capsys):
    """`sphfem optimize` on a scene that is not an extrusion job: exit code 2, one line."""
    from sphfem.cli import main

    scene = tmp_path / "plain.toml"
    text = (ROOT / "examples/diw/line_reduced.toml").read_text()
    text = re.sub(r"\n\[extrusion\]\n(.+\n)+", "\n", text)  # the table up to a blank line
    scene.write_text(text.replace('"fluid", "extrusion"', '"fluid"'))
    assert main(["optimize", str(scene), "--out", str(tmp_path / "o")]) == 2
    assert "extrusion" in capsys.readouterr().err
