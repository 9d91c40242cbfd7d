"""Coupling between the SPH side (sensor particles) and substrate backends (FEM, TL-SPH).

Modules, one job each:

* :mod:`coupling.sensors` -- the sensor particles (the SPH solid region's surface layers):
  the force the fluid exerts on them and the region's temperatures;
* :mod:`coupling.transfer` -- conservative point-force load f = P^T F on the substrate's
  surface and the particle -> node temperature map;
* :mod:`coupling.backends` -- the substrate-backend protocol and the FEM backend;
* :mod:`coupling.driver` -- the one-way staggered driver and the ``coupling`` physics
  module;
* :mod:`coupling.scene_section` -- the ``[coupling]`` scene section.

Importing this package registers the module and its section only (no numba / scipy).
"""

from coupling.scene_section import COUPLING
from sphfem.schema import register_module

register_module("coupling", COUPLING, target="coupling.driver:CouplingModule")
