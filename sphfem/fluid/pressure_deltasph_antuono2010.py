"""Weakly compressible delta-SPH (``pressure = "wcsph"``).

Antuono, Colagrossi, Marrone & Molteni (2010), Comput. Phys. Commun. 181, 532; Marrone et
al. (2011): the density evolves by the continuity equation with the diffusive term
delta h c0 D_i (``[fluid] delta``, renormalised density gradient), and the pressure follows
from it by the Tait equation of state (Monaghan 1994; Park 2019 eq. 2.73)

    p = rho0 c0^2 / gamma ((rho / rho0)^gamma - 1),

evaluated inside the force pass (:func:`sphfem.fluid.passes.prepare_fluid`).  The step is
the chosen time integrator's (``[fluid] integrator``, :mod:`sphfem.fluid.integrators`),
limited by the acoustic CFL condition dt <= cfl h / (c0 + |v|max).
"""

from __future__ import annotations

from sphfem.fluid.pressure import PressureMethod, register


def advance(solver, dt: float) -> None:
    """One step of the solver's time integrator."""
    solver.integrator.advance(solver, dt)


METHOD = register(PressureMethod(
    name="wcsph",
    doc="weakly compressible delta-SPH (Antuono et al. 2010, Marrone et al. 2011): Tait "
        "equation of state, density diffusion `delta`, explicit step of `integrator` under "
        "the acoustic CFL limit",
    params=(),
    advance=advance,
))
