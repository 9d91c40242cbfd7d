"""sphfem: coupled SPH-FEM multiphysics for droplet deposition on substrates.

The building blocks (kernels, neighbour search, SPH operators, particles) live in the
top-level modules; physics families live in sub-packages (``heat``, ``fluid``, ``solid``,
``fem``) and are only imported when a scene asks for them.
"""

__version__ = "0.1.0"

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
