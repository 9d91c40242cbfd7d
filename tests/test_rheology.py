"""Non-Newtonian rheology (sphfem.fluid.rheology): the regularised Herschel-Bulkley law
against its formula and limits, the strain rate of linear velocity fields, the scene keys,
and a short channel run against the exact Herschel-Bulkley profile."""

import math

import numpy as np
import pytest

from sphfem import kernels as K
from sphfem.fluid import rheology
from sphfem.fluid.rheology import apparent_viscosity, hb_viscosity, strain_rate
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID, WALL

mu_hb = hb_viscosity.py_func
GD = np.geomspace(1e-6, 1e4, 61)


def formula(gd, tau0, k, n, gd0, papanastasiou):
    """Written out independently: the cut-off (Park 2019 eq. 2.148 with the exponent n - 1)
    or Papanastasiou (1987) with m = 1/gd0 and the power-law part held at gd0."""
    g = max(gd, gd0)
    if papanastasiou:
        reg = tau0 / gd0 if gd == 0.0 else -tau0 * math.expm1(-gd / gd0) / gd  # 1 - e^-x
        return k * g ** (n - 1.0) + reg
    return k * g ** (n - 1.0) + tau0 / g


@pytest.mark.parametrize("pap", [False, True])
@pytest.mark.parametrize("tau0,k,n", [(2.0, 0.5, 0.5), (10.0, 1e-3, 1.0), (0.0, 3.0, 0.3),
                                      (1.0, 0.1, 1.7)])
def test_hb_viscosity_is_the_formula(tau0, k, n, pap):
    gd0 = 0.1
    for gd in [0.0, *GD]:
        assert mu_hb(gd, tau0, k, n, gd0, pap) == pytest.approx(
            formula(gd, tau0, k, n, gd0, pap), rel=1e-12)


def test_hb_viscosity_limits():
    gd0 = 1e-3
    for gd in GD[GD > gd0]:
        hb = mu_hb(gd, 0.0, 2.0, 0.4, gd0, False)
        assert hb == pytest.approx(2.0 * gd ** -0.6, rel=1e-14)           # tau0 = 0: power law
        assert mu_hb(gd, 5.0, 2.0, 1.0, gd0, False) == pytest.approx(2.0 + 5.0 / gd,
                                                                     rel=1e-14)  # Bingham
        assert mu_hb(gd, 0.0, 2.0, 1.0, gd0, True) == 2.0                 # Newtonian
        # above the cut-off the stress is tau0 + k gd^n (Herschel-Bulkley)
        assert mu_hb(gd, 5.0, 2.0, 0.4, gd0, False) * gd == pytest.approx(
            5.0 + 2.0 * gd**0.4, rel=1e-13)
    # Papanastasiou tends to Herschel-Bulkley far above gd0 ...
    assert mu_hb(1e3, 5.0, 2.0, 0.4, 1e-3, True) * 1e3 == pytest.approx(5.0 + 2.0 * 1e3**0.4,
                                                                        rel=1e-12)
    # ... the cut-off is continuous at gd0 and both are bounded by k gd0^(n-1) + tau0/gd0
    top = 2.0 * gd0**-0.6 + 5.0 / gd0
    for pap in (False, True):
        assert mu_hb(0.0, 5.0, 2.0, 0.4, gd0, pap) == pytest.approx(top, rel=1e-12)
        assert mu_hb(gd0 * (1 - 1e-12), 5.0, 2.0, 0.4, gd0, pap) <= top * (1 + 1e-12)
    assert mu_hb(gd0 * (1 + 1e-12), 5.0, 2.0, 0.4, gd0, False) == pytest.approx(top, rel=1e-9)


def test_apparent_viscosity_writes_fluid_rows_only():
    gd = np.array([0.0, 1.0, 10.0, 5.0])
    kind = np.array([FLUID, FLUID, FLUID, WALL], dtype=np.int8)
    mu = np.full(4, -1.0)
    apparent_viscosity(gd, kind, 1.0, 0.5, 0.5, 0.01, False, mu)
    assert mu[3] == -1.0
    np.testing.assert_allclose(mu[:3], [formula(g, 1.0, 0.5, 0.5, 0.01, False)
                                        for g in gd[:3]], rtol=1e-13)


def _cloud(dim, n_side, perturb=0.2, seed=3):
    dx = 1.0 / (n_side - 1)
    ax = np.arange(n_side) * dx
    x = np.stack([a.ravel() for a in np.meshgrid(*[ax] * dim, indexing="ij")], axis=1)
    x = x + perturb * dx * np.random.default_rng(seed).uniform(-1, 1, x.shape)
    x = np.ascontiguousarray(x)
    R = 3.0 * dx
    period = np.zeros(dim)
    nl = build_neighbor_list(x, R, x.min(0) - R, x.max(0) + R, period)
    code = K.kernel_code("wendland_c2")
    return x, np.full(len(x), dx**dim), nl, R, K.kernel_sigma(code, dim, R), code, period


