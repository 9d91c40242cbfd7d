"""Total-Lagrangian SPH thermo-elastic solid (Park 2019 sec. 2.5; Ganzenmueller 2015).

Modules, one job each:

* :mod:`~sphfem.solid.reference`    -- reference neighbours (kept for the run), kernel
  gradients, correction tensors B0 (eq. 2.117)
* :mod:`~sphfem.solid.kinematics`   -- deformation gradient F (eq. 2.128)
* :mod:`~sphfem.solid.constitutive` -- F = F_e F_theta, SVK thermo-elastic S, P = F S,
  Cauchy stress, von Mises (eqs. 2.118-2.125)
* :mod:`~sphfem.solid.forces`       -- momentum-conserving reference divergence of P and
  hourglass control
* :mod:`~sphfem.solid.body`         -- :class:`SolidBody`: state, boundary conditions,
  force pipeline, stable step
* :mod:`~sphfem.solid.integrate`    -- velocity Verlet, implicit trapezoid by fixed-point
  iteration (sec. 2.5.5), dynamic relaxation
* :mod:`~sphfem.solid.thermal`      -- heat conduction through :mod:`sphfem.heat` (ghosts)
* :mod:`~sphfem.solid.lattice`      -- particle lattices
* :mod:`~sphfem.solid.backend`      -- :class:`TLSPHSubstrate`, the quasi-static substrate
  with FEMSubstrate's ``solve`` (the coupling's TL-SPH backend,
  ``coupling.backends.TLSPHBackend``, wraps it; this package never imports ``coupling``)
* :mod:`~sphfem.solid.module`       -- :class:`TLSPHModule`, the ``tlsph`` physics module
  of the scene driver; :mod:`~sphfem.solid.scene_section` its ``[tlsph]`` section

Importing this package registers the ``tlsph`` module and its section by name only; it
compiles nothing.
"""

from sphfem.schema import register_module
from sphfem.solid.scene_section import TLSPH

register_module("tlsph", TLSPH, target="sphfem.solid.module:TLSPHModule")


def __getattr__(name):
    if name == "TLSPHSubstrate":
        from sphfem.solid.backend import TLSPHSubstrate

        return TLSPHSubstrate
    if name == "SolidBody":
        from sphfem.solid.body import SolidBody

        return SolidBody
    raise AttributeError(name)
