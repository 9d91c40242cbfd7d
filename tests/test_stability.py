"""Stability hardening: the stability matrix, the uncapped time step, the heat guard and its
positivity limiter, and the driver's refusal to write non-finite states."""

from __future__ import annotations

import json
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from sphfem.particles import ParticleKind
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


@contextmanager
def _test_module(name: str, attribute: str):
    """Register this file's module class ``attribute`` as physics module ``name`` for the
    block, and yield a scene running only it (the contrast scene's particles, t_end 0.01)."""
    from sphfem.physics import MODULES
    from sphfem.schema import register_module, unregister

    register_module(name, target=f"test_stability:{attribute}")
    try:
        data = S.contrast_scene(True)
        data["physics"]["modules"] = [name]
        del data["heat"]
        data["time"] = {"t_end": 0.01}
        yield data
    finally:
        unregister(name)
        MODULES.pop(name, None)


def _poison_class():
    from sphfem.physics import PhysicsModule

    class _Poison(PhysicsModule):
        name = "poison"

        def dt_limits(self, ctx):
            return {"poison": 1e-3}

        def step(self, ctx, dt):
            if ctx.step == 3:
                ctx.particles.T[5] = np.nan

    return _Poison


Poison = _poison_class()


def test_non_finite_state_is_never_written(tmp_path):
    """A module that poisons the state: the NaN guard stops the run and the last output is
    the last finite state."""
    with _test_module("poison", "Poison") as data:
        data["output"] = {"every": 2e-3}
        out = tmp_path / "run"
        with pytest.raises(SimulationStopped, match="non-finite"):
            Simulation(parse_scene(data)).run(out, progress=False)
        s = json.loads((out / "summary.json").read_text())
        assert "was not written" in s["message"]
        assert S._nonfinite_files(out) == []


def _negative_limit_class():
    from sphfem.physics import PhysicsModule

    class _NegativeLimit(PhysicsModule):
        """A limit that turns negative at step 3 (as the viscous limit h^2 rho_min / mu does
        when a density goes below 0): the driver must stop, not step backwards for ever."""

        name = "neglimit"

        def dt_limits(self, ctx):
            return {"viscous": 1e-3 if ctx.step < 3 else -8.8e-7}

        def step(self, ctx, dt):
            pass

    return _NegativeLimit


NegativeLimit = _negative_limit_class()


def test_a_non_positive_time_step_limit_stops_the_run(tmp_path):
    """A time-step limit <= 0 (or NaN) stops the run with a message naming the limit; the
    run used to take the negative step and go back in time without end."""
    with _test_module("neglimit", "NegativeLimit") as data:
        out = tmp_path / "run"
        with pytest.raises(SimulationStopped, match=r"neglimit.viscous is -8.8e-07"):
            Simulation(parse_scene(data)).run(out, progress=False)
        s = json.loads((out / "summary.json").read_text())
        assert s["status"] == "stopped" and s["steps"] == 3
        assert s["t"] == pytest.approx(3e-3)


def _nan_writer_class():
    from sphfem.physics import PhysicsModule

    class _NanWriter(PhysicsModule):
        """Writes a probe table with a NaN into the run's folder: only the output scan can
        see it (the particle state stays finite)."""

        name = "nanwriter"

        def dt_limits(self, ctx):
            return {"nanwriter": 1e-3}

        def step(self, ctx, dt):
            if ctx.step == 2:
                (ctx.out / "extra").mkdir(exist_ok=True)
                (ctx.out / "extra" / "probes.csv").write_text("t,T\n0.0,300.0\n0.002,nan\n")

    return _NanWriter


NanWriter = _nan_writer_class()


# --------------------------------------------------------------------------------------
# the matrix' checks: each one can fail, and a missing figure fails


def _outcome(**kw) -> S.Outcome:
    """A synthetic run outcome: 10 particles (8 fluid, 2 ghost) at rest, T in [300, 400]."""
    n = 10
    kind = np.array([ParticleKind.FLUID] * 8 + [ParticleKind.GHOST] * 2)
    T = np.linspace(300.0, 400.0, n)
    state = {"x": np.zeros((n, 2)), "v": np.ones((n, 2)), "m": np.ones(n), "T": T,
             "kind": kind}
    base = dict(summary={"steps": 10, "diagnostics": {}}, folder=Path(tempfile.mkdtemp()),
                stopped=False,
                message="", initial=state, final={k: v.copy() for k, v in state.items()},
                scene={}, stable_limit=None)
    base.update(kw)
    return S.Outcome(**base)


def _passes(check, o) -> bool:
    row = S.Row("r", "", lambda q: {}, checks={"c": check})
    return S._evaluate(row, o)[0]["c"]["passed"]


def _coupling(**d):
    return {"steps": 10, "diagnostics": {"coupling": d}}


def _heat_residual(r):
    return {"diagnostics": {"heat": {} if r is None else {"energy_balance_residual_rel": r}}}


