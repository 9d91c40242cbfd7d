"""The surface-tension registry chooses the method (issue 15).

``FluidSolver`` and the ``[fluid]`` declaration take the methods from
:mod:`sphfem.fluid.surface_tension`; a method registered from outside the fluid package
(no change to ``wcsph.py`` or ``scene_section.py``) is calibrated and applied.

Physics check of the plug-in path: a toy method adds the uniform acceleration
a = sigma / (rho0 R) along x to every fluid particle; on a disc at rest the acceleration
with the method minus the one without must be exactly that (to round-off), and the
calibration must report the sigma the method returns.
"""

from __future__ import annotations

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver, surface_tension
from sphfem.fluid.scene_section import FLUID
from sphfem.fluid.setup import droplet_packing, make_particles
from sphfem.particles import FLUID as FLUID_KIND
from sphfem.schema import Param


def test_the_scene_section_takes_choices_and_keys_from_the_registry():
    params = {p.name: p for p in FLUID.params}
    assert params["surface_tension"].choices == surface_tension.names()
    assert surface_tension.names()[:1] == ("none",)
    assert set(surface_tension.names()[1:]) == {"csf", "iif", "akinci"}
    for name, method in surface_tension.methods().items():
        for p in method.params:  # each key exists only for its own method
            assert params[p.name].when == ("surface_tension", (name,))
        if method.constant_key is not None:
            assert method.constant_key in {p.name for p in method.params}
    assert surface_tension.lookup("none") is None
    with pytest.raises(ValueError, match="unknown surface_tension"):
        surface_tension.lookup("brackbill")
    with pytest.raises(ValueError, match="unknown surface_tension"):
        FluidParams(surface_tension="brackbill", sigma=0.07)


def _disc_solver(**kw):
    dx, Rd = 1e-4, 1e-3
    x = droplet_packing(2, Rd, dx)
    ps = make_particles(x, None, dx, 1000.0)
    par = FluidParams(rho0=1000.0, c0=10.0, mu=1e-3, gravity=(0.0, 0.0), delta=0.0, **kw)
    return FluidSolver(ps, 3 * dx, [-2 * Rd] * 2, [2 * Rd] * 2, params=par)


def test_a_method_registered_from_outside_is_applied():
    calls = []

    def calibrate(pa, m_bar, R, dim):
        k = pa.st_params.get("toy_k")
        k = pa.sigma / (pa.rho0 * R) if k is None else k  # acceleration [m/s^2]
        return k, k * pa.rho0 * R

    def accelerate(solver, state):
        p = solver.p
        p.acc[p.kind == FLUID_KIND, 0] += solver.st_constant
        calls.append(state)
        return len(calls)  # the solver keeps the state between evaluations

    toy = surface_tension.SurfaceTensionMethod(
        name="toy", doc="uniform acceleration sigma/(rho0 R) along x",
        params=(Param("toy_k", float, None, when=("surface_tension", ("toy",))),),
        constant_key="toy_k", calibrate=calibrate, accelerate=accelerate)
    surface_tension.register(toy)
    try:
        with pytest.raises(ValueError, match="registered twice"):
            surface_tension.register(toy)
        ref = _disc_solver()
        s = _disc_solver(surface_tension="toy", sigma=0.072)
        a = 0.072 / (1000.0 * s.R)
        assert s.st_constant == pytest.approx(a, rel=1e-15)
        assert s.st_sigma == pytest.approx(0.072, rel=1e-15)
        fl = s.p.kind == FLUID_KIND
        diff = s.p.acc[fl] - ref.p.acc[fl]
        np.testing.assert_allclose(diff[:, 0], a, rtol=1e-12)
        np.testing.assert_allclose(diff[:, 1], 0.0, atol=1e-12 * a)
        s.evaluate()
        assert calls == [None, 1]  # state handed back by the solver
        # the method's own key, passed as the scene would (FluidParams.st_params)
        s2 = _disc_solver(surface_tension="toy", st_params={"toy_k": 2.0})
        assert s2.st_constant == 2.0
        assert s2.dt_limits()["capillary"] > 0
    finally:
        surface_tension.REGISTRY.unregister("toy")
