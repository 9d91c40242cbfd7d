"""Weakly compressible delta-SPH fluid with Adami walls (issue 4).

* :mod:`sphfem.fluid.eos` -- Tait equation of state and its inverse;
* :mod:`sphfem.fluid.passes` -- fused numba passes (density gradient, forces);
* :mod:`sphfem.fluid.walls_adami2012` -- wall pressure / velocity extrapolation;
* :mod:`sphfem.fluid.guards` -- stability guards;
* :mod:`sphfem.fluid.wcsph` -- :class:`FluidParams`, :class:`FluidSolver`, the ``fluid``
  physics module;
* :mod:`sphfem.fluid.setup` -- lattices, wall layers and hydrostatic initial states;
* :mod:`sphfem.fluid.bench` -- the 3D dam-break throughput benchmark.
"""

from sphfem.fluid.wcsph import FluidModule, FluidParams, FluidSolver

__all__ = ["FluidModule", "FluidParams", "FluidSolver"]
