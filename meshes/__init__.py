"""gmsh recipes for substrates (thin scripts; the code lives in :mod:`sphfem.fem.meshing`)."""

from sphfem.fem.meshing import substrate_block, substrate_rect

__all__ = ["substrate_block", "substrate_rect"]
