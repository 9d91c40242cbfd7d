"""Cost of the axisymmetric FEM substrate at droplet-impact scale (issue 16).

The thesis substrate (radius 1 mm, depth 0.26 mm, alumina) meshed in (r, z) with gmsh
triangles graded from ``h_fine`` under the impact point to 50 um, P1 and P2; loaded by a
smooth pressure patch (25 MPa, radius 20 um: the water-hammer scale) and a thermal layer
(dT = 16 K exp(-(z / 5 um)^2) for r < 60 um).  Prints vertices, dofs and the seconds of
meshing, assembly, factorisation, one solve and the stress recovery (nodal projection),
plus the peak von Mises and its place.

    python benchmarks/fem_axisymmetric.py [h_fine_um ...]      # default 2 1 0.5 0.25
"""

from __future__ import annotations

import resource
import sys
import time

import numpy as np

from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, substrate_rz
from sphfem.fem.substrate import load_mesh

E, NU, ALPHA = 370e9, 0.22, 7e-6  # alumina
R, DEPTH, P0, A = 1e-3, 0.26e-3, 25e6, 20e-6


def run(h_fine: float, element: str) -> dict:
    t0 = time.perf_counter()
    path = substrate_rz(radius=R, depth=DEPTH, h_fine=h_fine, h_coarse=50e-6,
                        refine_radius=40e-6)
    mesh = load_mesh(path)
    t1 = time.perf_counter()
    sub = AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element=element, clamps=["bottom"])
    t2 = time.perf_counter()

    def press(x):
        return np.array([0 * x[0], -P0 * np.clip(1 - (x[0] / A) ** 2, 0, None) ** 2])

    def dT(x):
        return 16.0 * np.exp(-(x[1] / 5e-6) ** 2) * (x[0] < 60e-6)

    res = sub.solve(tractions={"top": press}, dT_nodal=dT)
    t3 = time.perf_counter()
    vm, where = res.peak_von_mises()
    t4 = time.perf_counter()
    return {"h_fine_um": h_fine * 1e6, "element": element, "vertices": mesh.nvertices,
            "dofs": sub.n_dofs, "mesh_s": t1 - t0, "assemble_s": sub.timings["assemble_K"],
            "factorize_s": sub.timings["factorize"], "solve_s": t3 - t2,
            "stress_s": t4 - t3, "peak_vm_MPa": vm / 1e6,
            "at_um": (where * 1e6).round(2).tolist(),
            "u_z_centre_nm": float(res.probe([[0.0, 0.0]])["u"][0, 1] * 1e9),
            "maxrss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


if __name__ == "__main__":
    hs = [float(a) * 1e-6 for a in sys.argv[1:]] or [2e-6, 1e-6, 0.5e-6, 0.25e-6]
    for element in ("P1", "P2"):
        for h in hs:
            r = run(h, element)
            print("  ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in r.items()), flush=True)