@pytest.mark.parametrize("check, good, bad", [
    (S._energy_balance, dict(summary=_heat_residual(-3e-16)),
     dict(summary=_heat_residual(2e-6))),
    (S._energy_balance, dict(summary=_heat_residual(0.0)), dict(summary=_heat_residual(None))),
    (S._force_balance, dict(summary=_coupling(force_residual_rel_max=1e-15)),
     dict(summary=_coupling(force_residual_rel_max=1e-3))),
    # a coupling that never solved has no residual: a failure, not 0.0
    (S._force_balance, dict(summary=_coupling(force_residual_rel_max=0.0)),
     dict(summary=_coupling(force_residual_rel_max=None))),
    (S._thermal_stress_scale(300e9, 0.21, 8.1e-6, 1000.0),
     dict(summary=_coupling(peak_von_mises_Pa=3e9)),
     dict(summary=_coupling(peak_von_mises_Pa=3e10))),
    (S._thermal_stress_scale(300e9, 0.21, 8.1e-6, 1000.0),
     dict(summary=_coupling(peak_von_mises_Pa=3e9)), dict(summary=_coupling())),
    (S._dt_capped, dict(summary={"dt": {"max": 1e-6}}, stable_limit=1e-6),
     dict(summary={"dt": {"max": 1.5e-6}}, stable_limit=1e-6)),
    (S._dt_capped, dict(summary={"dt": {"max": 1e-6}}, stable_limit=1e-6),
     dict(summary={"dt": {"max": 1e-6}})),
])
def test_summary_checks_can_fail(check, good, bad):
    assert _passes(check, _outcome(**good))
    assert not _passes(check, _outcome(**bad))


def test_max_principle_and_guard_band_can_fail():
    """Ghost temperatures are ignored; a non-ghost particle 1 % of the range outside fails
    the strict maximum principle but not the guard's 10 % band; 20 % fails both; a
    Dirichlet temperature widens the range; NaN or no temperatures fail."""
    o = _outcome()
    o.final["T"][9] = 1000.0  # a ghost
    assert _passes(S._max_principle(), o) and _passes(S._within_guard_band, o)
    o.final["T"][0] = 299.0
    assert not _passes(S._max_principle(), o) and _passes(S._within_guard_band, o)
    o.final["T"][0] = 280.0
    assert not _passes(S._within_guard_band, o)
    held = {"heat": {"boundaries": [{"condition": "dirichlet", "temperature": 250.0}]}}
    assert _passes(S._max_principle(), _outcome(final=o.final, scene=held))
    o.final["T"][0] = np.nan
    assert not _passes(S._max_principle(), o)
    assert not _passes(S._max_principle(), _outcome(final={}))


def test_energy_gain_can_fail():
    """Kinetic energy lost passes; 2 % gained fails at 1 %; gravity counts (a particle that
    fell by h with v^2 = 2 g h conserves energy); no fluid particle is a failure."""
    o = _outcome()
    o.final["v"] *= 0.5
    assert _passes(S._energy_gain(), o)
    o.final["v"] = o.initial["v"] * np.sqrt(1.02)
    assert not _passes(S._energy_gain(), o) and _passes(S._energy_gain(0.1), o)
    g, h = 9.81, 0.01
    fall = _outcome(scene={"fluid": {"gravity": [0.0, -g]}})
    fall.initial["v"][:] = 0.0
    fall.final["v"][:] = [0.0, -np.sqrt(2 * g * h)]
    fall.final["x"][:, 1] -= h
    assert _passes(S._energy_gain(1e-12), fall)
    fall.final["x"][:, 1] += 0.1 * h  # the same speed from a shorter fall: energy made
    assert not _passes(S._energy_gain(), fall)
    dry = _outcome()
    for st in (dry.initial, dry.final):
        st["kind"] = np.full(10, 2)
    assert not _passes(S._energy_gain(), dry)


def _write_vtu(path, T):
    import meshio

    n = len(T)
    meshio.write(path, meshio.Mesh(np.zeros((n, 3)), [("vertex", np.arange(n)[:, None])],
                                   point_data={"T": np.asarray(T, float)}))


@pytest.mark.parametrize("fmt", ["vtu", "csv", "json", "npz"])
def test_nonfinite_file_scan_fires(fmt, tmp_path):
    """The output scan finds a NaN in every format a run writes; the finite twin passes."""
    for name, val in (("good", 1.0), ("bad", np.nan)):
        f = tmp_path / name / f"out.{fmt}"
        f.parent.mkdir()
        if fmt == "vtu":
            _write_vtu(f, [300.0, val])
        elif fmt == "csv":
            f.write_text(f"t,T\n0.0,{val!r}\n")
        elif fmt == "json":
            f.write_text(json.dumps({"history": [{"T": [1.0, val]}]}))
        else:
            with open(f, "wb") as fh:
                np.savez(fh, T=np.array([1.0, val]), names=np.array(["a"]))
    assert S._nonfinite_files(tmp_path / "good") == []
    assert S._nonfinite_files(tmp_path / "bad") == [f"out.{fmt}"]
    checks, failures = S._evaluate(S.Row("r", "", lambda q: {}),
                                   _outcome(folder=tmp_path / "bad"))
    assert not checks["non-finite files written"]["passed"] and failures


