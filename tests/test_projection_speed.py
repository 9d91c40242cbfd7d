"""Work the projection methods (IISPH, DFSPH) leave out, and the DFSPH warm starts.

* the force pass under a projection method runs without the delta-SPH term, so the
  renormalised density gradient (:func:`sphfem.fluid.passes.density_gradient`) is not
  computed (it feeds only ``drho``, which the projection does not use; the density is a
  summation there), while the accelerations stay bit-identical; WCSPH still computes it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver, passes
from sphfem.fluid.setup import box_walls, lattice, make_particles


def _solver(pressure: str, n: int = 8, **kw) -> FluidSolver:
    """2D column H = 1 m, H/n spacing, in a tank with 3 wall layers."""
    H, g = 1.0, 9.81
    dx = H / n
    ps = make_particles(lattice([0, 0], [H, H], dx), box_walls([0, 0], [2 * H, 1.5 * H], dx, 3),
                        dx, 1000.0)
    par = FluidParams(rho0=1000.0, c0=10 * math.sqrt(g * H), mu=1e-3, gravity=(0.0, -g),
                      alpha=0.02, pressure=pressure, **kw)
    m = 4 * dx
    return FluidSolver(ps, 3 * dx, [-m, -m], [2 * H + m, 1.5 * H], params=par)


def _count_gradient_calls(monkeypatch) -> list:
    calls = []
    orig = passes.density_gradient

    def counted(*a):
        calls.append(1)
        return orig(*a)

    monkeypatch.setattr(passes, "density_gradient", counted)
    return calls


@pytest.mark.parametrize("pressure", ["dfsph", "iisph"])
def test_projection_skips_the_density_gradient(monkeypatch, pressure):
    calls = _count_gradient_calls(monkeypatch)
    s = _solver(pressure, delta=0.1)
    for _ in range(3):
        s.step(1e-3)
    assert not calls  # the delta term (and with it the gradient) is WCSPH's only
    acc = s.p.acc.copy()
    s0 = _solver(pressure, delta=0.0)
    for _ in range(3):
        s0.step(1e-3)
    assert np.array_equal(acc, s0.p.acc)  # delta never entered a projection's forces


def test_wcsph_still_computes_the_density_gradient(monkeypatch):
    calls = _count_gradient_calls(monkeypatch)
    s = _solver("wcsph", delta=0.1)
    s.step(1e-4)
    assert calls
