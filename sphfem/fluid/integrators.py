"""Registry of the fluid's time integrators (``[fluid] integrator``).

An integrator advances the fluid particles' ``x``, ``v`` and ``rho`` by one step ``dt``
with the force evaluation of :class:`~sphfem.fluid.wcsph.FluidSolver`:

    advance(solver, dt)
        calls ``solver.after_drift()`` whenever it has moved particles and needs the
        neighbour list valid again, ``solver.evaluate(t)`` for the accelerations ``acc``
        and density rates ``drho`` at time ``t``, and keeps its start-of-step state in
        ``solver._scratch.v_n`` / ``rho_n`` (permuted with the particles by a cell sort);
        the solver then shifts particles (``[fluid] shifting``) and advances ``t``.

Wall particles are not moved (their state comes from the wall model).  The solver starts
with one evaluation at the initial state, so ``acc`` and ``drho`` are valid when the first
step begins (a scheme that reuses the last evaluation, as the symplectic one does, costs one
evaluation per step).  The integrators apply to the weakly compressible pressure model
(:mod:`sphfem.fluid.pressure`); the incompressible pressure solvers of issue 17 bring their
own step.

Each integrator lives in one module named after its paper and registers an
:class:`Integrator` at import (kept as the module's ``METHOD``).  Adding one: a new module
``integrator_<paper>.py`` and its name in :data:`METHOD_MODULES` (docs/architecture.md,
"Adding a method").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry

#: the integrator modules, in the order of the ``integrator`` choices (one line each)
METHOD_MODULES = (
    "sphfem.fluid.integrator_symplectic_gomezgesteira2012",
)


@dataclass(frozen=True)
class Integrator:
    """One time integrator.

    name     the value of ``[fluid] integrator``
    doc      its description in the key's documentation
    params   its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    order    its order of accuracy in time
    advance  ``(solver, dt) -> None``: one step (see the module docstring)
    """

    name: str
    doc: str
    params: tuple
    order: int
    advance: Callable


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] integrator``
REGISTRY = MethodRegistry("integrator", METHOD_MODULES, family="time-integrator")
register = REGISTRY.register
lookup = REGISTRY.lookup
