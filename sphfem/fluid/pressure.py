"""Registry of the fluid's pressure models (``[fluid] pressure``).

A pressure model owns the fluid's time step: ``advance(solver, dt)`` moves the fluid
particles' ``x``, ``v``, ``rho`` (and ``p``) by ``dt`` through the force evaluation of
:class:`~sphfem.fluid.wcsph.FluidSolver`.  Today there is one, the weakly compressible
delta-SPH model (:mod:`~sphfem.fluid.pressure_deltasph_antuono2010`, ``"wcsph"``): the
pressure follows from the density by the Tait equation of state inside the force pass, and
the step is the chosen time integrator's (:mod:`sphfem.fluid.integrators`).

The incompressible pressure solvers of issue 17 (IISPH, Ihmsen et al. 2014; DFSPH, Bender &
Koschier 2017) join here: each is one module ``pressure_<paper>.py`` whose ``advance``
predicts the velocities with the non-pressure forces, solves for the pressure and
integrates, plus its name in :data:`METHOD_MODULES` (docs/architecture.md, "Adding a
method"), and its own keys (tolerance, iteration limits) declared with ``when=``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry

#: the pressure-model modules, in the order of the ``pressure`` choices (one line each)
METHOD_MODULES = (
    "sphfem.fluid.pressure_deltasph_antuono2010",
)


@dataclass(frozen=True)
class PressureMethod:
    """One pressure model.

    name     the value of ``[fluid] pressure``
    doc      its description in the key's documentation
    params   its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    advance  ``(solver, dt) -> None``: one time step of the fluid particles
    """

    name: str
    doc: str
    params: tuple
    advance: Callable


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] pressure``
REGISTRY = MethodRegistry("pressure", METHOD_MODULES, family="pressure")
register = REGISTRY.register
lookup = REGISTRY.lookup
