"""Registry of the fluid's wall models (``[fluid] walls``).

A wall model gives the wall particles (kind WALL) the state the fluid's pair terms read
before every force evaluation: pressure ``p`` and density ``rho`` of each wall particle and
the velocity the viscous term sees (``vg`` of the solver's work arrays, the ghost velocity).
The fluid's passes then treat a wall particle like a fluid neighbour of mass rho_w V_w, and
each wall particle's ``f_fluid`` receives the exact negative of the pair forces.

Each model lives in one module named after its paper and registers a :class:`WallMethod`
at import (kept as the module's ``METHOD``): today :mod:`~sphfem.fluid.walls_adami2012`
(Adami, Hu & Adams 2012).  Adding a model: a new module ``walls_<paper>.py`` and its name in
:data:`METHOD_MODULES` (docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry

#: the wall-model modules, in the order of the ``walls`` choices (one line per model)
METHOD_MODULES = (
    "sphfem.fluid.walls_adami2012",
)


@dataclass(frozen=True)
class WallMethod:
    """One wall model.

    name        the value of ``[fluid] walls``
    doc         its description in the key's documentation
    params      its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    wall_state  ``(solver, g) -> None``: write ``p``, ``rho`` of the wall particles and
                their viscous velocity ``solver._scratch.vg`` (fluid pressures are up to
                date; ``g`` is the body force per unit mass at this evaluation)
    """

    name: str
    doc: str
    params: tuple
    wall_state: Callable


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] walls``
REGISTRY = MethodRegistry("walls", METHOD_MODULES, family="wall")
register = REGISTRY.register
lookup = REGISTRY.lookup
