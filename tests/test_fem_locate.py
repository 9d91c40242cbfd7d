"""Point location of the FEM substrate: each point mapped into its own nearest candidates
gives scikit-fem's element finder's interpolation, also for points on shared faces/edges."""

import numpy as np
from skfem import MeshTet1

from sphfem.fem.substrate import FEMSubstrate


def test_probe_matrix_equals_scikit_fem_probes_on_face_grid():
    mesh = MeshTet1.init_tensor(*(np.linspace(0.0, 1e-3, 7),) * 3).with_defaults()
    sub = FEMSubstrate(mesh, 300e9, 0.21, 7e-6, clamps=["bottom"])
    # a grid on the top face and on interior element faces (x = const planes of the mesh)
    g = np.linspace(0.0, 1e-3, 25)
    X, Y = np.meshgrid(g, g)
    top = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 1e-3 * (1 - 1e-12))])
    face = np.column_stack([np.full(X.size, 1e-3 / 6), X.ravel(), Y.ravel()])
    P = np.vstack([top, face])
    u = np.random.default_rng(0).normal(size=sub.basis.N)
    ours = sub.probe_matrix(P) @ u
    ref = sub.basis.probes(P.T) @ u  # (dim * n,) ordered as ours: components, then points
    assert ref.shape == ours.shape
    assert np.abs(ours - ref).max() < 1e-12 * np.abs(u).max()
