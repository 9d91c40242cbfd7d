"""The element-type-aware stiffness assembly (sphfem.fem.assembly) gives scikit-fem's matrix of
forms.elasticity to round-off for every element type, and the substrate's solution is the one
of scikit-fem's default quadrature."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve
from skfem import (
    Basis,
    ElementHex1,
    ElementHex2,
    ElementQuad1,
    ElementQuad2,
    ElementTetP1,
    ElementTetP2,
    ElementTriP1,
    ElementTriP2,
    ElementVector,
    MeshHex1,
    MeshQuad1,
    MeshTet1,
    MeshTri1,
    condense,
)

from sphfem.fem import FEMSubstrate, forms
from sphfem.fem.assembly import affine_jacobians, elasticity_stiffness, stiffness_intorder

LAM, MU = forms.lame_parameters(300e9, 0.21)
#: round-off bound of two summation orders of the same element integrals
RTOL = 1e-13


def _sheared(mesh):
    """The mesh under a fixed linear map (cells stay affine: parallelepipeds), mm sized."""
    dim = mesh.p.shape[0]
    A = np.eye(dim) + 0.3 * np.triu(np.ones((dim, dim)), 1)
    return type(mesh)(1e-3 * A @ mesh.p, mesh.t)


CASES = [
    (MeshTri1.init_tensor(np.linspace(0, 1, 7), np.linspace(0, 1, 5)), ElementTriP1, 1),
    (MeshTri1.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 4)), ElementTriP2, 2),
    (MeshQuad1.init_tensor(np.linspace(0, 1, 7), np.geomspace(1, 3, 5)), ElementQuad1, 1),
    (MeshQuad1.init_tensor(np.linspace(0, 1, 5), np.geomspace(1, 3, 4)), ElementQuad2, 2),
    (MeshTet1.init_tensor(*[np.linspace(0, 1, 4)] * 3), ElementTetP1, 1),
    (MeshTet1.init_tensor(*[np.linspace(0, 1, 3)] * 3), ElementTetP2, 2),
    (MeshHex1.init_tensor(np.linspace(0, 1, 4), np.geomspace(1, 2, 4), np.linspace(0, 1, 3)),
     ElementHex1, 1),
    (MeshHex1.init_tensor(*[np.linspace(0, 1, 3)] * 3), ElementHex2, 2),
]


@pytest.mark.parametrize("mesh, element, degree", CASES,
                         ids=[c[1].__name__ for c in CASES])
def test_stiffness_equals_scikit_fem_default_rule(mesh, element, degree):
    """On affine cells the minimal exact rule and scikit-fem's default rule give one matrix;
    the fast path computes it to round-off (graded and sheared cells)."""
    mesh = _sheared(mesh)
    b = Basis(mesh, ElementVector(element()))
    K0 = forms.elasticity(LAM, MU).assemble(b)
    io = stiffness_intorder(mesh, degree)
    assert io == (2 * (degree - 1) if isinstance(mesh, (MeshTri1, MeshTet1)) else 2 * degree)
    K = elasticity_stiffness(b, LAM, MU, io)
    assert K.has_sorted_indices and K.shape == K0.shape
    assert abs(K - K0).max() < RTOL * abs(K0).max()
    assert abs(K - K.T).max() < RTOL * abs(K0).max()


def test_non_affine_hexes_keep_the_given_rule():
    """A hexahedron with a moved vertex is not affine: no reduced rule, and the fast path on
    scikit-fem's default rule gives scikit-fem's matrix."""
    mesh = MeshHex1.init_tensor(*[np.linspace(0, 1, 3)] * 3)
    p = mesh.p.copy()
    centre = np.argmin(np.linalg.norm(p - 0.5, axis=0))
    p[:, centre] += [0.1, -0.05, 0.07]
    mesh = MeshHex1(p, mesh.t)
    assert affine_jacobians(mesh) is None and stiffness_intorder(mesh, 1) is None
    b = Basis(mesh, ElementVector(ElementHex1()))
    K0 = forms.elasticity(LAM, MU).assemble(b)
    K = elasticity_stiffness(b, LAM, MU, None)
    assert abs(K - K0).max() < RTOL * abs(K0).max()


def test_hex_substrate_solution_equals_the_default_rule_solution():
    """Clamped hex block under a vertex temperature field and a top traction: the substrate
    (8-point rule, fast K) against scikit-fem's default 64-point rule and its own K, load and
    solve.  Both rules integrate these polynomial integrands exactly: round-off apart
    (bounded by 1e-9 relative: condition number ~1e3 of K times 1e-13)."""
    mesh = MeshHex1.init_tensor(np.linspace(0, 2e-3, 6), np.geomspace(1e-3, 2e-3, 5),
                                np.linspace(-0.5e-3, 0, 4)).with_defaults()
    p = mesh.p
    dT = 50.0 * np.exp(-((p[0] - 1e-3) ** 2 + (p[1] - 1.5e-3) ** 2) / 0.5e-6) * (1 + 1e3 * p[2])
    sub = FEMSubstrate(mesh, 300e9, 0.21, 7e-6, clamps=["bottom"])
    assert sub.basis.X.shape[1] == 8
    traction = np.array([1e6, 0.0, -2e6])
    res = sub.solve(dT_nodal=dT, tractions={"top": traction})

    b = Basis(mesh, ElementVector(ElementHex1()))  # scikit-fem's default rule, 64 points
    assert b.X.shape[1] == 64
    K = forms.elasticity(LAM, MU).assemble(b)
    dTq = b.with_element(ElementHex1()).interpolate(dT)
    f = forms.thermal_load(LAM, MU, 7e-6).assemble(b, dT=dTq)
    from skfem import FacetBasis

    fb = FacetBasis(mesh, ElementVector(ElementHex1()), facets=mesh.boundaries["top"])
    f = f + forms.traction_load(traction).assemble(fb)
    D = b.get_dofs("bottom").flatten()
    A, rhs, x, I = condense(sp.csr_matrix(K), f, D=D)
    u = np.zeros(b.N)
    u[I] = spsolve(A.tocsc(), rhs)
    assert np.abs(u).max() > 0
    assert np.abs(res.dofs - u).max() < 1e-9 * np.abs(u).max()


@pytest.mark.parametrize("mesh, element", [
    (MeshTet1.init_tensor(*[np.linspace(0, 1e-3, 4)] * 3).with_defaults(), "P1"),
    (MeshHex1.init_tensor(*[np.linspace(0, 1e-3, 3)] * 3).with_defaults(), "P2"),
    (MeshTri1.init_tensor(np.linspace(0, 1e-3, 6), np.linspace(0, 1e-3, 4)).with_defaults(),
     "P2"),
], ids=["tet-P1", "hex-P2", "tri-P2"])
def test_step_operators_equal_scikit_fem(mesh, element):
    """The per-step sums from cached quadrature tables (thermal load, displacement gradient,
    temperature at the quadrature points, stress projection) against scikit-fem's forms."""
    from skfem import LinearForm

    sub = FEMSubstrate(mesh, 300e9, 0.21, 7e-6, element=element, clamps=["bottom"])
    p = mesh.p
    dT = 40.0 + 30.0 * np.sin(3e3 * p[0]) * np.cos(2e3 * p[1])
    dTq = sub.vbasis.interpolate(dT)
    assert np.abs(sub._dT_qp(dT) - dTq).max() < RTOL * np.abs(dTq).max()
    f0 = forms.thermal_load(LAM, MU, 7e-6).assemble(sub.basis, dT=dTq)
    assert np.abs(sub.thermal_load(dT) - f0).max() < RTOL * np.abs(f0).max()
    f0 = forms.thermal_load(LAM, MU, 7e-6).assemble(sub.basis, dT=2.5)
    assert np.abs(sub.thermal_load(2.5) - f0).max() < RTOL * np.abs(f0).max()
    res = sub.solve(dT_nodal=dT)
    g0 = sub.basis.interpolate(res.dofs).grad
    assert np.abs(sub.grad_qp(res.dofs) - g0).max() < RTOL * np.abs(g0).max()
    # projection: M x = int s phi dx, M and the right-hand side by scikit-fem
    S = res.stress_qp
    M = forms.mass.assemble(sub.vbasis).tocsc()
    Sn = res.stress_nodes
    for i, j in ((0, 0), (0, 1), (1, 2) if sub.dim == 3 else (1, 1), (2, 2)):

        @LinearForm
        def rhs(v, w, i=i, j=j):
            return w.s * v

        x = spsolve(M, rhs.assemble(sub.vbasis, s=S[i, j]))
        assert np.abs(Sn[:, i, j] - x).max() < 1e-11 * np.abs(S).max()
        assert np.array_equal(Sn[:, i, j], Sn[:, j, i])


def test_axisymmetric_stress_from_tables_equals_scikit_fem_interpolation():
    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, axisymmetric_stress

    mesh = MeshTri1.init_tensor(np.linspace(0, 1e-3, 8), np.linspace(-4e-4, 0, 5))
    sub = AxisymmetricFEMSubstrate(mesh.with_defaults(), 300e9, 0.21, 7e-6, element="P2",
                                   clamps=["bottom"])
    dT = 30.0 * np.exp(-(mesh.p[0] / 3e-4) ** 2)
    res = sub.solve(dT_nodal=dT, tractions={"top": [0.0, -1e6]})
    uh = sub.basis.interpolate(res.dofs)
    assert np.abs(sub.values_qp(res.dofs) - np.asarray(uh)).max() < RTOL * np.abs(res.dofs).max()
    S0 = axisymmetric_stress(sub.lam, sub.mu, sub.alpha, uh.grad, uh[0], sub.r_qp,
                             sub.vbasis.interpolate(dT))
    assert np.abs(res.stress_qp - S0).max() < 1e-12 * np.abs(S0).max()
