"""The coupling driver with the TL-SPH substrate backend (``[coupling] backend = "tlsph"``):
a hot water block on an alumina block (2D), heat only."""

from __future__ import annotations

import numpy as np
import pytest
from test_coupling import HOT  # the same hot-block scene, with the FEM backend

# the FEM scene with the TL-SPH backend: no mesh section, probes inside the TL-SPH body
SCENE = (
    HOT.replace('name = "hot_block"', 'name = "hot_block_tlsph"')
    .replace('[coupling]\nmaterial', '[coupling]\nbackend = "tlsph"\nmaterial')
    .replace('[coupling.mesh]\nh_fine = 25e-6\ncells = "tri"\n',
             'probes = [[0.0, -12.5e-6], [0.0, -0.1e-3]]\n')
)


def test_coupled_run_with_the_tlsph_substrate(tmp_path, monkeypatch):
    from sphfem.api import run
    from sphfem.scene import parse_scene_toml

    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))
    res = run(parse_scene_toml(SCENE), tmp_path / "out")
    summary = res.summary
    d = summary["diagnostics"]["coupling"]
    b = d["backend"]
    assert b["backend"] == "tlsph" and b["B0_fallbacks"] == 0
    steps = summary["steps"]
    assert d["solves"] == 1 + steps // 3 + (steps % 3 != 0)
    assert b["relax_steps"][0] == 0  # no load at t = 0: nothing to relax
    assert abs(d["heat"]["residual_rel"]) < 1e-11
    # heated from above, clamped at the sides: the hot top is in lateral compression
    top = d["last"]["probes"][0]
    assert top["xx"] < 0 and top["T"] > 293.15 + 1.0
    assert d["peak_von_mises_Pa"] > 1e6 and np.isfinite(d["peak_von_mises_Pa"])
    assert d["vtu_written"] >= 2


# ------------------------------------------------------------------ one result type
E, NU, ALPHA, T0, DT = 300e9, 0.21, 8.1e-6, 293.15, 40.0
LO, HI, DX = np.array([0.0, -0.5e-3]), np.array([1.0e-3, 0.0]), 0.1e-3
#: every face on rollers holding its normal component: the block cannot expand
ROLLERS = {"left": "x", "right": "x", "bottom": "y", "top": "y"}


def _lattice():
    axes = [np.arange(a + DX / 2, b, DX) for a, b in zip(LO, HI, strict=True)]
    g = np.meshgrid(*axes, indexing="ij")
    return np.stack([c.ravel() for c in g], axis=1)


def _backend(kind):
    from coupling.backends import FEMBackend, TLSPHBackend

    if kind == "tlsph":
        from sphfem.solid.backend import TLSPHSubstrate

        return TLSPHBackend(TLSPHSubstrate(LO, HI, DX, E, NU, ALPHA, T0=T0, rho=3950.0,
                                           rollers=ROLLERS), "top")
    from skfem import MeshQuad1
    from test_coupling import _box_groups

    from sphfem.fem import FEMSubstrate

    m = MeshQuad1.init_tensor(np.linspace(LO[0], HI[0], 11), np.linspace(LO[1], HI[1], 6))
    sub = FEMSubstrate(_box_groups(m, LO, HI), E=E, nu=NU, alpha=ALPHA, T0=T0,
                       rollers=ROLLERS)
    return FEMBackend(sub, "top", "mls", R=3 * DX)


@pytest.mark.parametrize("kind", ["fem", "tlsph"])
def test_both_backends_give_the_constrained_thermal_stress_through_one_result(kind):
    """A block whose faces all hold their normal displacement, heated uniformly by dT
    through the coupling's hand-over (particle temperatures, no sensor force): u = 0 and a
    hydrostatic stress sigma I (3 x 3, plane strain, sigma_zz included), read through the
    one CoupledResult of either backend: probes, the volume mean and a zero peak von Mises;
    probe T = T0 + dT.  FEM (linear): sigma = -(3 lam + 2 mu) alpha dT = -E alpha dT /
    (1 - 2 nu); TL-SPH (F = F_e F_theta, F_theta = v I, v = 1 + alpha dT, SVK; Park 2019
    eqs. 2.118-2.122 with F = I): sigma = v (3 lam + 2 mu) (1/v^2 - 1) / 2, which differs
    from the linear value by O(alpha dT) = 1.6e-4.  Both models are exact here (FEM: the
    field is in the element space; TL-SPH: mirror ghosts at the roller planes)."""
    from coupling.backends import CoupledResult

    be = _backend(kind)
    X = _lattice()
    book = be.apply(np.zeros((0, 2)), np.zeros((0, 2)), X, np.full(len(X), T0 + DT),
                    np.full(len(X), DX**2))
    assert np.all(book["force_out"] == 0) and book["clipped"] == 0
    res = be.solve(1.0)
    assert isinstance(res, CoupledResult) and res.t == 1.0
    k3 = E / (1 - 2 * NU)  # 3 lam + 2 mu
    v = 1 + ALPHA * DT
    s = -k3 * ALPHA * DT if kind == "fem" else v * k3 * (1 / v**2 - 1) / 2  # -168 MPa
    pts = np.array([[0.5e-3, -0.25e-3], [0.12e-3, -0.03e-3], [0.93e-3, -0.41e-3]])
    p = res.probe(pts)
    assert np.abs(p["stress"] - s * np.eye(3)).max() < 1e-10 * abs(s)
    assert np.abs(p["u"]).max() < 1e-10 * ALPHA * DT * DX
    assert np.allclose(p["T"], T0 + DT, rtol=1e-14, atol=0)
    assert np.abs(res.mean_stress() - s * np.eye(3)).max() < 1e-10 * abs(s)
    vm, where = res.peak_von_mises()
    assert vm < 1e-9 * abs(s) and where.shape == (2,)


def test_tlsph_backend_hands_over_the_total_force_exactly():
    """Sensor forces land on the nearest particles of the coupled face: the total force is
    the sensors' own (exactly, summed in the same order) and the moment is that of the
    forces at the face particles they landed on."""
    from coupling.transfer import point_moment

    be = _backend("tlsph")
    rng = np.random.default_rng(5)
    P = np.column_stack([rng.uniform(LO[0], HI[0], 30), rng.uniform(-2 * DX, 0.0, 30)])
    F = rng.normal(size=(30, 2))
    book = be.apply(P, F)
    assert np.array_equal(book["force_out"], F.sum(axis=0))
    layer = be.sub.X[np.abs(be.sub.X[:, 1] - (HI[1] - DX / 2)) < 1e-9 * DX]
    landed = layer[np.argmin(np.abs(P[:, None, 0] - layer[None, :, 0]), axis=1)]
    assert np.allclose(book["moment_out"], point_moment(landed, F), rtol=1e-13, atol=0)
    assert np.allclose(book["moment_in"], point_moment(P, F), rtol=1e-13, atol=0)


def test_tlsph_backend_from_the_factory_follows_the_protocol():
    from coupling.backends import BACKENDS, SubstrateBackend, TLSPHBackend, make_backend

    sub = _backend("tlsph").sub
    be = make_backend("tlsph", substrate=sub, surface="top")
    assert isinstance(be, TLSPHBackend) and isinstance(be, SubstrateBackend)
    assert be.surface_plane == (1, 0.0, -1) and {"fem", "tlsph"} <= set(BACKENDS)
    with pytest.raises(ValueError, match="names box faces"):
        TLSPHBackend(sub, "roof")
