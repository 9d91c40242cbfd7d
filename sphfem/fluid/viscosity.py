"""Registry of the fluid's viscosity models (``[fluid] viscosity``).

Every fluid particle carries its dynamic viscosity in the field ``mu`` [Pa s] (from its
material; the stand-alone :class:`~sphfem.fluid.wcsph.FluidSolver` fills zeros with
``FluidParams.mu``); ``"none"`` (no entry) sets it to 0: inviscid, only the artificial
viscosity ``[fluid] alpha`` (Monaghan 1992, a stabilisation added to any model) acts.  A
model either is *fused*, its pair term computed inside the WCSPH force pass
(:func:`sphfem.fluid.passes.fluid_forces`, which then reads ``mu``), or adds its own pass
after the WCSPH forces (``accelerate``, like a surface-tension method): it adds its
acceleration to the fluid rows of ``acc`` and the reaction to the wall rows of ``f_fluid``.
The viscous time-step limit ``visc_cfl h^2 min(rho/mu)`` applies to every model that is
not ``implicit`` (an implicit model solves for the viscous velocity change itself; the
step then comes from the other limits).

Each model lives in one module named after its paper and registers a
:class:`ViscosityMethod` at import (kept as the module's ``METHOD``).  Adding a model: a
new module ``viscosity_<paper>.py`` and its name in :data:`METHOD_MODULES`
(docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry

#: the viscosity-model modules, in the order of the ``viscosity`` choices (one line each)
METHOD_MODULES = (
    "sphfem.fluid.viscosity_laminar_shao2003",
    "sphfem.fluid.viscosity_morris1997",
    "sphfem.fluid.viscosity_implicit_weiler2018",
    "sphfem.fluid.viscosity_semi_implicit_park2019",
)


@dataclass(frozen=True)
class ViscosityMethod:
    """One viscosity model.

    name        the value of ``[fluid] viscosity``
    doc         its description in the key's documentation
    params      its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    fused       True: the WCSPH force pass computes the term from the particles' ``mu``
    accelerate  ``(solver, state) -> state`` (not fused): add the viscous acceleration to
                ``solver.p.acc`` (fluid rows) and the reaction force to ``solver.p.f_fluid``
                (wall rows) after the WCSPH forces; ``state`` (None at first) is the
                model's work arrays, kept by the solver between evaluations
    implicit    True: the model integrates the viscous term implicitly over the step
                ``solver.step_dt`` (no viscous time-step limit)
    """

    name: str
    doc: str
    params: tuple
    fused: bool
    accelerate: Callable | None = None
    implicit: bool = False


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] viscosity``
REGISTRY = MethodRegistry("viscosity", METHOD_MODULES,
                          none_doc="inviscid (mu = 0; only the artificial alpha term acts)")
register = REGISTRY.register
lookup = REGISTRY.lookup
