"""Element-type-aware assembly of the linear-elastic stiffness matrix, any Lagrange element.

The stiffness of :func:`sphfem.fem.forms.elasticity`, written per pair of scalar basis
functions (a, b) and displacement components (c, d) (Zienkiewicz & Taylor, *The Finite
Element Method*, vol. 1: the element matrix K_ab = int B_a^T D B_b dx)::

    K[(a, c), (b, d)] = sum_q w_q [ lam g_a[c] g_b[d] + mu g_a[d] g_b[c] + mu delta_cd g_a . g_b ]

with g_a the physical gradient of scalar basis function a at quadrature point q and w_q the
quadrature weight times |det J|.  scikit-fem evaluates the form through its vector basis
(dim * nloc functions, each a (dim, dim) gradient field, the form called once per pair of
functions: (dim nloc)^2 numpy calls); here the scalar gradients (nloc, dim) come from a
scalar scikit-fem basis and one numba loop forms the (dim x dim) blocks and adds them into a
block-sparse matrix whose pattern is the scalar dof graph.  scikit-fem numbers the dofs of
``ElementVector(e)`` as ``dim * (scalar dof) + component``; :func:`elasticity_stiffness`
checks that and returns None when a basis is numbered otherwise (the caller then uses the
scikit-fem form).

Quadrature (:func:`stiffness_intorder`): on affine cells, g_a . g_b is a polynomial, so the
smallest rule that integrates it exactly gives the same matrix as any finer rule, to
round-off.  Simplices P_p: total degree 2(p - 1).  Parallelepiped quadrilaterals and
hexahedra Q_p: degree 2p in each reference direction, Gauss-Legendre with p + 1 points per
direction (scikit-fem's ``intorder=2p``) instead of its default ``2 * maxdeg`` (4^3 = 64
points for Q1 hexahedra, 7^3 = 343 for Q2).  Cells that are not affine keep the given rule.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from skfem import Basis, ElementVector, MeshTet1, MeshTri1
from skfem.quadrature import get_quadrature

__all__ = ["elasticity_stiffness", "stiffness_intorder", "affine_jacobians", "block_pattern"]

#: relative spread of the Jacobian over a cell's corners below which the cell is affine
AFFINE_RTOL = 1e-10


def _reference_gradients(elem, X: np.ndarray) -> np.ndarray:
    """Gradients (nloc, dim, npts) of the basis functions of ``elem`` on its reference cell
    at the points X (dim, npts)."""
    return np.stack([np.asarray(elem.lbasis(X, a)[1]) for a in range(elem.doflocs.shape[0])])


def affine_jacobians(mesh) -> np.ndarray | None:
    """The constant Jacobian dx/dxi (dim, dim, nelems) of every cell, or None when some cell
    is not affine.

    Simplices always are.  A bilinear (trilinear) quadrilateral (hexahedron) map has a
    Jacobian whose entries are linear (bilinear) in the other reference coordinates, so it
    is constant iff it takes one value at the 2^dim corners of the reference cell.
    """
    if isinstance(mesh, (MeshTet1, MeshTri1)):  # columns: edges from vertex 0
        return mesh.p[:, mesh.t[1:]] - mesh.p[:, mesh.t[:1]]
    gel = mesh.elem()  # the geometry element: Q1 on mesh.t
    dN = _reference_gradients(gel, gel.doflocs.T)  # (nverts, dim, ncorners)
    J = np.einsum("dke,kjq->djeq", mesh.p[:, mesh.t], dN, optimize=True)
    spread = np.abs(J - J[..., :1]).max(axis=(0, 1, 3))
    size = np.abs(J[..., 0]).max(axis=(0, 1))
    if np.all(spread <= AFFINE_RTOL * size):
        return np.ascontiguousarray(J[..., 0])
    return None


def stiffness_intorder(mesh, degree: int) -> int | None:
    """The quadrature order that integrates grad phi_a . grad phi_b exactly on affine cells of
    polynomial ``degree`` p (see the module text), or None (scikit-fem's default rule) when
    some cell is not affine."""
    if isinstance(mesh, (MeshTet1, MeshTri1)):
        return 2 * (degree - 1)
    return 2 * degree if affine_jacobians(mesh) is not None else None


@njit(cache=True)
def _pattern(E, n):
    """Scalar dof graph of the elements E (nelems, nloc) over n dofs: CSR (indptr, indices)
    with sorted rows, and pos (nelems, nloc, nloc), the index in ``indices`` of the pair
    (E[e, a], E[e, b])."""
    nel, nloc = E.shape
    start = np.zeros(n + 1, np.int64)  # dof -> elements
    for e in range(nel):
        for a in range(nloc):
            start[E[e, a] + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    fill = start[:-1].copy()
    elems = np.empty(start[n], np.int64)
    for e in range(nel):
        for a in range(nloc):
            i = E[e, a]
            elems[fill[i]] = e
            fill[i] += 1
    mark = np.full(n, -1, np.int64)
    indptr = np.zeros(n + 1, np.int64)
    for i in range(n):
        cnt = 0
        for k in range(start[i], start[i + 1]):
            e = elems[k]
            for b in range(nloc):
                j = E[e, b]
                if mark[j] != i:
                    mark[j] = i
                    cnt += 1
        indptr[i + 1] = indptr[i] + cnt
    indices = np.empty(indptr[n], np.int64)
    pos = np.empty((nel, nloc, nloc), np.int64)
    loc = np.empty(n, np.int64)  # column j -> its index in the current row's indices
    mark[:] = -1
    for i in range(n):
        p = indptr[i]
        for k in range(start[i], start[i + 1]):
            e = elems[k]
            for b in range(nloc):
                j = E[e, b]
                if mark[j] != i:
                    mark[j] = i
                    indices[p] = j
                    p += 1
        for k in range(indptr[i] + 1, indptr[i + 1]):  # insertion sort of the short row
            j = indices[k]
            m = k - 1
            while m >= indptr[i] and indices[m] > j:
                indices[m + 1] = indices[m]
                m -= 1
            indices[m + 1] = j
        for k in range(indptr[i], indptr[i + 1]):
            loc[indices[k]] = k
        for k in range(start[i], start[i + 1]):  # the row's pairs of each element at i
            e = elems[k]
            for a in range(nloc):
                if E[e, a] == i:
                    for b in range(nloc):
                        pos[e, a, b] = loc[E[e, b]]
    return indptr, indices, pos


def block_pattern(element_dofs: np.ndarray, n: int):
    """CSR pattern (indptr, indices) of the scalar dof graph of ``element_dofs`` (nloc,
    nelems) over n dofs, and ``pos`` (nelems, nloc, nloc): the position in ``indices`` of
    the pair (element_dofs[a, e], element_dofs[b, e])."""
    E = np.ascontiguousarray(np.asarray(element_dofs, dtype=np.int64).T)
    return _pattern(E, int(n))


@njit(cache=True)
def _vector_pattern(indptr, indices, dim):
    """CSR pattern of the vector dofs dim * i + c from the scalar pattern: row (i, c) holds
    the columns dim * j + d of every j of scalar row i, so block entry (p, c, d) of scalar
    row i sits at dim^2 indptr[i] + c dim len_i + dim (p - indptr[i]) + d."""
    n = len(indptr) - 1
    vptr = np.zeros(dim * n + 1, np.int64)
    vind = np.empty(dim * dim * indptr[n], np.int32)
    for i in range(n):
        L = indptr[i + 1] - indptr[i]
        for c in range(dim):
            r = dim * i + c
            vptr[r + 1] = vptr[r] + dim * L
            q = vptr[r]
            for p in range(indptr[i], indptr[i + 1]):
                for d in range(dim):
                    vind[q] = dim * indices[p] + d
                    q += 1
    return vptr, vind


@njit(cache=True)
def _add_pair(S, lam, mu, out, indptr, pos, E, e, a, b, dim):
    """Add the block K[(a, c), (b, d)] = lam S[c, d] + mu S[d, c] + mu delta_cd tr S of
    element e, with S[c, d] = int g_a[c] g_b[d] dx, and for b != a its transpose at (b, a).

    In the vector CSR (:func:`_vector_pattern`) block entry (c, d) of scalar row i at the
    scalar position p sits at dim^2 indptr[i] + c dim len_i + dim (p - indptr[i]) + d."""
    tr = 0.0
    for k in range(dim):
        tr += S[k, k]
    i, j = E[e, a], E[e, b]
    Li, Lj = indptr[i + 1] - indptr[i], indptr[j + 1] - indptr[j]
    pi = dim * dim * indptr[i] + dim * (pos[e, a, b] - indptr[i])
    pj = dim * dim * indptr[j] + dim * (pos[e, b, a] - indptr[j])
    for c in range(dim):
        for d in range(dim):
            v = lam * S[c, d] + mu * S[d, c]
            if c == d:
                v += mu * tr
            out[pi + c * dim * Li + d] += v
            if b != a:
                out[pj + d * dim * Lj + c] += v


@njit(cache=True)
def _elastic_general(G, dx, E, n, lam, mu):
    """Vector CSR (indptr, indices, data) of the stiffness from the scalar gradients G
    (nelems, nqp, nloc, dim) and weights dx (nelems, nqp) at the quadrature points."""
    nel, nqp, nloc, dim = G.shape
    indptr, indices, pos = _pattern(E, n)
    vptr, vind = _vector_pattern(indptr, indices, dim)
    out = np.zeros(len(vind))
    S = np.zeros((dim, dim))
    for e in range(nel):
        for a in range(nloc):
            for b in range(a, nloc):
                S[:, :] = 0.0
                for q in range(nqp):
                    for c in range(dim):
                        wac = dx[e, q] * G[e, q, a, c]
                        for d in range(dim):
                            S[c, d] += wac * G[e, q, b, d]
                _add_pair(S, lam, mu, out, indptr, pos, E, e, a, b, dim)
    return vptr, vind, out


@njit(cache=True)
def _elastic_affine(invJ, detJ, R, E, n, lam, mu):
    """Vector CSR (indptr, indices, data) of the stiffness on affine cells: with the
    reference integrals R[a, b, k, l] = int_ref dphi_a/dxi_k dphi_b/dxi_l, a cell with
    Jacobian J has S_ab = |det J| J^-T R_ab J^-1 (invJ[e, k, c] = d xi_k / d x_c)."""
    nel, nloc = E.shape
    dim = invJ.shape[1]
    indptr, indices, pos = _pattern(E, n)
    vptr, vind = _vector_pattern(indptr, indices, dim)
    out = np.zeros(len(vind))
    T = np.zeros((dim, dim))
    S = np.zeros((dim, dim))
    for e in range(nel):
        w = abs(detJ[e])
        for a in range(nloc):
            for b in range(a, nloc):
                for k in range(dim):  # T = R_ab invJ
                    for d in range(dim):
                        t = 0.0
                        for m in range(dim):
                            t += R[a, b, k, m] * invJ[e, m, d]
                        T[k, d] = t
                for c in range(dim):  # S = |det J| invJ^T T
                    for d in range(dim):
                        t = 0.0
                        for k in range(dim):
                            t += invJ[e, k, c] * T[k, d]
                        S[c, d] = w * t
                _add_pair(S, lam, mu, out, indptr, pos, E, e, a, b, dim)
    return vptr, vind, out


def _inv_det(J: np.ndarray):
    """Inverses (nelems, dim, dim) and determinants (nelems,) of the 2 x 2 or 3 x 3
    matrices J (dim, dim, nelems), by cofactors."""
    if J.shape[0] == 2:
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        inv = np.array([[J[1, 1], -J[0, 1]], [-J[1, 0], J[0, 0]]]) / det
    else:
        cof = np.empty_like(J)
        for r in range(3):
            for c in range(3):
                r1, r2, c1, c2 = (r + 1) % 3, (r + 2) % 3, (c + 1) % 3, (c + 2) % 3
                cof[r, c] = J[r1, c1] * J[r2, c2] - J[r1, c2] * J[r2, c1]
        det = (J[0] * cof[0]).sum(axis=0)
        inv = np.swapaxes(cof, 0, 1) / det
    return np.ascontiguousarray(np.moveaxis(inv, -1, 0)), det


def elasticity_stiffness(vbasis: Basis, lam: float, mu: float,
                         intorder: int | None = None) -> sp.csr_matrix | None:
    """Stiffness matrix of ``forms.elasticity(lam, mu)`` on the dofs of the vector basis
    ``vbasis`` (``ElementVector`` of a scalar Lagrange element), CSR with sorted indices.

    ``intorder``: quadrature order (None: scikit-fem's default for the element).  Returns
    None when ``vbasis`` is not an ``ElementVector`` basis numbered dim * scalar + component.
    """
    elem = vbasis.elem
    if not isinstance(elem, ElementVector):
        return None
    dim = vbasis.mesh.p.shape[0]
    Ev = vbasis.element_dofs
    nloc = Ev.shape[0] // dim
    if Ev.shape[0] != dim * nloc or vbasis.N % dim:
        return None
    Es = Ev[::dim] // dim
    Ev = Ev.reshape(nloc, dim, -1)
    if not np.array_equal(Ev, dim * Es[:, None, :] + np.arange(dim)[None, :, None]):
        return None
    # the cells in the order of their lowest dof: consecutive cells then add into nearby
    # rows of K (the element loop 1.5-1.7x, the whole assembly ~1.15x faster at 1e5
    # unknowns of a gmsh tet mesh, benchmarks/README.md; the sums differ in order only)
    order = np.argsort(Es.min(axis=0), kind="stable")
    E = np.ascontiguousarray(Es.T[order].astype(np.int64))
    n = vbasis.N // dim
    mesh, scalar = vbasis.mesh, elem.elem
    J = affine_jacobians(mesh) if intorder is not None else None
    if J is not None:
        X, W = get_quadrature(scalar.refdom, intorder)
        ghat = _reference_gradients(scalar, X)  # (nloc, dim, nqp)
        invJ, detJ = _inv_det(J[..., order])
        if len(W) < 2 * dim:  # few points: physical gradients, nqp dim^2 per pair
            G = np.einsum("ekc,akq->eqac", invJ, ghat, optimize=True)
            dx = np.abs(detJ)[:, None] * W[None, :]
            ptr, ind, data = _elastic_general(np.ascontiguousarray(G), dx, E, n,
                                              float(lam), float(mu))
        else:  # the reference integrals mapped cell by cell, 2 dim^3 per pair
            R = np.einsum("akq,blq,q->abkl", ghat, ghat, W)
            ptr, ind, data = _elastic_affine(invJ, detJ, np.ascontiguousarray(R), E, n,
                                             float(lam), float(mu))
    else:  # gradients at the quadrature points of a scalar scikit-fem basis
        sb = Basis(mesh, scalar, intorder=intorder)
        G = np.stack([sb.basis[a][0].grad for a in range(sb.Nbfun)])  # (nloc, dim, nel, nqp)
        ptr, ind, data = _elastic_general(
            np.ascontiguousarray(G.transpose(2, 3, 0, 1)[order]),
            np.ascontiguousarray(sb.dx[order]), E, n, float(lam), float(mu))
    K = sp.csr_matrix((data, ind, ptr), shape=(vbasis.N, vbasis.N))
    K.has_sorted_indices = True
    return K
