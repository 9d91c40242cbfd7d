"""Direct backends of the FEM substrate (sphfem.fem.direct): each solves K_II u = f to
round-off, the node ordering keeps a node's unknowns together, and the substrate's solution
does not depend on the backend."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from skfem import MeshTet1

from sphfem.fem import FEMSubstrate
from sphfem.fem.direct import available_backends, factorize, node_nested_dissection


def _substrate(**kw):
    mesh = MeshTet1.init_tensor(*[np.linspace(0, 1e-3, 7)] * 3).with_defaults()
    return FEMSubstrate(mesh, 300e9, 0.21, 7e-6, clamps=["bottom"], **kw)


@pytest.mark.parametrize("backend", ["splu", "pardiso", "cholespy"])
def test_backend_solves_to_round_off(backend):
    if backend not in available_backends():
        pytest.skip(f"{backend} not installed")
    sub = _substrate()
    A = sub.K[sub.I][:, sub.I]
    b = np.random.default_rng(1).normal(size=A.shape[0])
    fac = factorize(A, backend, groups=sub.I // sub.dim)
    x = fac.solve(b)
    # backward error of a stable Cholesky/LU: a small multiple of the unit round-off
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)
    assert fac.backend == backend and fac.n == A.shape[0]


def test_node_ordering_is_a_permutation_keeping_nodes_together():
    pytest.importorskip("pymetis")
    sub = _substrate()
    A = sub.K[sub.I][:, sub.I]
    groups = sub.I // sub.dim
    perm = node_nested_dissection(A, groups)
    assert np.array_equal(np.sort(perm), np.arange(A.shape[0]))
    g = groups[perm]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    assert len(starts) == len(np.unique(groups))  # each node one contiguous run


def test_substrate_solution_independent_of_backend():
    backends = available_backends()
    subs = [_substrate(direct_backend=b) for b in backends]
    p = subs[0].mesh.p
    dT = 80.0 * np.exp(-((p[0] - 5e-4) ** 2 + (p[1] - 5e-4) ** 2) / 1e-7)
    u = [s.solve(dT_nodal=dT, tractions={"top": [0.0, 0.0, -1e6]}).dofs for s in subs]
    for s, ui in zip(subs, u, strict=True):
        assert s.backend == s.factor.backend
        assert np.abs(ui - u[0]).max() <= 1e-10 * np.abs(u[0]).max()
    # and against scipy's general sparse LU
    s = subs[0]
    f = s.load_vector(dT_nodal=dT, tractions={"top": [0.0, 0.0, -1e6]})[0]
    ref = sp.linalg.spsolve(s.K[s.I][:, s.I].tocsc(), f[s.I])
    assert np.abs(u[0][s.I] - ref).max() <= 1e-10 * np.abs(ref).max()


def test_splu_without_pymetis_falls_back_to_mmd(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_pymetis(name, *args, **kw):
        if name == "pymetis":
            raise ImportError("no pymetis")
        return real_import(name, *args, **kw)

    monkeypatch.setattr(builtins, "__import__", no_pymetis)
    sub = _substrate()
    A = sub.K[sub.I][:, sub.I]
    assert node_nested_dissection(A, sub.I // sub.dim) is None
    fac = factorize(A, "splu", groups=sub.I // sub.dim)
    assert fac.ordering == "mmd (superlu)"
    b = np.ones(A.shape[0])
    assert np.linalg.norm(A @ fac.solve(b) - b) <= 1e-12 * np.linalg.norm(b)
