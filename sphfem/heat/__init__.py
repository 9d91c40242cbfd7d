"""SPH heat conduction: rho c dT/dt = div(k grad T) on particles of several materials.

Modules (one job each): :mod:`~sphfem.heat.conduction` (pair conductances, Cleary and
Fatehi-Manzari), :mod:`~sphfem.heat.ghosts` (algorithm 2.5 ghosts and boundary rules),
:mod:`~sphfem.heat.system` (rate and sparse matrix of the same operator),
:mod:`~sphfem.heat.stepping` (explicit Heun, theta method with one LU),
:mod:`~sphfem.heat.energy` (energy ledger), :mod:`~sphfem.heat.problem` (stand-alone
problems), :mod:`~sphfem.heat.params` (parameters), :mod:`~sphfem.heat.module` (the
``heat`` physics module).  Importing this package registers the module by name only;
nothing is compiled until it is used.
"""

from sphfem.heat.scene_section import HEAT
from sphfem.physics import register_physics
from sphfem.schema import register_module

register_module("heat", HEAT, target="sphfem.heat.module:HeatConduction")
register_physics("heat", "sphfem.axisymmetric_scene:AxisymmetricHeatModule",
                 geometry="axisymmetric")
