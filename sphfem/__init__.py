"""sphfem: coupled SPH-FEM multiphysics for droplet deposition on substrates.

The building blocks (kernels, neighbour search, SPH operators, particles) live in the
top-level modules; physics families live in sub-packages (``heat``, ``fluid``, ``solid``,
``fem``) and are only imported when a scene asks for them.
"""

__version__ = "0.1.0"
