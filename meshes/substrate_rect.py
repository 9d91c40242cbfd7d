"""2D (plane-strain) substrate rectangle: wrapper around :func:`sphfem.fem.meshing.substrate_rect`.

    python meshes/substrate_rect.py --out strip.msh --size 2e-3 0.26e-3 --element quad

Equivalent to ``sphfem mesh rect ...``.
"""

import sys

from sphfem.fem.meshing import mesh_command, substrate_rect

__all__ = ["substrate_rect"]

if __name__ == "__main__":
    sys.exit(mesh_command(["rect", *sys.argv[1:]]))
