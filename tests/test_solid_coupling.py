"""The coupling driver with the TL-SPH substrate backend (``[coupling] backend = "tlsph"``):
a hot water block on an alumina block (2D), heat only."""

from __future__ import annotations

import numpy as np

SCENE = """
[scene]
name = "hot_block_tlsph"
dim = 2

[domain]
lo = [-0.6e-3, -0.3e-3]
hi = [0.6e-3, 0.3e-3]

[sph]
dx = 25e-6

[materials.water]
rho0 = 1000.0
c = 4000.0
k = 0.6

[materials.alumina]
rho0 = 3950.0
c = 900.0
k = 10.0
E = 300e9
nu = 0.21
alpha = 8.1e-6

[[blocks]]
name = "substrate"
shape = "box"
kind = "solid"
material = "alumina"
lo = [-0.5e-3, -0.25e-3]
hi = [0.5e-3, 0.0]
temperature = "20 C"

[[blocks]]
name = "hot"
shape = "box"
kind = "fluid"
material = "water"
lo = [-0.2e-3, 0.0]
hi = [0.2e-3, 0.1e-3]
temperature = "100 C"

[physics]
modules = ["heat", "coupling"]

[coupling]
backend = "tlsph"
material = "alumina"
clamps = ["left", "right"]
every_k_steps = 3
vtu_every = 2
probes = [[0.0, -12.5e-6], [0.0, -0.1e-3]]

[time]
t_end = 6e-4
"""


def test_coupled_run_with_the_tlsph_substrate(tmp_path, monkeypatch):
    from coupling.driver import run_scene
    from sphfem.scene import parse_scene_toml

    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))
    sim, summary = run_scene(parse_scene_toml(SCENE), tmp_path / "out")
    d = summary["diagnostics"]["coupling"]
    b = d["backend"]
    assert b["backend"] == "tlsph" and b["B0_fallbacks"] == 0
    steps = summary["steps"]
    assert d["solves"] == 1 + steps // 3 + (steps % 3 != 0)
    assert b["relax_steps"][0] == 0  # no load at t = 0: nothing to relax
    assert abs(d["heat"]["residual_rel"]) < 1e-11
    # heated from above, clamped at the sides: the hot top is in lateral compression
    top = d["last"]["probes"][0]
    assert top["xx"] < 0 and top["T"] > 293.15 + 1.0
    assert d["peak_von_mises_Pa"] > 1e6 and np.isfinite(d["peak_von_mises_Pa"])
    assert d["vtu_written"] >= 2
