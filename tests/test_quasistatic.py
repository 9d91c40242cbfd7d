"""One ``solve`` for the quasi-static substrates (FEM, axisymmetric FEM, TL-SPH).

A uniform temperature rise dT with every face on rollers (normal held) has u = 0 and the
hydrostatic stress -(3 lam + 2 mu) alpha dT in linear elasticity (FEM, exact), and
v (3 lam + 2 mu) (1/v^2 - 1) / 2 with v = 1 + alpha dT for the SVK law of the TL-SPH solid
(exact at F = I).  Both substrates take the loads through the one shared ``solve``: the
temperature as dT or as absolute T (dT = T - T0) gives the same state.
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import MeshTri

from sphfem.fem import FEMSubstrate
from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate
from sphfem.quasistatic import QuasiStaticSubstrate
from sphfem.solid.backend import TLSPHSubstrate

E, NU, ALPHA, T0, DT = 200e9, 0.3, 1e-5, 300.0, 40.0
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))
ROLLERS = {"left": "x", "right": "x", "bottom": "y", "top": "y"}


def _fem():
    mesh = MeshTri.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 0.5, 4)).with_defaults()
    return FEMSubstrate(mesh, E, NU, ALPHA, T0=T0, rollers=ROLLERS)


def _tlsph():
    return TLSPHSubstrate((0.0, 0.0), (0.8, 0.5), 0.1, E, NU, ALPHA, T0=T0, rho=1000.0,
                          rollers=ROLLERS, tol=1e-8)


def test_every_substrate_solves_through_the_shared_solve():
    for cls in (FEMSubstrate, AxisymmetricFEMSubstrate, TLSPHSubstrate):
        assert issubclass(cls, QuasiStaticSubstrate)
        assert cls.solve is QuasiStaticSubstrate.solve


def test_fem_uniform_heating_on_rollers_is_exact_for_dT_and_T():
    sub = _fem()
    exact = -(3 * LAM + 2 * MU) * ALPHA * DT
    for loads in ({"dT_nodal": DT}, {"T_nodal": T0 + DT},
                  {"T_nodal": np.full(sub.mesh.nvertices, T0 + DT)}):
        r = sub.solve(**loads)
        assert np.abs(r.u).max() < 1e-12 * ALPHA * DT
        s = r.stress_elem
        assert np.abs(s[:, [0, 1, 2], [0, 1, 2]] / exact - 1).max() < 1e-10
        assert {"assemble_load_s", "solve_s"} <= set(r.info)
    assert sub.n_solves == 3


def test_tlsph_uniform_heating_on_rollers_is_exact_for_dT_and_T():
    sub = _tlsph()
    v = 1 + ALPHA * DT
    exact = v * (3 * LAM + 2 * MU) * (1 / v**2 - 1) / 2
    for loads in ({"dT_nodal": DT}, {"T_nodal": T0 + DT}):
        r = sub.solve(**loads)
        assert np.abs(r.u).max() <= 1e-12 * ALPHA * DT
        assert np.abs(r.stress[:, [0, 1, 2], [0, 1, 2]] / exact - 1).max() < 1e-11
        assert np.allclose(r.dT, DT, rtol=1e-14)
        assert {"assemble_load_s", "solve_s", "steps", "converged"} <= set(r.info)
    assert sub.n_solves == 2 and len(sub.relax_steps) == 2


def test_shared_solve_rejects_conflicting_loads():
    sub = _tlsph()
    with pytest.raises(ValueError, match="dT_nodal or T_nodal"):
        sub.solve(dT_nodal=1.0, T_nodal=T0 + 1.0)
    with pytest.raises(ValueError, match="ready nodal load vector"):
        sub.solve(load=np.zeros(3))
    with pytest.raises(ValueError, match="dT_nodal or T_nodal"):
        _fem().solve(dT_nodal=1.0, T_nodal=T0 + 1.0)
