"""Direct ink writing (DIW): nozzle extrusion and toolpath optimisation (thesis chapter 3).

A nozzle moving over a substrate lays down a bead of Herschel-Bulkley ink. Where the path
turns, the ink already extruded keeps its momentum and lands off the intended line
("whipping"). The toolpath is corrected by moving waypoints of the desired path along its
normal (thesis eq. 3.41-3.46) and searching the offsets with a gradient-free optimiser,
one extrusion simulation per candidate, evaluated on Dask.

Modules
-------
``toolpath``   desired paths in parametric form, waypoint offsets (s_i, delta_i), PCHIP
               toolpath, the named bends of thesis section 3.4 (issue 18, part A)
``fitness``    deviation of a deposit from the desired path (thesis metric and
               practitioner metrics: max/mean deviation in nozzle diameters, width, gaps)
``optimize``   ask/tell optimisers (thesis PSO, CMA-ES, DE) on an evaluation budget
``evaluate``   Dask evaluation: tasks keyed by a hash of scene + parameters, on-disk cache,
               retry-once-then-failed, resume
``report``     fitness history and top-view PNGs, best parameters JSON
``extrusion``  the extrusion physics: nozzle emitter, moving nozzle, deposition (part B)

The contract between the optimisation machinery (part A) and the physics (part B)
---------------------------------------------------------------------------------
``sphfem.diw.extrusion.simulate_deposit(scene, path, out_dir=None) -> DepositResult``

* ``scene``: a loaded scene (``sphfem.scene``) of an extrusion job.
* ``path``: any object with ``position(t) -> (2,)`` nozzle xy in the substrate plane [m],
  ``velocity(t) -> (2,)`` [m/s] and ``duration`` [s]; ``sphfem.diw.toolpath.Toolpath``
  satisfies it.
* ``out_dir``: folder for the run's VTU (or None: write nothing).
* ``DepositResult`` has ``positions`` (n, 3) of the deposited ink particles [m],
  ``h`` (smoothing length / particle spacing [m]), ``nozzle_diameter`` [m], ``info``
  (dict with at least ``steps``, ``wall_s``, ``stopped_reason`` (str or None)) and ``vtu``
  (path or None).

The fitness reads only ``positions[:, :2]`` (projection on the substrate), ``h`` and
``nozzle_diameter``; a non-None ``stopped_reason`` marks a failed evaluation.
"""

from sphfem.diw import optimize_section as _optimize_section  # noqa: E402, F401  (registers [optimize])
from sphfem.diw import scene_section as _scene_section  # noqa: E402, F401  (registers [extrusion])
