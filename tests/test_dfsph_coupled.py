"""A hot ink drop lands on the FEM substrate with ``pressure = "dfsph"`` (issue 17).

``examples/scenes/hot_ink_drop_dfsph.toml``: a 2D viscous ink drop (R = 0.25 mm, 80 C,
mu = 0.5 Pa s, implicit viscosity) lands at 0.1 m/s on an alumina substrate (20 C) that
is coupled one way to a clamped FEM block (modules fluid, heat, coupling).  Checked:

* the DFSPH solve holds its density tolerance at every step, never at the iteration limit,
  and the step has no acoustic limit;
* heat balance: the heat the ink lost equals the heat the SPH substrate gained (Cleary's
  conservative Laplacian in an insulated box: equal to round-off, measured 2e-14), and the
  exchange is sizeable (6.9 % of the ink's m c (80 C - 20 C) within 20 ms);
* load: once the drop rests (t >= 10 ms, 9 ms after it touched down and ~90 viscous
  damping times rho R^2 / mu = 0.1 ms later) the total normal force handed to the FEM
  equals the drop's weight m g (per metre of depth): its time mean within 1 % and every
  coupling solve within 5 % (the solve's pressure noise; measured: mean -0.2 %, spread
  -2.7 .. +2.7 % over 12 solves); the tangential force vanishes; the clamp's reaction
  carries the load.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sphfem.particles import FLUID, WALL

SCENE = Path(__file__).resolve().parents[1] / "examples" / "scenes" / "hot_ink_drop_dfsph.toml"
G = 9.81
#: the drop has landed and its impact is damped (see the module docstring)
T_REST = 0.01


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))


@pytest.fixture
def result(tmp_path, cache):
    from sphfem.api import run

    return run(SCENE, tmp_path / "out")


def test_hot_ink_drop_lands_on_the_fem_substrate_with_dfsph(result):
    res = result
    assert res.status == "completed"
    fluid = res.diagnostics["fluid"]
    solve = fluid["pressure_solve"]
    assert solve["steps"] == res.summary["steps"] and solve["steps_not_converged"] == 0
    assert solve["density_error_percent"]["max"] <= solve["tolerance_percent"]
    assert "acoustic" not in fluid["dt_limits_s"]

    # heat: lost by the ink = gained by the substrate particles, to round-off
    q = res.coupling["heat"]
    ps = res.simulation.particles
    fl = ps.kind == FLUID
    e_ink = float(np.sum(ps.m[fl] * ps.c_heat[fl] * (353.15 - ps.T[fl])))
    assert q["heat_lost_by_fluid_J"] == pytest.approx(e_ink, rel=1e-12)
    excess = float(np.sum(ps.m[fl] * ps.c_heat[fl])) * (353.15 - 293.15)
    assert q["heat_lost_by_fluid_J"] > 0.02 * excess  # measured 6.9 % of m c (T_ink - T_sub)
    assert abs(q["residual_rel"]) < 1e-11 and q["heat_to_other_particles_J"] == 0.0
    assert ps.T[ps.kind == WALL].max() > 293.15 + 1.0

    # load: the FEM carries the resting drop's weight
    weight = float(ps.m[fl].sum()) * G
    hist = [h for h in res.history() if h["t"] >= T_REST]
    assert len(hist) >= 10
    fy = np.array([h["force_load"][1] for h in hist])
    fx = np.array([h["force_load"][0] for h in hist])
    assert abs(-fy.mean() / weight - 1.0) < 0.01
    assert np.abs(-fy / weight - 1.0).max() < 0.05
    assert np.abs(fx).max() < 1e-9 * weight
    drv = next(m for m in res.simulation.modules if m.name == "coupling").driver
    reaction = drv.last.result.reaction("bottom")
    assert reaction[1] == pytest.approx(-hist[-1]["force_load"][1], rel=1e-6)
