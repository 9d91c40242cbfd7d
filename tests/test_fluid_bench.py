"""``sphfem bench dambreak2d | droplet3d`` (quick): figures present and consistent."""

import pytest

from sphfem.bench import BENCHMARKS, run_bench


@pytest.mark.parametrize("name", ["dambreak2d", "droplet3d"])
def test_fluid_bench_quick(name):
    assert name in BENCHMARKS
    res = run_bench(name, quick=True, threads=(1,), verbose=False)
    (r,) = res["runs"]
    assert r["case"] == name and r["threads"] == 1
    assert r["dim"] == (2 if name == "dambreak2d" else 3)
    assert r["pairs"] > 10 * r["n_fluid"]
    assert r["pairs_per_s"] > 0 and r["particle_steps_per_s"] > 0
    assert 0 < r["cpu_search_share"] < 1