@pytest.mark.parametrize("dim", [2, 3])
def test_strain_rate_of_a_linear_field_is_exact(dim):
    """u = A x + c on a perturbed lattice with free edges: gamma_dot = sqrt(2 D:D),
    D = (A + A^T)/2, at every particle (the renormalised gradient is exact for linear u)."""
    x, vol, nl, R, sig, code, period = _cloud(dim, 9 if dim == 2 else 6)
    A = np.random.default_rng(dim).normal(size=(dim, dim))
    u = x @ A.T + 0.3
    kind = np.full(len(x), FLUID, dtype=np.int8)
    gd, ok = np.zeros(len(x)), np.zeros(len(x), dtype=np.bool_)
    strain_rate(x, u, vol, kind, nl.offsets, nl.indices, R, sig, code, period, 1e8, gd, ok)
    D = 0.5 * (A + A.T)
    assert ok.all()
    np.testing.assert_allclose(gd, math.sqrt(2.0 * np.sum(D * D)), rtol=1e-10)
    # wall neighbours carrying the same linear field (walls=True) keep it exact
    kw = kind.copy()
    kw[x[:, 0] < 0.3] = WALL
    strain_rate(x, u, vol, kw, nl.offsets, nl.indices, R, sig, code, period, 1e8, gd, ok, True)
    np.testing.assert_allclose(gd[kw == FLUID], math.sqrt(2.0 * np.sum(D * D)), rtol=1e-10)
    assert np.all(gd[kw == WALL] == 0.0)
    # simple shear u = (G y, 0): gamma_dot = |G|
    us = np.zeros_like(x)
    us[:, 0] = -4.0 * x[:, 1]
    strain_rate(x, us, vol, kind, nl.offsets, nl.indices, R, sig, code, period, 1e8, gd, ok)
    np.testing.assert_allclose(gd, 4.0, rtol=1e-10)


def test_strain_rate_falls_back_and_skips_other_kinds():
    """A lone fluid particle (singular moment matrix) falls back to the plain gradient
    (flagged, gamma_dot 0, finite); wall rows get 0; wall neighbours count only with
    ``walls``."""
    x = np.array([[0.0, 0.0], [0.1, 0.0], [5.0, 5.0]])
    kind = np.array([FLUID, WALL, FLUID], dtype=np.int8)
    u = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    R, period = 0.3, np.zeros(2)
    nl = build_neighbor_list(x, R, x.min(0) - R, x.max(0) + R, period)
    code = K.kernel_code("wendland_c2")
    gd, ok = np.full(3, -1.0), np.zeros(3, dtype=np.bool_)
    strain_rate(x, u, np.full(3, 0.01), kind, nl.offsets, nl.indices, R,
                K.kernel_sigma(code, 2, R), code, period, 1e8, gd, ok, False)
    assert np.all(gd == 0.0) and not ok[0] and not ok[2] and ok[1]
    strain_rate(x, u, np.full(3, 0.01), kind, nl.offsets, nl.indices, R,
                K.kernel_sigma(code, 2, R), code, period, 1e8, gd, ok, True)
    assert gd[0] > 0.0 and np.isfinite(gd[0]) and not ok[0] and gd[1] == gd[2] == 0.0


def test_registry_scene_keys_and_docs():
    assert set(rheology.REGISTRY.names()) == {"newtonian", "herschel-bulkley", "power-law",
                                              "bingham"}
    from pathlib import Path

    doc = (Path(__file__).parents[1] / "docs" / "scenes.md").read_text()
    for key in ("rheology", "tau0", "gamma_dot_0", "regularisation"):
        assert f"| `{key}` |" in doc
    from sphfem.fluid import FluidParams

    p = FluidParams(rheology="herschel-bulkley", tau0=1.0, k=0.5, n=0.5)
    assert rheology.missing_keys(p) == ("gamma_dot_0",)
    assert rheology.missing_keys(FluidParams(rheology="bingham", tau0=1.0, k=0.5,
                                             gamma_dot_0=1.0)) == ()
    p = FluidParams(rheology="herschel-bulkley", tau0=2.0, k=0.5, n=0.5, gamma_dot_0=0.01)
    assert rheology.max_viscosity(p) == pytest.approx(0.5 * 0.01**-0.5 + 2.0 / 0.01)


SCENE = """
[scene]
name = "ink"
dim = 2
[domain]
lo = [-1.0e-3, -0.4e-3]
hi = [1.0e-3, 1.2e-3]
[sph]
dx = 5.0e-5
[materials.ink]
rho0 = 1000.0
c0 = 20.0
[materials.floor]
rho0 = 1000.0
[[blocks]]
name = "floor"
shape = "box"
kind = "wall"
material = "floor"
lo = [-1.0e-3, -0.15e-3]
hi = [1.0e-3, 0.0]
[[blocks]]
name = "drop"
shape = "sphere"
kind = "fluid"
material = "ink"
center = [0.0, 0.6e-3]
radius = 0.4e-3
[physics]
modules = ["fluid"]
[fluid]
{fluid}
[time]
t_end = 1.0e-3
max_steps = 3
"""
HB_KEYS = 'rheology = "herschel-bulkley"\ntau0 = 20.0\nk = 0.5\nn = 0.5\ngamma_dot_0 = 2.0'


