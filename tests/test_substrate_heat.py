"""[coupling.heat] model = "fem-contact" (coupling/substrate_heat.py): a hot water slab at
rest on an alumina substrate through the full coupled driver (heat + coupling modules)
against the contact of two semi-infinite bodies, and the scene errors of the sub-table."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from test_coupling import HOT  # the hot water block on alumina of the SPH-heat path

#: the same scene with the FEM contact heat, every step coupled, a fine time step
SLAB = (HOT.replace("every_k_steps = 3", "every_k_steps = 1")
        .replace("vtu_every = 2", "vtu_every = 0")
        .replace("[coupling.mesh]", '[coupling.heat]\nmodel = "fem-contact"\n\n[coupling.mesh]')
        .replace("t_end = 6e-4", "t_end = 1.0e-6\ndt = 0.1e-6"))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))


def test_fem_contact_slab_matches_the_contact_solution(tmp_path, cache):
    """Water (100 C) at rest on alumina (20 C), dx = 25 um: both thermal layers stay far
    below dx (water sqrt(alpha t) <= 0.4 um).  Exact (Carslaw & Jaeger sec. 2.15): interface
    at T_i = (e_f T_f + e_s T_s)/(e_f + e_s) = 36.50 C at once, heat 2 C sqrt(t) per area.
    Checked: heat lost by the fluid particles = heat gained by the FEM to round-off; the
    surface temperature under the slab's centre within 2 % of the contact rise from the
    second coupling step (0.2 us) on (measured: +9.0 % after the first backward-Euler step
    of 0.1 us, then +1.4, +0.2, -0.2 ... -0.4 %); the heat within 3 % of the ideal contact
    over the wetted nodes at every step (measured -2.3 % first, -0.8 % at 1 us); the SPH
    substrate particles exchange nothing (SPH wall conduction off)."""
    from sphfem.api import run
    from sphfem.particles import FLUID
    from sphfem.scene import parse_scene_toml

    for edit in ('model = "fem-contact"', "every_k_steps = 1", "dt = 0.1e-6"):
        assert edit in SLAB  # HOT still has the lines SLAB edits
    res = run(parse_scene_toml(SLAB), tmp_path / "out")
    d = res.summary["diagnostics"]["coupling"]["substrate_heat"]
    ef, es = math.sqrt(0.6 * 1000 * 4000), math.sqrt(10 * 3950 * 900)
    Tf, Ts = 373.15, 293.15
    Ti = (ef * Tf + es * Ts) / (ef + es)
    assert d["ideal_contact_temperature_K"] == pytest.approx(Ti, rel=1e-14)
    q = d["heat_to_substrate_J"]
    assert q > 0.01  # J per m of depth
    assert abs(d["interface"]["balance_rel"]) < 1e-12
    assert abs(d["fluid_substrate_residual_rel"]) < 1e-11  # measured 4e-15
    assert abs(d["substrate_energy_gain_J"] - q) < 1e-10 * q
    assert abs(d["energy_residual_J"]) < 1e-10 * q
    h = d["history"]
    assert len(h) == 10 and d["interface"]["steps"] == 10
    eT = np.array([(r["T_impact"] - Ts) / (Ti - Ts) - 1.0 for r in h])
    eQ = np.array([r["heat_to_substrate_J"] / r["ideal_contact_heat_J"] - 1.0 for r in h])
    assert np.all(np.abs(eT[1:]) < 0.02), eT
    assert np.all(np.abs(eQ) < 0.03), eQ
    # the wetted nodes are those under the slab (0.4 mm of 1 mm, h_lateral = dx/2)
    assert h[-1]["wetted_area"] == pytest.approx(0.4e-3, rel=0.05)
    ps = res.particles
    sub = (ps.kind != FLUID) & (ps.material == 1)
    assert np.all(ps.T[sub] == Ts)  # no SPH wall conduction: the region keeps T0
    # the stress substrate's thermal load is the FEM heat field: surface probe ~ T_i
    top = res.summary["diagnostics"]["coupling"]["last"]["probes"][0]
    assert top["T"] > Ts + 0.5 * (Ti - Ts)


@pytest.mark.parametrize("old, new, key", [
    ('model = "fem-contact"', 'model = "fem"', "coupling.heat.model"),
    ('model = "fem-contact"', 'model = "fem-contact"\ngrowth = 0.9', "coupling.heat.growth"),
    ('model = "fem-contact"', 'model = "fem-contact"\nlateral = [[1e-4, -1e-4]]',
     "coupling.heat.lateral"),
    ('model = "fem-contact"', 'model = "fem-contact"\nh_surfce = 1e-7', "coupling.heat"),
    ('model = "fem-contact"', 'model = "sph"\nh_surface = 1e-7', "coupling.heat.h_surface"),
    ('model = "fem-contact"', 'model = "fem-contact"\ndepth = -1e-5', "coupling.heat.depth"),
    ('modules = ["heat", "coupling"]', 'modules = ["coupling"]', "coupling.heat.model"),
    ("[coupling]\n", '[coupling]\nbackend = "tlsph"\n', "coupling.heat.model"),
    ("k = 0.6\n", "", "materials.water.k"),
])
def test_fem_contact_scene_errors_name_the_key(old, new, key):
    from sphfem.scene import SceneError, parse_scene_toml

    assert old in SLAB
    with pytest.raises(SceneError, match=re.escape(key)):
        parse_scene_toml(SLAB.replace(old, new, 1))


def test_heat_defaults_follow_the_layer():
    """depth = 8 sqrt(alpha_s t_end), first cell sqrt(alpha_s t_end / 100) / 3, lateral
    dx / 2 and the SPH region's extent (droplet job: 25.5 um, 0.106 um, 3.125 um)."""
    from types import SimpleNamespace

    from coupling.substrate_heat import heat_defaults

    h = SimpleNamespace(lateral=None, depth=None, h_surface=None, h_lateral=None, growth=1.15)
    p = heat_defaults(h, 3, 6.25e-6, 3.6e-6, 10.0, 3950.0, 900.0, [-1, -2, -3], [1, 2, 0])
    a = 10.0 / (3950 * 900)
    assert p["depth"] == pytest.approx(8 * math.sqrt(a * 3.6e-6), rel=1e-14)
    assert p["h_surface"] == pytest.approx(math.sqrt(a * 3.6e-8) / 3, rel=1e-14)
    assert p["h_lateral"] == 3.125e-6 and p["lateral"] == ((-1.0, 1.0), (-2.0, 2.0))


