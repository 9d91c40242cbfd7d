"""The "fem-axisymmetric" coupling backend: ring forces, temperatures, registry."""

from __future__ import annotations

import numpy as np
import pytest
from builders import isolated_cache  # noqa: F401  (autouse: a private mesh cache)

from coupling.backend_fem_axisymmetric import AxisymmetricFEMBackend
from coupling.backends import BACKENDS, make_backend
from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, substrate_rz

E, NU, ALPHA = 300e9, 0.21, 7e-6
R_SUB, DEPTH = 1.0, 0.4




def substrate(**kw):
    mesh = substrate_rz(radius=R_SUB, depth=DEPTH, h_fine=0.01, h_coarse=0.08,
                        refine_radius=0.25)
    return AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element="P2", **kw)


def test_registered():
    assert BACKENDS["fem-axisymmetric"] is AxisymmetricFEMBackend  # by importing its module
    with pytest.raises(TypeError, match="AxisymmetricFEMSubstrate"):
        from sphfem.fem import FEMSubstrate
        from sphfem.fem.meshing import substrate_rect

        plane = FEMSubstrate(substrate_rect(size=(1.0, 0.3), h_fine=0.1, h_coarse=0.1),
                             E, NU, ALPHA, clamps=["bottom"])
        make_backend("fem-axisymmetric", substrate=plane, temperature_map="off")


def test_ring_forces_equal_the_pressure_patch():
    """Sensors on rings r_i = (i + 1/2) dr, i < a/dr, each with the ring force
    -p 2 pi r_i dr of a uniform pressure p on r < a: the total axial reaction is p pi a^2
    (midpoint rule, exact for the ring areas) and the displacement under the load matches
    the substrate loaded by the traction p on r < a within 1 %."""
    p, a, dr = 2e7, 0.2, 0.002
    sub = substrate(clamps=["bottom"])
    back = make_backend("fem-axisymmetric", substrate=sub, temperature_map="off")
    r = (np.arange(int(round(a / dr))) + 0.5) * dr
    X = np.column_stack([r, np.zeros_like(r)])
    F = np.column_stack([np.zeros_like(r), -p * 2 * np.pi * r * dr])
    book = back.apply(X, F)
    assert np.allclose(book["force_out"], book["force_in"], rtol=1e-12, atol=1e-9)
    res = back.solve(0.0)
    assert res.result.reaction("bottom")[1] == pytest.approx(p * np.pi * a**2, rel=1e-9)
    ref = sub.solve(tractions={"top": lambda x: np.array([0 * x[0],
                                                          -p * (x[0] < a)])})
    q = [[0.0, 0.0], [0.0, -0.1], [0.1, -0.05]]
    assert np.allclose(res.probe(q)["u"], ref.probe(q)["u"], rtol=1e-2, atol=1e-3 * np.abs(
        ref.probe(q)["u"]).max())
    vm, where = res.peak_von_mises()
    assert vm > 0 and where.shape == (2,)
    # per-radian forces give the same solution
    back2 = make_backend("fem-axisymmetric", substrate=sub, temperature_map="off",
                         force_convention="radian")
    back2.apply(X, F / (2 * np.pi))
    assert np.allclose(back2.solve(0.0).result.dofs, res.result.dofs, rtol=0,
                       atol=1e-12 * np.abs(res.result.dofs).max())
    # line densities f = F / (2 pi r): the same loads, bookkeeping in ring totals
    back3 = make_backend("fem-axisymmetric", substrate=sub, temperature_map="off",
                         force_convention="line")
    book3 = back3.apply(X, F / (2 * np.pi * r[:, None]))
    assert np.allclose(book3["force_in"], F.sum(axis=0), rtol=1e-12)
    assert np.allclose(back3.solve(0.0).result.dofs, res.result.dofs, rtol=0,
                       atol=1e-12 * np.abs(res.result.dofs).max())
    d = back.diagnostics()
    assert d["backend"] == "fem-axisymmetric" and d["force_convention"] == "ring"
    assert sub.n_factorizations == 1


def test_write_series(tmp_path):
    """One VTU frame of the (r, z) mesh (points (r, z, 0)) with the hoop stress in the
    tensor's third diagonal entry, and the .pvd listing it."""
    import meshio

    sub = substrate(clamps=["bottom"])
    back = make_backend("fem-axisymmetric", substrate=sub, temperature_map="off")
    back.apply([[0.0, 0.0], [0.05, 0.0]], [[0.0, -1e3], [0.0, -2e3]])
    res = back.solve(0.0)
    path = back.write(0.0, tmp_path)
    m = meshio.read(path)
    assert m.points.shape == (sub.mesh.nvertices, 3) and np.all(m.points[:, 2] == 0)
    assert np.allclose(m.point_data["stress"].reshape(-1, 3, 3)[:, 2, 2],
                       res.result.stress_nodes[:, 2, 2])
    assert (tmp_path / "substrate.pvd").is_file()


def test_uniform_temperature_through_the_map_is_stress_free():
    """Region particles on a lattice covering the (r, z) section at T0 + dT (vol = cell
    areas): the MLS map gives dT at every node, the free disc expands without stress and
    the ring-volume-weighted mean stress is zero."""
    dT, h = 40.0, 0.02
    sub = substrate()
    back = make_backend("fem-axisymmetric", substrate=sub, temperature_map="mls", R=3 * h)
    rr, zz = np.meshgrid(np.arange(h / 2, R_SUB, h), np.arange(-DEPTH + h / 2, 0, h))
    Tp = np.column_stack([rr.ravel(), zz.ravel()])
    back.apply(np.zeros((0, 2)), np.zeros((0, 2)), Tp, np.full(len(Tp), sub.T0 + dT),
               np.full(len(Tp), h * h))
    res = back.solve(0.0)
    scale = E * ALPHA * dT
    assert np.abs(res.result.stress_nodes).max() < 1e-8 * scale
    assert np.abs(res.mean_stress()).max() < 1e-8 * scale
    assert np.allclose(res.result.u[:, 0], ALPHA * dT * sub.mesh.p[0], rtol=0, atol=1e-14)
    assert res.cell_volume.sum() == pytest.approx(np.pi * R_SUB**2 * DEPTH, rel=1e-12)
    assert res.probe([[0.5, -0.2]])["T"][0] == pytest.approx(sub.T0 + dT, rel=1e-12)
