"""Coupling between the SPH side (sensor particles) and substrate backends (FEM, TL-SPH).

Modules, one job each:

* :mod:`coupling.sensors` -- the SPH solid region (:func:`~coupling.sensors.coupled_region`)
  and its sensor particles (the surface layers): the force the fluid exerts on them and the
  region's temperatures;
* :mod:`coupling.transfer` -- conservative point-force load f = P^T F on the substrate's
  surface and the particle -> node temperature map;
* :mod:`coupling.backends` -- the substrate-backend protocol, both backends (FEM and TL-SPH,
  wrapping ``sphfem``'s substrates) and their one result type;
* :mod:`coupling.driver` -- the one-way staggered driver and the ``coupling`` physics
  module;
* :mod:`coupling.scene_section` -- the ``[coupling]`` scene section.

``coupling`` depends on ``sphfem``, never the reverse.  Importing this package registers the
module and its section only (no numba / scipy).
"""

from coupling.scene_section import COUPLING
from sphfem.schema import register_module

register_module("coupling", COUPLING, target="coupling.driver:CouplingModule")
