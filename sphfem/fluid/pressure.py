"""Registry of the fluid's pressure models (``[fluid] pressure``).

A pressure model owns the fluid's time step: its ``advance(solver, dt)`` moves the fluid
particles' ``x``, ``v``, ``rho`` (and ``p``) by ``dt`` with the force evaluation of
:class:`~sphfem.fluid.wcsph.FluidSolver` (``solver.evaluate(t)``: ``acc`` and ``drho`` at
the current positions).  There are two kinds, told apart by :attr:`PressureMethod.eos`:

**Equation of state** (``solve`` None; ``"wcsph"``,
:mod:`~sphfem.fluid.pressure_deltasph_antuono2010`): the pressure follows from the
density inside the force pass, so ``acc`` holds every force, pressure included, and
``advance`` is an explicit step of the chosen time integrator
(:mod:`sphfem.fluid.integrators`).

**Pressure projection** (a ``solve``; IISPH, Ihmsen et al. 2014; DFSPH, Bender & Koschier
2017): the force pass runs *without pressure* -- ``acc`` holds gravity, viscosity, surface
tension and the wall's viscous reaction only, and ``p`` keeps the method's own pressures
-- and the step is :func:`projection_advance`, the semi-implicit Euler scheme of both
papers (Ihmsen et al. 2014, Alg. 1; Bender & Koschier 2017, Alg. 1):

    v*      = v^n + dt a_nonp(x^n, v^n)             advection with the forces without pressure
    v^{n+1} = v* + dt a_p                          ``solve(solver, dt, state) -> state``
    x^{n+1} = x^n + dt v^{n+1}                     then the list and a_nonp at x^{n+1}

``solve`` is the method's own pressure solve: on entry ``solver.p.v`` holds v* of the fluid
particles and the list is valid at x^n; it sets ``p`` (walls included, for the reaction
``f_fluid`` it adds to the wall particles) and the fluid's pressure velocity change (and
``rho`` if it evolves it), and returns its state for the next step (warm start; kept by
the solver, not permuted by cell sorts, so no per-particle arrays).  Adding one: a module
``pressure_<paper>.py`` registering ``PressureMethod(name, doc, params, solve=...)``, its
name in :data:`METHOD_MODULES` and its own keys (tolerance, iteration limits) declared
with ``when=`` (docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry
from sphfem.particles import FLUID

#: the pressure-model modules, in the order of the ``pressure`` choices (one line each)
METHOD_MODULES = (
    "sphfem.fluid.pressure_deltasph_antuono2010",
    "sphfem.fluid.pressure_iisph_ihmsen2014",
    "sphfem.fluid.pressure_dfsph_bender2017",
)


def projection_advance(solver, dt: float) -> None:
    """One step of a pressure-projection method (see the module docstring): advection with
    the last evaluation's forces without pressure, the method's ``solve``, the drift, and
    the forces without pressure at the new positions."""
    method = solver.pressure_method
    p = solver.p
    t0 = time.perf_counter()
    fl = p.kind == FLUID
    p.v[fl] += dt * p.acc[fl]
    solver.wall["integrate"] += time.perf_counter() - t0
    solver.pressure_state = method.solve(solver, dt, solver.pressure_state)
    t0 = time.perf_counter()
    p.x[fl] += dt * p.v[fl]
    solver.wall["integrate"] += time.perf_counter() - t0
    solver.after_drift()
    solver.evaluate(solver.t + dt)
    if method.finish is not None:  # e.g. its pressure reaction on the walls into f_fluid
        method.finish(solver, solver.pressure_state)


@dataclass(frozen=True)
class PressureMethod:
    """One pressure model: give ``advance`` (equation of state) or ``solve`` (projection).

    name     the value of ``[fluid] pressure``
    doc      its description in the key's documentation
    params   its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    advance  ``(solver, dt) -> None``: one time step of the fluid particles (a projection
             method's is :func:`projection_advance`)
    solve    ``(solver, dt, state) -> state``: a projection method's pressure solve
    finish   ``(solver, state) -> None``: a projection method's last word after the forces
             without pressure at x^{n+1} (which rewrote the walls' ``f_fluid``)
    """

    name: str
    doc: str
    params: tuple
    advance: Callable | None = None
    solve: Callable | None = None
    finish: Callable | None = None

    def __post_init__(self):
        if (self.advance is None) == (self.solve is None):
            raise ValueError(f"pressure method {self.name!r}: give advance (an equation of "
                             "state) or solve (a pressure projection), not both or neither")
        if self.advance is None:
            object.__setattr__(self, "advance", projection_advance)

    @property
    def eos(self) -> bool:
        """The pressure follows from the density in the force pass (no solve of its own)."""
        return self.solve is None


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] pressure``
REGISTRY = MethodRegistry("pressure", METHOD_MODULES, family="pressure")
register = REGISTRY.register
lookup = REGISTRY.lookup
