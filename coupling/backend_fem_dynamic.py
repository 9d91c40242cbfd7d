"""Elastodynamic FEM substrates as coupling backends: "fem-dynamic" and
"fem-axisymmetric-dynamic".

The loads are handed over exactly as by :class:`coupling.backends.FEMBackend` and
:class:`coupling.backend_fem_axisymmetric.AxisymmetricFEMBackend` (f = P^T F, the
temperature map); ``solve(t)`` then advances an
:class:`sphfem.fem.elastodynamic.ElastodynamicSubstrate` (HHT-alpha / Newmark) from the
previous coupling time to ``t`` instead of solving K u = f.  The step dt = t - t_prev is
whatever the driver's coupling interval is (the SPH step or k of them, varying); the
effective matrix is refactorised only when dt changes (a few sizes are cached).  A second
``solve`` at the same t returns the last result without stepping.  The state at ``t0``
(constructor) is rest: a first ``solve(t0)`` puts it in equilibrium under the load of
that moment (the quasi-static solution, v = a = 0); later loads act from there.

Registration.  Importing this module adds both names to
:data:`coupling.backends.BACKENDS`.
"""

from __future__ import annotations

import time

from coupling.backend_fem_axisymmetric import AxisymmetricFEMBackend
from coupling.backends import BACKENDS, CoupledResult, FEMBackend

__all__ = ["DynamicFEMBackend", "AxisymmetricDynamicFEMBackend"]


class _DynamicMixin:
    """``solve(t)`` by time stepping; shared by the plane/3D and axisymmetric backends."""

    def _init_dynamic(self, rho, hht_alpha, mass, t0):
        from sphfem.fem.elastodynamic import ElastodynamicSubstrate

        self.dyn = ElastodynamicSubstrate(self.sub, rho, hht_alpha=hht_alpha, mass=mass,
                                          t0=t0)
        self.last = None

    def solve(self, t: float) -> CoupledResult:
        if self.last is not None and t == self.dyn.t:
            return self.last
        if self.last is None and t == self.dyn.t:
            # the first solve at the start time: the substrate is at rest in equilibrium
            # under the load present then (K u0 = f0, v0 = a0 = 0), the quasi-static state
            out = super().solve(t)
            self.dyn.reset(u0=out.result.dofs, f0=out.result.load, t0=t)
            return out
        dt = float(t) - self.dyn.t
        if not dt > 0:
            raise ValueError(f"{self.name}: coupling time {t} is not after the previous "
                             f"one ({self.dyn.t}); the dynamic substrate only steps forward")
        t0 = time.perf_counter()
        dT = None if self._T_nodes is None else self._T_nodes - self.T0
        f = self.sub.basis.zeros() if self._f is None else self._f
        if dT is not None:
            f = f + self.sub.thermal_load(dT)
        res = self.dyn.advance(dt, f, dT)
        self.timings["solve"] += time.perf_counter() - t0
        t1 = time.perf_counter()
        _ = res.von_mises_nodes
        self.last = CoupledResult(res, t, self.T0, self.sub.mesh.p.T, res.stress_elem,
                                  self._cell_volume)
        self.timings["stress"] += time.perf_counter() - t1
        self.n_solves += 1
        return self.last

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d.update(backend=self.name, dynamics=self.dyn.diagnostics())
        return d


class DynamicFEMBackend(_DynamicMixin, FEMBackend):
    """:class:`coupling.backends.FEMBackend` with an elastodynamic substrate; ``rho``
    [kg/m^3], ``hht_alpha`` (0: Newmark average acceleration), ``mass``, ``t0`` as
    :class:`sphfem.fem.elastodynamic.ElastodynamicSubstrate`."""

    name = "fem-dynamic"

    def __init__(self, substrate, rho: float, surface: str = "top",
                 temperature_map: str = "mls", R: float | None = None,
                 kernel: str = "wendland_c2", hht_alpha: float = 0.0,
                 mass: str = "consistent", t0: float = 0.0):
        super().__init__(substrate, surface, temperature_map, R, kernel)
        self._init_dynamic(rho, hht_alpha, mass, t0)


class AxisymmetricDynamicFEMBackend(_DynamicMixin, AxisymmetricFEMBackend):
    """:class:`coupling.backend_fem_axisymmetric.AxisymmetricFEMBackend` (ring forces,
    per-radian loads) with an elastodynamic substrate (r-weighted mass)."""

    name = "fem-axisymmetric-dynamic"

    def __init__(self, substrate, rho: float, surface: str = "top",
                 temperature_map: str = "mls", R: float | None = None,
                 kernel: str = "wendland_c2", force_convention: str = "ring",
                 hht_alpha: float = 0.0, mass: str = "consistent", t0: float = 0.0):
        super().__init__(substrate, surface, temperature_map, R, kernel, force_convention)
        self._init_dynamic(rho, hht_alpha, mass, t0)


BACKENDS["fem-dynamic"] = DynamicFEMBackend
BACKENDS["fem-axisymmetric-dynamic"] = AxisymmetricDynamicFEMBackend
