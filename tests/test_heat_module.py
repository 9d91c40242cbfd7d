"""The ``heat`` physics module through a scene: registry, [heat] section, a driver run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sphfem.validation.heat import rod_exact

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "heat_rod" / "heat_rod.toml"


def test_registry_import_is_cheap():
    """Importing sphfem.heat registers the module and section without numba or scipy."""
    code = ("import sys, sphfem.heat; from sphfem.physics import MODULES; "
            "from sphfem.schema import SECTIONS; "
            "print(MODULES['heat'], 'heat' in SECTIONS, 'numba' in sys.modules, "
            "'scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, env={"PYTHONPATH": str(ROOT)}, check=True).stdout.split()
    assert out == ["sphfem.heat.module:HeatConduction", "True", "False", "False"]


def test_heat_section_rejects_bad_values():
    from sphfem.scene import SceneError, parse_scene_toml

    text = SCENE.read_text()
    with pytest.raises(SceneError, match="theta"):
        parse_scene_toml(text.replace("theta = 0.5", "theta = 0.2"))
    with pytest.raises(SceneError, match="temperature"):
        parse_scene_toml(text.replace('temperature = 301.0', ''))


def test_heat_rod_scene_runs(tmp_path):
    """The example scene: Crank-Nicolson at 10x the explicit step, ghosts at both ends,
    T against the Fourier series, energy ledger balanced, in summary.json."""
    from sphfem.scene import load_scene
    from sphfem.simulation import Simulation

    sim = Simulation(load_scene(SCENE), source=str(SCENE))
    (tmp_path / "out").mkdir()
    summary = sim.run(tmp_path / "out", progress=False)
    d = summary["diagnostics"]["heat"]
    assert d["ghosts"]["dirichlet"] == 6 and summary["particles"]["ghost"] == 6
    assert abs(d["energy_balance_residual_rel"]) < 1e-12
    assert d["explicit_stable_dt_s"] > 0 and 0.5 < d["explicit_dt_constant_C"] < 1.0
    ps = sim.particles
    real = ps.kind != 3
    x = ps.x[real, 0]
    err = np.max(np.abs(ps.T[real] - 300.0 - rod_exact(x, 0.03)))
    assert err < 2e-3  # 80 particles, CN at 10x: measured 1.4e-4 order
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "energy_drift_rel" in saved["diagnostics"]["heat"]
