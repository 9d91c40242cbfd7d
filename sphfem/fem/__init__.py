"""FEM substrate: scikit-fem quasi-static linear thermo-elasticity on gmsh meshes.

``K`` is assembled and factorised once per run; each coupling step re-assembles only the
load (thermal strain, tractions, sensor point forces, body force) and back-substitutes.
"""

from sphfem.fem.meshing import mesh_command, substrate_block, substrate_rect
from sphfem.fem.output import FEMSeries
from sphfem.fem.substrate import FEMResult, FEMSubstrate, load_mesh

__all__ = ["FEMResult", "FEMSeries", "FEMSubstrate", "load_mesh", "mesh_command",
           "substrate_block", "substrate_rect"]
