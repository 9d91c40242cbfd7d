"""sphfem: coupled SPH-FEM multiphysics for droplet deposition on substrates.

The building blocks (kernels, neighbour search, SPH operators, particles) live in the
top-level modules; physics families live in sub-packages (``heat``, ``fluid``, ``solid``,
``fem``) and are only imported when a scene asks for them.
"""

__version__ = "0.1.0"

import os as _os

# numba's OpenMP threading layer: let idle worker threads sleep between parallel regions
# instead of spinning (GNU OpenMP spins by default).  On the shared 2-core machine at load
# 8-11 the spinning made a 2-thread run of the axisymmetric droplet job 2.8x slower than
# with sleeping threads (120 vs 43 s, 41 vs 10 CPU-s; benchmarks/README.md "Axisymmetric
# droplet job").  Read when the OpenMP runtime starts (numba's first parallel kernel); a
# value set by the user wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# The library facade (docs/api.md), imported on first use so that ``import sphfem`` stays
# free of numba, scipy and scikit-fem.
_LAZY = {
    "run": "sphfem.api", "load_scene": "sphfem.api", "load_result": "sphfem.api",
    "Result": "sphfem.api", "RunStopped": "sphfem.api", "validate": "sphfem.api",
    "validation_cases": "sphfem.api", "format_table": "sphfem.validation",
    "FEMSubstrate": "sphfem.fem", "load_mesh": "sphfem.fem",
    "substrate_rect": "sphfem.fem", "substrate_block": "sphfem.fem",
    "TLSPHSubstrate": "sphfem.solid.backend",
    "SceneError": "sphfem.errors", "OutputExistsError": "sphfem.output",
    "OutputFolderError": "sphfem.errors",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sphfem' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
