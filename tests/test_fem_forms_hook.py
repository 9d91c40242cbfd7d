"""FEMSubstrate takes its weak forms from class attributes: the axisymmetric substrate
states its forms and geometry hooks only, and the default quadrature rule of K is exact."""

from __future__ import annotations

import numpy as np
from skfem import MeshTri

from sphfem.fem import FEMSubstrate, forms
from sphfem.fem.axisymmetric import (
    AxisymmetricFEMSubstrate,
    axisymmetric_elasticity,
    axisymmetric_thermal_load,
)

E, NU, ALPHA = 70e9, 0.25, 2e-5


def _mesh():
    return MeshTri.init_tensor(np.linspace(0, 1e-3, 6), np.linspace(-5e-4, 0, 4)).with_defaults()


def test_axisymmetric_substrate_assembles_its_own_forms():
    sub = AxisymmetricFEMSubstrate(_mesh(), E, NU, ALPHA, element="P2", clamps=["bottom"])
    assert sub.intorder == 5 and "__init__" in vars(AxisymmetricFEMSubstrate)
    K = axisymmetric_elasticity(sub.lam, sub.mu).assemble(sub.basis)
    assert abs(sub.K - K).max() == 0.0
    f = axisymmetric_thermal_load(sub.lam, sub.mu, ALPHA).assemble(sub.basis, dT=3.0)
    assert np.array_equal(sub.thermal_load(3.0), f)
    # the axis holds u_r, the clamp both components; nothing else
    axis_r = np.intersect1d(sub._group_dofs("axis"), sub.component_dofs[0])
    assert np.array_equal(sub.D, np.union1d(axis_r, sub._group_dofs("bottom")))
    assert not sub.pin_rigid


def test_axisymmetric_pins_z_only_when_nothing_holds_it():
    assert AxisymmetricFEMSubstrate(_mesh(), E, NU, ALPHA, rollers={"right": "r"}).pin_rigid
    assert not AxisymmetricFEMSubstrate(_mesh(), E, NU, ALPHA, rollers={"bottom": "z"}).pin_rigid


def test_fem_stiffness_rule_is_exact_on_simplices():
    """P1/P2 triangles: grad u : grad v has degree 2(p - 1), so the reduced rule K is built
    with gives the K of a high-order rule to round-off."""
    for element in ("P1", "P2"):
        reduced = FEMSubstrate(_mesh(), E, NU, ALPHA, element=element, clamps=["bottom"])
        full = FEMSubstrate(_mesh(), E, NU, ALPHA, element=element, clamps=["bottom"],
                            intorder=6)
        assert abs(reduced.K - full.K).max() < 1e-12 * abs(full.K).max()
        lam, mu = forms.lame_parameters(E, NU)
        # K comes from sphfem.fem.assembly (its own summation order): round-off
        K = forms.elasticity(lam, mu).assemble(full.basis)
        assert abs(full.K - K).max() < 1e-13 * abs(K).max()
