"""Sparse direct solution of the condensed stiffness K_II u = f: factorise once, re-solve.

K_II is symmetric positive definite.  In 3D its Cholesky factor is dense-ish whatever the
ordering (nested dissection gives O(n^2) flops for n unknowns: about 1.7e11 for the
1e5-unknown P1 substrate), so the time goes into dense kernels on the separators and a
supernodal/multifrontal factorisation with BLAS-3 is what makes it fast (Davis, Rajamanickam
& Sid-Lakhdar, "A survey of direct methods for sparse linear systems", Acta Numerica 25,
2016).  Backends, ``direct_backend``:

* ``"pardiso"`` -- Intel MKL PARDISO (supernodal, threaded, METIS ordering) through pypardiso
  (optional: ``pip install pypardiso``, which brings MKL).  The upper triangle is passed
  (matrix type 2, real SPD).
* ``"splu"`` -- SciPy's SuperLU in symmetric mode (no pivoting) on K_II permuted by a
  nested-dissection ordering of the *node* graph (METIS through pymetis; each node's
  components kept together), else SuperLU's own MMD ordering of A^T + A.
* ``"cholespy"`` -- CHOLMOD through cholespy.  cholespy builds CHOLMOD in its simplicial
  mode (no supernodes, no BLAS): the ordering (nested dissection) is good but the numeric
  factorisation runs at scalar speed, minutes at 1e5 unknowns.  Kept for comparison.
* ``"auto"`` -- pardiso when importable, else splu.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

logger = logging.getLogger(__name__)

__all__ = ["DirectFactor", "factorize", "node_nested_dissection", "available_backends"]

BACKENDS = ("auto", "pardiso", "splu", "cholespy")


def _importable(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


def available_backends() -> list[str]:
    """The direct backends importable here, fastest first."""
    out = ["pardiso"] if _importable("pypardiso") else []
    out.append("splu")
    if _importable("cholespy"):
        out.append("cholespy")
    return out


@dataclass
class DirectFactor:
    """A factorised SPD matrix: ``solve(b)`` back-substitutes."""

    solve: object  #: callable b -> x
    backend: str
    ordering: str
    n: int
    nnz: int  #: nonzeros of the matrix
    seconds: dict = field(default_factory=dict)  #: "ordering", "factorize"
    nnz_factor: int | None = None  #: nonzeros of the factor(s) where the backend says


def node_nested_dissection(A: sp.spmatrix, groups: np.ndarray) -> np.ndarray | None:
    """A fill-reducing permutation of the unknowns of A: METIS nested dissection (pymetis) of
    the graph of ``groups`` (the mesh node of each unknown), the unknowns of a node kept
    together in their original order.  ``perm[k]`` is the unknown placed k-th; None without
    pymetis."""
    try:
        import pymetis
    except ImportError:
        return None
    groups = np.asarray(groups)
    uniq, gid = np.unique(groups, return_inverse=True)
    n = A.shape[0]
    P = sp.csr_matrix((np.ones(n), (np.arange(n), gid)), shape=(n, len(uniq)))
    G = (P.T @ (abs(A) @ P)).tocsr()
    G.setdiag(0)
    G.eliminate_zeros()
    G.sort_indices()
    adjacency = pymetis.CSRAdjacency(G.indptr.astype(np.int64), G.indices.astype(np.int64)) \
        if hasattr(pymetis, "CSRAdjacency") else None
    if adjacency is not None:
        order, _ = pymetis.nested_dissection(adjacency)
    else:  # pragma: no cover - older pymetis
        order, _ = pymetis.nested_dissection(xadj=G.indptr, adjncy=G.indices)
    rank = np.empty(len(uniq), np.int64)
    rank[np.asarray(order)] = np.arange(len(uniq))
    return np.lexsort((np.arange(n), rank[gid]))


def factorize(A: sp.spmatrix, backend: str = "auto", groups=None) -> DirectFactor:
    """Factorise the SPD matrix A once.  ``groups``: the mesh node of each unknown (the
    splu backend orders the node graph); None: each unknown its own node."""
    if backend not in BACKENDS:
        raise ValueError(f"direct_backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "auto":
        backend = available_backends()[0]
    A = sp.csr_matrix(A)
    n = A.shape[0]
    t0 = time.perf_counter()
    if backend == "pardiso":
        out = _pardiso(A)
    elif backend == "splu":
        out = _splu(A, groups)
    else:
        out = _cholespy(A)
    out.seconds["total"] = time.perf_counter() - t0
    logger.info("factorised %d unknowns (%d nonzeros) with %s (%s ordering) in %.2f s", n,
                A.nnz, out.backend, out.ordering, out.seconds["total"])
    return out


def _pardiso(A: sp.csr_matrix) -> DirectFactor:
    try:
        import pypardiso
    except ImportError as e:
        raise ImportError("direct_backend='pardiso' needs pypardiso (pip install pypardiso)"
                          ) from e
    U = sp.triu(A, format="csr")
    U.sort_indices()
    solver = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
    t = time.perf_counter()
    solver.factorize(U)
    tf = time.perf_counter() - t

    def solve(b):
        return solver.solve(U, np.asarray(b, dtype=np.float64))

    return DirectFactor(solve, "pardiso", "metis (pardiso)", A.shape[0], A.nnz,
                        {"factorize": tf})


def _splu(A: sp.csr_matrix, groups) -> DirectFactor:
    from scipy.sparse.linalg import splu

    n = A.shape[0]
    t = time.perf_counter()
    perm = node_nested_dissection(A, np.arange(n) if groups is None else groups)
    to = time.perf_counter() - t
    # K_II is SPD: a symmetric ordering without pivoting (SuperLU's symmetric mode)
    opts = dict(diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    t = time.perf_counter()
    if perm is None:
        lu = splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", **opts)
        ordering = "mmd (superlu)"
        solve = lu.solve
    else:
        lu = splu(A[perm][:, perm].tocsc(), permc_spec="NATURAL", **opts)
        ordering = "metis nested dissection (nodes)"

        def solve(b):
            b = np.asarray(b, dtype=np.float64)
            x = np.empty_like(b)
            x[perm] = lu.solve(b[perm])
            return x

    tf = time.perf_counter() - t
    return DirectFactor(solve, "splu", ordering, n, A.nnz, {"ordering": to, "factorize": tf},
                        nnz_factor=int(lu.L.nnz + lu.U.nnz))


def _cholespy(A: sp.csr_matrix) -> DirectFactor:
    import cholespy

    t = time.perf_counter()
    chol = cholespy.CholeskySolverD(
        A.shape[0], A.indptr.astype(np.int32), A.indices.astype(np.int32),
        np.ascontiguousarray(A.data, dtype=np.float64), cholespy.MatrixType.CSR)
    tf = time.perf_counter() - t

    def solve(b):
        x = np.zeros(A.shape[0])
        chol.solve(np.ascontiguousarray(b, dtype=np.float64), x)
        return x

    return DirectFactor(solve, "cholespy", "nesdis (cholmod, simplicial)", A.shape[0], A.nnz,
                        {"factorize": tf})
