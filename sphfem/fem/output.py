"""VTU time series of FEM substrate results (+ ParaView .pvd), written atomically."""

from __future__ import annotations

import numpy as np

from sphfem.output import VTUSeries


class FEMSeries(VTUSeries):
    """One VTU per call of :meth:`write` plus ``<name>.pvd`` listing them by time.

    Point data (at mesh vertices): ``displacement`` (3 components, zero-padded in 2D),
    ``stress`` (9 components, row-major 3x3, L2-projected), ``von_mises``, ``dT``.
    Cell data: ``stress_elem`` (element average, 9 components) and ``von_mises_elem``.
    Each file goes to a temporary name and is renamed; the .pvd is rewritten atomically.
    """

    def __init__(self, folder, name: str = "substrate"):
        super().__init__(folder, name)
        self.folder.mkdir(parents=True, exist_ok=True)

    def write(self, t: float, result):
        from skfem.io.meshio import to_meshio

        mesh = result.substrate.mesh
        nv = mesh.nvertices
        u = np.zeros((nv, 3))
        u[:, : result.u.shape[1]] = result.u
        point_data = {
            "displacement": u,
            "stress": result.stress_nodes.reshape(nv, 9),
            "von_mises": result.von_mises_nodes,
            "dT": result.dT_nodes,
        }
        m = to_meshio(mesh, point_data=point_data, encode_cell_data=False)
        if m.points.shape[1] == 2:
            m.points = np.column_stack([m.points, np.zeros(len(m.points))])
        m.cell_data = {"stress_elem": [result.stress_elem.reshape(-1, 9)],
                       "von_mises_elem": [result.von_mises_elem]}
        return self.write_mesh(t, m)