def test_scene_rheology_keys_are_checked(tmp_path):
    from sphfem.scene import SceneError, load_scene

    def load(fluid):
        path = tmp_path / "ink.toml"
        path.write_text(SCENE.format(fluid=fluid))
        return load_scene(path)

    sc = load(HB_KEYS)  # the material needs no mu with a non-Newtonian rheology
    assert (sc.fluid.rheology, sc.fluid.tau0, sc.fluid.regularisation) == (
        "herschel-bulkley", 20.0, "cutoff")
    with pytest.raises(SceneError, match="gamma_dot_0"):
        load(HB_KEYS.replace("gamma_dot_0 = 2.0", ""))
    with pytest.raises(SceneError, match="viscosity"):
        load(HB_KEYS + '\nviscosity = "none"')
    with pytest.raises(SceneError, match="does not apply"):  # Bingham takes no n
        load(HB_KEYS.replace("herschel-bulkley", "bingham"))
    with pytest.raises(SceneError, match="mu"):  # Newtonian still needs the material's mu
        load('rheology = "newtonian"')


def test_resting_ink_has_the_largest_viscosity_and_its_step(tmp_path):
    """A drop at rest on a lattice has no strain rate (exactly, to round-off), so every
    fluid particle takes mu_max = k gd0^(n-1) + tau0/gd0 = 0.5/sqrt(2) + 10 Pa s, and the
    viscous step limit is visc_cfl h^2 rho/mu_max (h = 1.5 dx)."""
    from sphfem.scene import load_scene
    from sphfem.simulation import Simulation

    path = tmp_path / "ink.toml"
    path.write_text(SCENE.format(fluid=HB_KEYS))
    sim = Simulation(load_scene(path), source=str(path))
    summary = sim.run(tmp_path / "out", progress=False)
    ps = sim.particles
    fl = ps.kind == FLUID
    mu_max = 0.5 / math.sqrt(2.0) + 20.0 / 2.0
    assert summary["steps"] == 3
    assert np.all(ps.gamma_dot[fl] < 1e-6 * 2.0)
    np.testing.assert_allclose(ps.mu[fl], mu_max, rtol=1e-12)
    lim = summary["diagnostics"]["fluid"]["dt_limits_s"]["viscous"]
    rho_min = float(ps.rho[fl].min())
    assert lim == pytest.approx(0.125 * (1.5 * 5.0e-5) ** 2 * rho_min / mu_max, rel=1e-12)


def test_short_bingham_channel_against_the_exact_profile():
    """Bingham channel (tau0 = 0.3 tau_w, plug 0.3 H; sphfem.validation.hb_poiseuille) at 10
    particles across, from the regularised model's exact profile to its steady state: within
    12 % (relative L2) of the exact Bingham profile with its plug (9.7 % measured: the
    discretisation error at this resolution, 3 % at 20 across), the centre rows unyielded
    (gamma_dot < gamma_dot_0, mu = mu_max) and moving together within 1 % of u_max."""
    from sphfem.validation import hb_poiseuille as hb

    r = hb.variant(0.3, 1.0, 30.0)
    y, u, gd, mu, s, info = hb.run_hb_channel(10, r, t_end_over_tv=3.0, start="exact")
    assert info["change"] < 1e-3  # steady to the jitter of sliding layers (7e-4 here)
    u_hb = hb.hb_profile(y, hb.H, hb.G, r["tau0"], r["k"], 1.0)
    err = np.sqrt(np.sum((u - u_hb) ** 2) / np.sum(u_hb**2))
    assert err < 0.12
    centre = np.abs(y - 0.5 * hb.H) < 0.1 * hb.H
    mu_max = r["k"] + r["tau0"] / r["gamma_dot_0"]
    assert np.all(gd[centre] < r["gamma_dot_0"])
    np.testing.assert_allclose(mu[centre], mu_max, rtol=1e-12)
    assert np.ptp(u[centre]) < 0.01 * u_hb.max()


def test_axisymmetric_fluid_refuses_a_non_newtonian_rheology():
    """The (r, z) fluid has its own force pass, which does not call the rheology: a
    Herschel-Bulkley scene there must stop at set-up instead of running as a Newtonian
    fluid (it did: the key was accepted and silently ignored)."""
    from test_scene_axisymmetric import droplet_scene

    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    data = droplet_scene()
    data["fluid"].update(rheology="bingham", tau0=10.0, k=0.1, gamma_dot_0=100.0)
    with pytest.raises(ValueError, match="rheology"):
        Simulation(parse_scene(data))
