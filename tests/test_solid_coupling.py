"""The coupling driver with the TL-SPH substrate backend (``[coupling] backend = "tlsph"``):
a hot water block on an alumina block (2D), heat only."""

from __future__ import annotations

import numpy as np
from test_coupling import HOT  # the same hot-block scene, with the FEM backend

# the FEM scene with the TL-SPH backend: no mesh section, probes inside the TL-SPH body
SCENE = (
    HOT.replace('name = "hot_block"', 'name = "hot_block_tlsph"')
    .replace('[coupling]\nmaterial', '[coupling]\nbackend = "tlsph"\nmaterial')
    .replace('[coupling.mesh]\nh_fine = 25e-6\ncells = "tri"\n',
             'probes = [[0.0, -12.5e-6], [0.0, -0.1e-3]]\n')
)


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
