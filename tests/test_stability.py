"""Stability hardening: the stability matrix, the uncapped time step, the heat guard and its
positivity limiter, and the driver's refusal to write non-finite states."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sphfem.scene import parse_scene
from sphfem.simulation import Simulation, SimulationStopped
from sphfem.validation import stability as S


def test_positivity_limit_blends_only_rows_with_negative_weights():
    """Row 0 has a negative weight: it is blended with the plain row just enough that its
    smallest weight is 0; row 1 is all positive and is left exactly as it was."""
    from sphfem.heat.conduction import positivity_limit

    offsets = np.array([0, 3, 5])
    w = np.array([2.0, -1.0, 3.0, 1.0, 0.5])
    wb = np.array([1.0, 1.0, 1.0, 2.0, 2.0])
    beta = np.zeros(2)
    positivity_limit(w, wb, offsets, beta)
    assert beta[0] == pytest.approx(0.5) and beta[1] == 0.0  # -(-1) / (1 - (-1))
    assert np.allclose(w, [1.5, 0.0, 2.0, 1.0, 0.5])
    assert w.min() >= 0.0


def test_jitter_is_seeded_and_bounded():
    """[[blocks]] jitter moves each coordinate by at most jitter dx, the same way for the
    same seed."""
    from sphfem.geometry import block_points

    plain = parse_scene(S.contrast_scene(True))
    shaken = parse_scene(S.contrast_scene(True, jitter=0.2))
    x0 = block_points(plain, 0)
    x1, x2 = block_points(shaken, 0), block_points(shaken, 0)
    assert np.array_equal(x1, x2) and x1.shape == x0.shape
    d = np.abs(x1 - x0).max(axis=0)
    dx = 1.0 / 32
    assert np.all(d <= 0.2 * dx) and np.all(d > 0.15 * dx)


def _heat_scene(dt_factor: float, cap: bool) -> dict:
    data = S.rest_heat_scene(True)
    limit, _ = S._stable_limit(data)
    data["time"].update(dt=dt_factor * limit, cap_dt=cap, t_end=60 * limit)
    return data, limit


def test_capped_dt_adapts_and_uncapped_dt_is_taken_as_given(tmp_path):
    data, limit = _heat_scene(2.0, True)
    s = Simulation(parse_scene(data)).run(tmp_path / "capped", progress=False)
    assert s["status"] == "completed" and s["dt"]["max"] <= limit * (1 + 1e-12)
    assert s["dt"]["steps_above_stable_limit"] == 0
    data, limit = _heat_scene(0.9, False)
    s = Simulation(parse_scene(data)).run(tmp_path / "uncapped", progress=False)
    assert s["dt"]["max"] == pytest.approx(0.9 * limit)
    assert s["dt"]["controlling_limit_counts"] == {"time.dt": s["steps"]}


def test_heat_guard_stops_an_unstable_explicit_run_before_nan(tmp_path):
    """Explicit heat at 2x its stable step grows a checkerboard mode; the maximum-principle
    guard stops it within a few tens of steps, every written file is finite and the
    summary says why."""
    data, _ = _heat_scene(2.0, False)
    out = tmp_path / "run"
    with pytest.raises(SimulationStopped, match="temperature outside"):
        Simulation(parse_scene(data)).run(out, progress=False)
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "stopped" and "heat.bound_margin" in s["message"]
    assert s["steps"] < 60
    assert S._nonfinite_files(out) == []


def _poison_class():
    from sphfem.physics import PhysicsModule

    class _Poison(PhysicsModule):
        name = "poison"

        def dt_limits(self, sim):
            return {"poison": 1e-3}

        def step(self, sim, dt):
            if sim.step_count == 3:
                sim.particles.T[5] = np.nan

    return _Poison


Poison = _poison_class()


def test_non_finite_state_is_never_written(tmp_path):
    """A module that poisons the state: the NaN guard stops the run and the last output is
    the last finite state."""
    from sphfem.physics import MODULES
    from sphfem.schema import register_module, unregister

    register_module("poison", target="test_stability:Poison")
    try:
        data = S.contrast_scene(True)
        data["physics"]["modules"] = ["poison"]
        del data["heat"]
        data["time"] = {"t_end": 0.01}
        data["output"] = {"every": 2e-3}
        out = tmp_path / "run"
        with pytest.raises(SimulationStopped, match="non-finite"):
            Simulation(parse_scene(data)).run(out, progress=False)
        s = json.loads((out / "summary.json").read_text())
        assert "was not written" in s["message"]
        assert S._nonfinite_files(out) == []
    finally:
        unregister("poison")
        MODULES.pop("poison", None)


def test_validate_stability_quick_exits_zero(tmp_path, capsys):
    """The acceptance command: every row of the quick matrix stable or stopped cleanly, the
    uncapped 2x/8x rows stopped by a guard, the report and JSON written."""
    from sphfem.cli import main

    code = main(["validate", "stability", "--quick", "--out", str(tmp_path / "st")])
    out = capsys.readouterr().out
    assert code == 0, out
    rep = json.loads((tmp_path / "st" / "stability.json").read_text())
    rows = {r["name"]: r for r in rep["rows"]}
    assert set(rows) == {r.name for r in S.ROWS}
    for name in ("heat-dt-2x", "heat-dt-8x", "fluid-dt-8x"):
        assert rows[name]["verdict"] == S.STOPPED and rows[name]["reason"], name
    for name in ("stiff-substrate-300GPa", "stiff-substrate-300GPa-tlsph", "thermal-shock-1000K",
                 "disordered-20pct",
                 "heat-dt-0.9x", "heat-dt-2x-capped", "fluid-dt-2x-capped"):
        assert rows[name]["verdict"] == S.STABLE, (name, rows[name]["reason"])
    assert "| stiff-substrate-300GPa | stable |" in (tmp_path / "st" / "stability.md").read_text()
