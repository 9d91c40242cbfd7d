"""FEM substrate speed, one figure per process (so an outside timer can repeat it).

    python benchmarks/fem_speed.py assemble  --cells tet --degree 1 --dofs 1e5 [--old]
    python benchmarks/fem_speed.py factorize --cells tet --dofs 1e5 --backend splu

Prints one JSON line.  ``assemble``: the stiffness K of the alumina substrate (E = 300 GPa,
nu = 0.21) on a mesh of ~``dofs`` unknowns, timed in-process (wall and CPU seconds of
:func:`sphfem.fem.assembly.elasticity_stiffness` with the quadrature the substrate uses, the
first call in the process, i.e. with numba's cached kernels loaded); ``--old`` also times
scikit-fem's assembly of the same form on the rule the substrate used before (scikit-fem's
default on quadrilaterals/hexahedra: 4^3 points per Q1 hexahedron) and checks the two
matrices agree.  ``factorize``: K_II of the clamped substrate (the droplet-impact block,
bottom clamped) factorised by ``--backend`` (:mod:`sphfem.fem.direct`), with its ordering,
nonzeros and one back-substitution.

Meshes (gmsh recipes of :mod:`sphfem.fem.meshing`, cached): tet / hex: the 2 x 2 x 0.26 mm
block refined at the top centre; tri / quad: the 2 x 0.26 mm plane-strain section.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

import numpy as np

#: (cells, dofs) -> (h_fine, h_coarse) of the recipe, ~dofs unknowns (P1)
MESHES = {
    ("tet", "1e4"): (20e-6, 150e-6), ("tet", "3e4"): (14e-6, 90e-6),
    ("tet", "1e5"): (10e-6, 50e-6),
    ("hex", "1e4"): (40e-6, 200e-6), ("hex", "1e5"): (20e-6, 80e-6),
    ("tri", "1e4"): (4e-6, 20e-6), ("tri", "1e5"): (1.7e-6, 8.5e-6),
    ("quad", "1e4"): (5e-6, 20e-6), ("quad", "1e5"): (2.1e-6, 8.5e-6),
}
E, NU = 300e9, 0.21


def _mesh(cells: str, dofs: str):
    from sphfem.fem.meshing import substrate_block, substrate_rect
    from sphfem.fem.substrate import load_mesh

    hf, hc = MESHES[cells, dofs]
    if cells in ("tet", "hex"):
        return load_mesh(substrate_block(h_fine=hf, h_coarse=hc, element=cells))
    return load_mesh(substrate_rect(h_fine=hf, h_coarse=hc, element=cells))


def assemble(cells: str, degree: int, dofs: str, old: bool) -> dict:
    from skfem import Basis, ElementVector

    from sphfem.fem import forms
    from sphfem.fem.assembly import elasticity_stiffness, stiffness_intorder
    from sphfem.fem.substrate import _ELEMENTS, FEMSubstrate

    mesh = _mesh(cells, dofs)
    elem = _ELEMENTS[(type(mesh), f"P{degree}")]()
    lam, mu = forms.lame_parameters(E, NU)
    basis = Basis(mesh, ElementVector(elem), intorder=FEMSubstrate._basis_intorder(
        mesh, f"P{degree}", None))
    t, c = time.perf_counter(), time.process_time()
    K = elasticity_stiffness(basis, lam, mu, stiffness_intorder(mesh, degree))
    t, c = time.perf_counter() - t, time.process_time() - c
    t2 = time.perf_counter()  # again: without loading the compiled kernels
    elasticity_stiffness(basis, lam, mu, stiffness_intorder(mesh, degree))
    t2 = time.perf_counter() - t2
    out = {"cells": cells, "degree": degree, "unknowns": int(basis.N),
           "elements": int(mesh.t.shape[1]), "nnz": int(K.nnz),
           "quadrature_points": int(basis.X.shape[1]), "assemble_s": t, "assemble_cpu_s": c,
           "unknowns_per_s": basis.N / t, "assemble_again_s": t2}
    if old:
        b_old = Basis(mesh, ElementVector(elem),
                      intorder=2 * (degree - 1) if cells in ("tet", "tri") else None)
        t = time.perf_counter()
        K0 = forms.elasticity(lam, mu).assemble(b_old).tocsr()
        out.update(old_quadrature_points=int(b_old.X.shape[1]),
                   old_assemble_s=time.perf_counter() - t,
                   max_rel_diff=float(abs(K - K0).max() / abs(K0).max()))
    return out


def factorize(cells: str, dofs: str, backend: str) -> dict:
    from sphfem.fem.direct import factorize as fac
    from sphfem.fem.substrate import FEMSubstrate

    mesh = _mesh(cells, dofs)

    class Unfactorised(FEMSubstrate):
        def _factorize(self):
            self.backend = None

    sub = Unfactorised(mesh, E, NU, 7e-6, clamps=["bottom"])
    A = sub.K[sub.I][:, sub.I].tocsr()
    coo = A.tocoo()
    t = time.perf_counter()
    f = fac(A, backend, groups=sub.I // sub.dim)
    total = time.perf_counter() - t
    b = np.random.default_rng(0).normal(size=A.shape[0])
    t = time.perf_counter()
    x = f.solve(b)
    solve_s = time.perf_counter() - t
    return {"cells": cells, "unknowns": A.shape[0], "nnz": A.nnz,
            "bandwidth": int(np.abs(coo.row - coo.col).max()), "backend": f.backend,
            "ordering": f.ordering, "nnz_factor": f.nnz_factor, "factorize_s": total,
            "phases_s": f.seconds, "solve_s": solve_s,
            "relative_residual": float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python benchmarks/fem_speed.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=("assemble", "factorize"))
    p.add_argument("--cells", choices=("tet", "hex", "tri", "quad"), default="tet")
    p.add_argument("--degree", type=int, choices=(1, 2), default=1)
    p.add_argument("--dofs", choices=("1e4", "3e4", "1e5"), default="1e5",
                   help="3e4: tet only")
    p.add_argument("--backend", default="auto")
    p.add_argument("--old", action="store_true")
    a = p.parse_args(argv)
    if a.what == "assemble":
        out = assemble(a.cells, a.degree, a.dofs, a.old)
    else:
        out = factorize(a.cells, a.dofs, a.backend)
    out["peak_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(out, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