def test_stop_checks_can_fail():
    """A required stop: the wrong guard, a stop past the bound, or no stop at all fail."""
    row = S.Row("r", "", lambda q: {}, S.STOPPED, S.HEAT_GUARD, 13)
    msg = "heat stopped at step 2, t = 1 s: 3 particle(s) with temperature outside [1, 2] K"
    ok, fail = S._evaluate(row, _outcome(stopped=True, message=msg, summary={"steps": 1}))
    assert not fail and ok["stopped by the expected guard"]["passed"]
    nan = "step 2, t = 1 s: non-finite values in T (3 particles)"
    _, fail = S._evaluate(row, _outcome(stopped=True, message=nan, summary={"steps": 1}))
    assert fail == ["stopped by the expected guard: 0 not >= 1"]
    _, fail = S._evaluate(row, _outcome(stopped=True, message=msg, summary={"steps": 40}))
    assert fail == ["stop step: 41 not <= 13"]
    _, fail = S._evaluate(row, _outcome(stopped=False, summary={"steps": 40}))
    assert fail == ["stop step: - not <= 13"]
    assert S._growth_steps(2.0) == 32 and S._growth_steps(8.0) == 13


def test_every_row_has_physics_checks():
    """Every row has at least one check of its own besides the output scan; a row that may
    stop names the guard it expects, a row that must stop has a step bound."""
    for r in S.ROWS:
        assert r.checks, r.name
        assert r.expect in (S.STABLE, S.STOPPED, S.EITHER), r.name
        if r.expect != S.STABLE:
            assert r.guard, r.name
        if r.expect == S.STOPPED:
            assert r.max_stop_step, r.name


def _row(name: str, **changes) -> S.Row:
    from dataclasses import replace

    return replace(next(r for r in S.ROWS if r.name == name), **changes)


def test_checks_run_after_a_stop(tmp_path):
    """heat-dt-8x stops cleanly; a check its state before the stop misses (the strict
    maximum principle: that state is some 3 % of the range outside) fails the row: a stop
    does not skip the checks."""
    res = S.run_row(_row("heat-dt-8x"), True, tmp_path / "a")
    assert res.verdict == S.STOPPED, res.reason
    assert res.checks["stop step"]["value"] <= S._growth_steps(8.0)
    strict = _row("heat-dt-8x", checks={"max principle": S._max_principle()})
    res = S.run_row(strict, True, tmp_path / "b")
    assert res.verdict == S.FAILED and "max principle" in res.reason
    assert res.checks["max principle"]["value"] > 1e-3


def test_a_disabled_guard_fails_a_row_that_must_stop(tmp_path):
    """heat-dt-8x with its guard widened out of reach (bound_margin = 1e30) runs to t_end
    with the temperature blown up: the row fails (no stop, no stop step)."""

    def build(q):
        d = S.rest_heat_scene(q)
        d["heat"]["bound_margin"] = 1e30
        return d

    res = S.run_row(_row("heat-dt-8x", build=build), True, tmp_path / "run")
    assert res.verdict == S.FAILED
    assert "a guard must stop this scene" in res.reason and "stop step" in res.reason


def test_nonfinite_output_fails_the_row(tmp_path):
    """A run whose particle state stays finite but which writes a NaN into a result file:
    the row fails on the output scan."""
    with _test_module("nanwriter", "NanWriter") as data:
        row = S.Row("nan-output", "", lambda q: data, checks={"steps": lambda o: (
            o.summary["steps"], 1, ">=")})
        res = S.run_row(row, True, tmp_path / "run")
        assert res.verdict == S.FAILED, res.reason
        assert "non-finite files written: 1 not <= 0" in res.reason


@pytest.mark.slow  # 124 s of one worker: the default suite's longest test (2026-12-02)
def test_validate_stability_quick_exits_zero(tmp_path, capsys):
    """The acceptance command: every row of the quick matrix passes its checks, the rows
    that must stop stopped on their guard, the rows that must run through did, and the
    report and JSON are written."""
    from sphfem.cli import main

    code = main(["validate", "stability", "--quick", "--out", str(tmp_path / "st")])
    out = capsys.readouterr().out
    assert code == 0, out
    rep = json.loads((tmp_path / "st" / "stability.json").read_text())
    rows = {r["name"]: r for r in rep["rows"]}
    assert set(rows) == {r.name for r in S.ROWS}
    for r in S.ROWS:
        got = rows[r.name]
        assert got["checks"] and all(c["passed"] for c in got["checks"].values()), got
        if r.expect == S.STOPPED:
            assert got["verdict"] == S.STOPPED and got["reason"], r.name
        elif r.expect == S.STABLE:
            assert got["verdict"] == S.STABLE, (r.name, got["reason"])
    assert "| stiff-substrate-300GPa | stable |" in (tmp_path / "st" / "stability.md").read_text()