@pytest.mark.parametrize("lateral", [[(-1e-4, 1e-4)], [(-1e-4, 1e-4), (-5e-5, 5e-5)]])
def test_tensor_probe_is_the_p1_interpolant(lateral):
    """TensorProbe equals scikit-fem's probes (the P1 interpolant) to round-off on a
    graded tensor mesh (2D and 3D), exact at nodes; every row sums to 1."""
    from coupling.substrate_heat import TensorProbe
    from sphfem.fem.heat_transient import TransientHeat, graded_mesh

    m = graded_mesh(lateral, 2e-5, 1e-7, 1.2, h_lateral=1e-5)
    h = TransientHeat(m, 10.0, 3950.0, 900.0, 0.0)
    lo, hi = m.p.min(axis=1), m.p.max(axis=1)
    X = lo + (hi - lo) * np.random.default_rng(0).random((300, m.p.shape[0]))
    X[:5] = m.p[:, :5].T
    h.T = 1.0 + 2.0 * m.p[0] / 1e-4 + 3.0 * np.sin(m.p[-1] / 1e-6)
    P = TensorProbe(m)(X)
    assert np.abs(P @ h.T - h.probe(X)).max() < 1e-12
    assert np.abs(np.asarray(P.sum(axis=1)).ravel() - 1.0).max() < 1e-14
    assert np.allclose(P[:5] @ h.T, h.T[:5], rtol=0, atol=1e-13)
