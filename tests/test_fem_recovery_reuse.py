"""Per-coupling-step operators of the axisymmetric FEM substrate built once and re-used
(sphfem.fem.axisymmetric, sphfem.fem.substrate): the thermal load as a matrix times the
nodal temperature change, and the stress recovery's right-hand-side matrix, each against
scikit-fem's assembly of the same integrals to round-off."""

import numpy as np
import pytest
from skfem import BilinearForm, LinearForm, MeshTri

from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, axisymmetric_thermal_load

E, NU, ALPHA = 300e9, 0.21, 8.1e-6
#: summation-order round-off, relative to the largest entry (measured <= 5e-16)
RTOL = 1e-13


def substrate(element="P1"):
    m = MeshTri.init_tensor(np.linspace(0, 1e-3, 25),
                            np.concatenate([-np.geomspace(5e-4, 1e-6, 14), [0.0]]))
    return AxisymmetricFEMSubstrate(m.with_defaults(), E, NU, ALPHA, element=element,
                                    clamps=["bottom", "right"])


def field(x):
    return 40.0 + 30.0 * np.sin(3e3 * x[0]) * np.cos(7e3 * x[1])


@pytest.mark.parametrize("element", ["P1", "P2"])
def test_thermal_load_matrix_equals_the_linear_form(element):
    sub = substrate(element)
    form = axisymmetric_thermal_load(sub.lam, sub.mu, ALPHA)
    for basis in (sub.vbasis, sub.sbasis):  # vertex and scalar-dof temperature arrays
        dT = field(basis.doflocs)
        f0 = form.assemble(sub.basis, dT=basis.interpolate(dT))
        f = sub.thermal_load(dT)
        assert np.abs(f - f0).max() < RTOL * np.abs(f0).max()
    # scalars and callables still go through the linear form, bit for bit
    assert np.array_equal(sub.thermal_load(3.0), form.assemble(sub.basis, dT=3.0))
    with pytest.raises(ValueError, match="dT"):
        sub.thermal_load(np.ones(7))


def test_projection_against_scikit_fem_and_zero_components():
    """Nodal stresses of a solve: M x = int s phi dx assembled by scikit-fem per
    component; the theta shears (zero at every quadrature point) come out exactly 0."""
    sub = substrate()
    res = sub.solve(dT_nodal=field(sub.mesh.p))
    Sq = res.stress_qp
    assert not np.any(Sq[0, 2]) and not np.any(Sq[1, 2])
    vb = sub.vbasis

    @BilinearForm
    def mass(u, v, w):
        return u * v

    @LinearForm
    def rhs(v, w):
        return w.s * v

    from scipy.sparse.linalg import spsolve

    M = mass.assemble(vb).tocsc()
    Sn = res.stress_nodes
    for i, j in ((0, 0), (1, 1), (2, 2), (0, 1)):
        x = spsolve(M, rhs.assemble(vb, s=Sq[i, j]))
        assert np.abs(Sn[:, i, j] - x).max() < 1e-12 * np.abs(x).max()
    assert np.all(Sn[:, 0, 2] == 0.0) and np.all(Sn[:, 2, 1] == 0.0)
    # cached on the result: the same arrays on every query
    assert res.stress_elem is res.stress_elem
    assert res.von_mises_nodes is res.von_mises_nodes


@pytest.mark.parametrize("element", ["P1", "P2"])
@pytest.mark.parametrize("with_dT", [True, False])
def test_linear_stress_maps_equal_the_quadrature_path(element, with_dT):
    """Nodal (projected) and element-averaged stresses by the linear maps of (u, dT)
    against the projection / average of the stress at the quadrature points, to 1e-12 of
    the largest stress; a callable dT takes the quadrature path."""
    from sphfem.fem.axisymmetric import AxisymmetricResult

    sub = substrate(element)
    dT = field(sub.mesh.p) if with_dT else None
    res = sub.solve(dT_nodal=dT,
                    tractions={"top": lambda x: np.array([0 * x[0], -1e6 * (x[0] < 2e-4)])})
    Sn, Se = res.stress_nodes, res.stress_elem
    Sq = res.stress_qp
    ref_n = sub.project_tensor(Sq)
    w = sub.rdx
    ref_e = np.moveaxis((Sq * w).sum(axis=-1) / w.sum(axis=-1), -1, 0)
    scale = np.abs(ref_n).max()
    assert scale > 1e5
    assert np.abs(Sn - ref_n).max() < 1e-12 * scale
    assert np.abs(Se - ref_e).max() < 1e-12 * np.abs(ref_e).max()
    assert not np.any(Sn[:, 0, 2]) and not np.any(Se[:, 1, 2])
    if with_dT:  # the same field as a callable: the quadrature path, bit for bit (the
        # element averages over the nonzero upper-triangle components, mirrored)
        other = AxisymmetricResult(sub, res.dofs, res.load, lambda X: field(X), {})
        assert sub.linear_stress(res.dofs, other.dT_spec, "nodes") is None
        assert np.array_equal(other.stress_nodes, sub.project_tensor(other.stress_qp))
        Sq = other.stress_qp
        full = np.moveaxis((Sq * w).sum(axis=-1) / w.sum(axis=-1), -1, 0)
        assert np.array_equal(other.stress_elem, full)


def test_probe_locations_kept():
    """A second probe of the same points uses the kept cells and reference coordinates:
    the same answer bit for bit, and the kept arrays do not change when the returned ones
    are written to; points outside the mesh still raise."""
    sub = substrate()
    res = sub.solve(dT_nodal=field(sub.mesh.p))
    X = np.array([[0.0, -1e-9], [1e-4, -5e-6], [3e-4, -2e-4]])
    a = res.probe(X)
    cells, pts = sub._locate(X.T)
    cells[:] = 0
    pts[:] = 0.0
    b = res.probe(X)
    for k in ("u", "stress", "von_mises", "dT"):
        assert np.array_equal(a[k], b[k])
    sub.__dict__["_located"].clear()
    c = res.probe(X)
    assert all(np.array_equal(a[k], c[k]) for k in a)
    with pytest.raises(ValueError, match="outside"):
        sub._locate(np.array([[2e-3], [0.0]]))
