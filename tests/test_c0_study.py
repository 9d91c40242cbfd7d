"""examples/droplet_impact/c0_study.py: the wall pressure it reads from the ring forces and
the axisymmetric dynamic backend it puts into the scene (the library's
"fem-axisymmetric-dynamic" stepping, reached through the scene's RingBackend)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np

from coupling.axisymmetric_scene import RingBackend
from coupling.backend_fem_dynamic import AxisymmetricDynamicFEMBackend
from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, graded_tensor_rz

E, NU, RHO = 300e9, 0.21, 3950.0
R_SUB, DEPTH = 1e-3, 0.26e-3
EXAMPLE = Path(__file__).parents[1] / "examples" / "droplet_impact" / "c0_study.py"


def study():
    spec = importlib.util.spec_from_file_location("c0_study", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_wall_pressure_of_ring_forces():
    """Rings of three wall layers carrying a pressure p(r) = p0 (1 - (r/a)^2) on the
    annuli of their columns (total ring force p(r_c) 2 pi r_c dx, split unevenly over the
    layers): every column's pressure is p(r_c) to round-off; peak and axis value are kept
    with the time of the following solve."""
    mod = study()
    dx, p0, a = 1e-6, 7.4e7, 12e-6
    n = 15
    rc = (np.arange(n) + 0.5) * dx
    p = p0 * np.clip(1 - (rc / a) ** 2, 0, None)
    share = np.array([0.6, 0.3, 0.1])
    pts = np.array([[r + 0.2 * dx * (k - 1), -(k + 0.5) * dx] for r in rc for k in range(3)])
    F = np.array([[0.0, -pk * 2 * math.pi * r * dx * s]
                  for r, pk in zip(rc, p, strict=True) for s in share])
    wall = mod.WallPressure(dx)
    r_out, p_out = wall.columns(pts, F)
    assert np.allclose(r_out, rc, rtol=0, atol=1e-15)
    assert np.allclose(p_out, p, rtol=1e-12, atol=1e-12 * p0)
    wall.record(pts, F)
    wall.commit(3e-9)
    assert wall.peak["t_s"] == 3e-9 and wall.peak["r_m"] == rc[0]
    assert math.isclose(wall.peak["p_Pa"], p[0], rel_tol=1e-12)
    assert wall.axis == [(3e-9, wall.peak["p_Pa"])]


def test_study_backend_steps_as_the_library_dynamic_backend():
    """The scene's RingBackend turned dynamic by study_backend gives, for the same ring
    forces at irregular coupling times, the states of AxisymmetricDynamicFEMBackend
    ("ring" convention) to round-off (1e-12 of the largest displacement); the quasi-static
    variant gives RingBackend's."""
    mod = study()

    def sub():
        m = graded_tensor_rz(R_SUB, DEPTH, 20e-6, 100e-6, growth=1.3)
        return AxisymmetricFEMSubstrate(m, E, NU, 0.0, clamps=["bottom"],
                                        force_convention="ring")

    n = 8
    X = np.column_stack([(np.arange(n) + 0.5) * 10e-6, np.zeros(n)])
    times = np.cumsum([2e-9, 2e-9, 3e-9, 1.5e-9, 3e-9])
    ref = AxisymmetricDynamicFEMBackend(sub(), RHO, force_convention="ring",
                                        hht_alpha=-0.05, temperature_map="off")
    wall = mod.WallPressure(10e-6)
    dyn = mod.study_backend(RingBackend(sub(), force_convention="ring",
                                        temperature_map="off"),
                            wall, dynamic=True, rho=RHO, hht_alpha=-0.05)
    qs_ref = RingBackend(sub(), force_convention="ring", temperature_map="off")
    qs = mod.study_backend(RingBackend(sub(), force_convention="ring",
                                       temperature_map="off"), mod.WallPressure(10e-6))
    for k, t in enumerate(times):
        F = np.column_stack([np.zeros(n), -1.0 * (k + 1) * (1 + X[:, 0] / X[-1, 0])])
        outs = []
        for b in (ref, dyn, qs_ref, qs):
            b.apply(X, F)
            outs.append(b.solve(t).result.dofs)
        scale = np.abs(outs[0]).max()
        assert scale > 0
        assert np.abs(outs[1] - outs[0]).max() <= 1e-12 * scale
        assert np.abs(outs[3] - outs[2]).max() <= 1e-12 * np.abs(outs[2]).max()
        assert np.abs(outs[0] - outs[2]).max() > 1e-3 * scale  # the dynamics do act
    assert dyn.dyn.n_steps == ref.dyn.n_steps == len(times)
    assert len(wall.axis) == len(times)
