"""Weakly compressible delta-SPH fluid with Adami walls (issue 4).

* :mod:`sphfem.fluid.eos` -- Tait equation of state and its inverse;
* :mod:`sphfem.fluid.passes` -- fused numba passes (density gradient, forces);
* method registries (:class:`sphfem.methods.MethodRegistry`), one module per method:
  :mod:`~sphfem.fluid.pressure` (``wcsph``:
  :mod:`~sphfem.fluid.pressure_deltasph_antuono2010`), :mod:`~sphfem.fluid.integrators`
  (``symplectic``: :mod:`~sphfem.fluid.integrator_symplectic_gomezgesteira2012`),
  :mod:`~sphfem.fluid.walls` (``adami2012``: :mod:`~sphfem.fluid.walls_adami2012`),
  :mod:`~sphfem.fluid.viscosity` (``laminar``:
  :mod:`~sphfem.fluid.viscosity_laminar_shao2003`, ``morris``:
  :mod:`~sphfem.fluid.viscosity_morris1997`) and :mod:`~sphfem.fluid.surface_tension`
  (:mod:`~sphfem.fluid.surface_tension_csf`,
  :mod:`~sphfem.fluid.surface_tension_iif_tartakovsky2005`,
  :mod:`~sphfem.fluid.surface_tension_akinci2013`);
* :mod:`sphfem.fluid.surface` -- colour gradient, free-surface detection, shifting;
* :mod:`sphfem.fluid.guards` -- stability guards;
* :mod:`sphfem.fluid.wcsph` -- :class:`FluidParams`, :class:`FluidSolver`, the ``fluid``
  physics module;
* :mod:`sphfem.fluid.standalone` -- the context and Verlet list of a stand-alone run;
* :mod:`sphfem.fluid.scene_section` -- the ``[fluid]`` scene section;
* :mod:`sphfem.fluid.setup` -- lattices, wall layers and hydrostatic initial states;
* :mod:`sphfem.fluid.packing` -- initial particle packing (``[fluid.packing]``, declared in
  :mod:`sphfem.fluid.packing_section`);
* :mod:`sphfem.fluid.bench` -- the 3D dam-break throughput benchmark.

Importing this package registers the module and its section; the solver classes are
imported on first attribute access.  The section's method keys come from the method
modules, which declare them next to their numba kernels, so importing the package loads
numba (nothing is compiled).
"""

from dataclasses import replace as _replace

from sphfem.fluid.packing_section import PACKING
from sphfem.fluid.scene_section import FLUID
from sphfem.physics import register_physics
from sphfem.schema import register_module

# [fluid.packing] is declared next to the packing (sphfem.fluid.packing_section)
register_module("fluid", _replace(FLUID, subsections=FLUID.subsections + (PACKING,)),
                target="sphfem.fluid.wcsph:FluidModule")
register_physics("fluid", "sphfem.axisymmetric_scene:AxisymmetricFluidModule",
                 geometry="axisymmetric")

__all__ = ["FluidModule", "FluidParams", "FluidSolver"]


def __getattr__(name):
    if name in __all__:
        from sphfem.fluid import wcsph

        return getattr(wcsph, name)
    raise AttributeError(f"module 'sphfem.fluid' has no attribute {name!r}")
