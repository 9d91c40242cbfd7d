"""FEM substrate: scikit-fem quasi-static linear thermo-elasticity on gmsh meshes.

``K`` is assembled and factorised once per run; each coupling step re-assembles only the
load (thermal strain, tractions, sensor point forces, body force) and back-substitutes.
"""

from sphfem.fem.meshing import mesh_command, substrate_block, substrate_rect

__all__ = ["mesh_command", "substrate_block", "substrate_rect"]
