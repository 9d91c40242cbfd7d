"""Substrate block mesh (gmsh): thin wrapper around :func:`sphfem.fem.meshing.substrate_block`.

    python meshes/substrate_block.py --out substrate.msh --size 2e-3 2e-3 0.26e-3 \
        --h-fine 20e-6 --h-coarse 150e-6 --refine-radius 0.25e-3 [--element hex] [--order 2]

Equivalent to ``sphfem mesh block ...``.  Importable: ``from meshes.substrate_block import
substrate_block`` (with the repository root on ``sys.path``).
"""

import sys

from sphfem.fem.meshing import mesh_command, substrate_block

__all__ = ["substrate_block"]

if __name__ == "__main__":
    sys.exit(mesh_command(["block", *sys.argv[1:]]))
