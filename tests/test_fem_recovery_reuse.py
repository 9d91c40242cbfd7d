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


def test_element_averages_over_the_nonzero_components():
    """stress_elem from the nonzero upper-triangle components equals the r-weighted
    average of the whole (3, 3) field, bit for bit."""
    sub = substrate()
    res = sub.solve(dT_nodal=field(sub.mesh.p))
    w = sub.rdx
    full = np.moveaxis((res.stress_qp * w).sum(axis=-1) / w.sum(axis=-1), -1, 0)
    assert np.array_equal(res.stress_elem, full)
    assert np.abs(full[:, 0, 1]).max() > 0 and not np.any(full[:, 0, 2])
