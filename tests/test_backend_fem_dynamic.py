"""The "fem-dynamic" and "fem-axisymmetric-dynamic" coupling backends: registry, varying
coupling step (= direct HHT/Newmark stepping to round-off), thermal load, slow loading ->
the quasi-static backend."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.linalg import eigsh

from coupling.backend_fem_dynamic import AxisymmetricDynamicFEMBackend, DynamicFEMBackend
from coupling.backends import BACKENDS, make_backend
from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, graded_tensor_rz
from sphfem.fem.elastodynamic import ElastodynamicSubstrate
from sphfem.fem.substrate import FEMSubstrate

E, NU, ALPHA, RHO = 300e9, 0.21, 7e-6, 3950.0
R_SUB, DEPTH = 1e-3, 0.26e-3


def axi():
    m = graded_tensor_rz(R_SUB, DEPTH, 20e-6, 100e-6, growth=1.3)
    return AxisymmetricFEMSubstrate(m, E, NU, ALPHA, clamps=["bottom"])


def plane():
    m = graded_tensor_rz(R_SUB, DEPTH, 20e-6, 100e-6, growth=1.3)  # an (x, z) strip
    return FEMSubstrate(m, E, NU, ALPHA, clamps=["bottom"])


def sensors(sub, n=8, F=-1.0):
    r = (np.arange(n) + 0.5) * 10e-6
    X = np.column_stack([r, np.zeros(n)])
    return X, np.column_stack([np.zeros(n), F * (1 + r / r.max())])


def test_registered():
    assert BACKENDS["fem-dynamic"] is DynamicFEMBackend
    assert BACKENDS["fem-axisymmetric-dynamic"] is AxisymmetricDynamicFEMBackend


@pytest.mark.parametrize("kind", ["fem-dynamic", "fem-axisymmetric-dynamic"])
def test_varying_coupling_step_equals_direct_stepping(kind):
    """Irregular coupling times, forces and a temperature field: the backend's states equal
    an ElastodynamicSubstrate stepped with the same loads (the transfer's nodal forces,
    the mapped temperatures) to round-off (1e-9 of the largest
    displacement: the loads are summed in another order, amplified by the effective
    matrix's condition number); one factorisation per
    distinct dt; a repeated time returns the same result; going back raises."""
    sub = axi() if kind.startswith("fem-axi") else plane()
    R = 30e-6
    g = np.stack(np.meshgrid(np.linspace(0, R_SUB, 60), np.linspace(-DEPTH, 0, 20)), -1)
    Tp = g.reshape(-1, 2)
    vol = np.full(len(Tp), (R_SUB / 59) * (DEPTH / 19))
    back = make_backend(kind, substrate=sub, rho=RHO, temperature_map="shepard", R=R)
    ref = ElastodynamicSubstrate(sub, RHO)
    X, F = sensors(sub)
    times = np.cumsum([2e-9, 2e-9, 3e-9, 2e-9, 1.5e-9, 3e-9])
    for k, t in enumerate(times):
        T = back.T0 + 50.0 * np.exp(Tp[:, 1] / 20e-6) * (k + 1) / len(times)
        Fk = F * np.sin(k + 1.0)
        back.apply(X, Fk, Tp, T, vol)
        res = back.solve(t)
        assert back.solve(t) is res
        dT = back._T_nodes - back.T0
        r2 = ref.step(t - ref.t, dT_nodal=dT, load=back._f)  # the transferred P^T F
        scale = np.abs(r2.dofs).max()
        assert np.abs(res.result.dofs - r2.dofs).max() <= 1e-9 * scale
        vm = r2.von_mises_nodes
        assert np.abs(res.result.von_mises_nodes - vm).max() <= 1e-9 * vm.max()
    assert back.dyn.n_factorizations == 3
    with pytest.raises(ValueError, match="not after"):
        back.solve(times[2])
    d = back.diagnostics()
    assert d["backend"] == kind and d["dynamics"]["factorizations"] == 3


def test_slow_loading_tends_to_the_quasi_static_backend():
    """Ring forces ramped over t_r = 2.5 T_1 and 10.5 T_1 (T_1 the slowest discrete period
    of the clamped disk; half-integer multiples, where the first mode's residual amplitude
    |sin(pi t_r / T_1)| / (pi t_r / T_1) is largest) and held for T_1: the largest relative
    difference of the axis displacement u_z(0, 0) from the quasi-static backend's over the
    hold is below 2 T_1 / (pi t_r) (the modal envelope; factor 2 for modal contributions of
    either sign at a point other than the load's) and falls with t_r."""
    sub = axi()
    qs = make_backend("fem-axisymmetric", substrate=sub, temperature_map="off")
    X, F = sensors(sub, F=-1e3)
    qs.apply(X, F)
    u_qs = qs.solve(0.0).probe([[0.0, 0.0]])["u"][0, 1]
    I = sub.I
    dyn0 = ElastodynamicSubstrate(sub, RHO)
    w2 = eigsh(sub.K[I][:, I].tocsc(), k=1, M=dyn0.M[I][:, I].tocsc(), sigma=0)[0]
    T1 = 2 * np.pi / np.sqrt(w2[0])
    devs = []
    for mult in (2.5, 10.5):
        tr = mult * T1
        back = make_backend("fem-axisymmetric-dynamic", substrate=sub, rho=RHO,
                            temperature_map="off")
        dt, t, dev = T1 / 40, 0.0, 0.0
        while t < tr + T1 - 1e-15:
            t += dt
            back.apply(X, F * min(1.0, t / tr))
            res = back.solve(t)
            if t >= tr:
                dev = max(dev, abs(res.probe([[0.0, 0.0]])["u"][0, 1] / u_qs - 1.0))
        assert dev < 2 * T1 / (np.pi * tr), (mult, dev)
        devs.append(dev)
    assert devs[1] < 0.5 * devs[0], devs
