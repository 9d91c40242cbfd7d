"""The fluid's method registries (issue 15): pressure, viscosity, walls, integrator.

* every registry's methods are the choices of its ``[fluid]`` key, documented in
  docs/scenes.md (generated from the declarations);
* :class:`FluidParams` is derived from the ``[fluid]`` declaration (one field per key, the
  declared default, the declared bounds enforced);
* the worked example of docs/architecture.md, the Morris et al. (1997) viscosity
  (``viscosity = "morris"``, one module plus one registry line): found by the registry,
  listed in docs/scenes.md, its wall reaction is the exact negative of its force on the
  fluid, and the start-up Poiseuille flow matches the series solution.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.scene_section import FLUID, REGISTRIES
from sphfem.fluid.setup import box_walls, lattice, make_particles
from sphfem.fluid.wcsph import RUN_FIELDS
from sphfem.particles import ParticleKind
from sphfem.validation.fluid import poiseuille_series, run_poiseuille

SCENES_MD = Path(__file__).resolve().parents[1] / "docs" / "scenes.md"


def _fluid_rows() -> dict[str, str]:
    """key -> its table row in the [fluid] section of docs/scenes.md."""
    text = SCENES_MD.read_text()
    sec = text[text.index("### `[fluid]`"):]
    sec = sec[:sec.index("\n### ", 5)]
    return {line.split("`")[1]: line for line in sec.splitlines() if line.startswith("| `")}


@pytest.mark.parametrize("key", sorted(REGISTRIES))
def test_each_registry_gives_its_key_choices_defaults_and_docs(key):
    reg = REGISTRIES[key]
    param = FLUID.param(key)
    assert param.choices == reg.names()
    assert param.default in reg.names()
    row = _fluid_rows()[key]
    for name, method in reg.methods().items():
        assert f'`"{name}"`' in row  # listed in docs/scenes.md ...
        assert method.doc[:40].replace("|", "\\|") in row  # ... with its documentation
        for p in method.params:  # a method's own keys exist only for that method
            assert param.when is None and FLUID.param(p.name).when == (key, (name,))
    with pytest.raises(ValueError, match=f"unknown {key}"):
        reg.lookup("no-such-method")


def test_the_default_methods_are_the_ones_before_the_registries():
    defaults = {k: FLUID.param(k).default for k in REGISTRIES}
    assert defaults == {"pressure": "wcsph", "viscosity": "laminar", "surface_tension": "none",
                        "walls": "adami2012", "integrator": "symplectic",
                        "rheology": "newtonian"}


def test_fluid_params_are_derived_from_the_declaration():
    pa = FluidParams()
    for p in FLUID.params:
        assert hasattr(pa, p.name)
        if not callable(p.default):
            assert getattr(pa, p.name) == p.default
    assert set(RUN_FIELDS) <= set(vars(pa))
    with pytest.raises(ValueError, match="visc_cfl"):  # declared gt 0, le 1
        FluidParams(visc_cfl=1.5)
    with pytest.raises(ValueError, match="unknown fluid shifting"):
        FluidParams(shifting="sideways")
    with pytest.raises(ValueError, match="unknown walls"):
        FluidParams(walls="mirror")


def _box_solver(viscosity: str, seed: int = 3):
    """2D fluid block in a walled box, random velocities, one force evaluation."""
    dx = 0.01
    xf = lattice([0.0, 0.0], [0.2, 0.15], dx)
    xw = box_walls([0.0, 0.0], [0.2, 0.2], dx, 3)
    ps = make_particles(xf, xw, dx, 1000.0)
    par = FluidParams(c0=10.0, mu=0.05, gravity=(0.0, 0.0), delta=0.0,
                      viscosity=viscosity)
    s = FluidSolver(ps, 3 * dx, [-0.05, -0.05], [0.25, 0.25], params=par)
    fl = s.p.kind == ParticleKind.FLUID
    rng = np.random.default_rng(seed)
    s.p.v[fl] = rng.normal(0.0, 0.1, (int(fl.sum()), 2))
    s.p.rho[fl] *= 1.0 + 0.01 * rng.standard_normal(int(fl.sum()))
    s.evaluate()
    return s, fl


def test_morris_viscosity_reaction_on_the_walls_balances_the_fluid():
    """Viscous pair forces are antisymmetric: sum_fluid m a_visc + sum_wall f_visc = 0."""
    s, fl = _box_solver("morris")
    s0, _ = _box_solver("none")
    a_visc = s.p.acc[fl] - s0.p.acc[fl]
    wall = s.p.kind == ParticleKind.WALL
    f_visc = s.p.f_fluid[wall] - s0.p.f_fluid[wall]
    on_fluid = (s.p.m[fl, None] * a_visc).sum(axis=0)
    scale = np.abs(s.p.m[fl, None] * a_visc).sum()
    assert scale > 0 and np.abs(f_visc).sum() > 0
    assert np.abs(on_fluid + f_visc.sum(axis=0)).max() < 1e-12 * scale


def test_morris_and_the_fused_laminar_form_agree_to_the_density_factor():
    """m_j (mu_i + mu_j) / (rho_i rho_j) vs 4 m_j (mu_i + mu_j) / (rho_i + rho_j)^2: with
    density ratios within 1 +- 0.03 the two accelerations differ by O(1e-3)."""
    sm, fl = _box_solver("morris")
    sl, _ = _box_solver("laminar")
    s0, _ = _box_solver("none")
    am, al = sm.p.acc[fl] - s0.p.acc[fl], sl.p.acc[fl] - s0.p.acc[fl]
    rel = np.linalg.norm(am - al) / np.linalg.norm(al)
    assert 0.0 < rel < 2e-3


@pytest.mark.parametrize("viscosity", ["morris", "laminar"])
def test_poiseuille_start_up_matches_the_series(viscosity):
    """Body-force channel (Morris et al. 1997 parameters) at t = 0.1 L^2/nu, 20 particles
    across: relative L2 error of u(y) against the transient series below 2 % (the
    validation case's criterion)."""
    L, nu, F = 1e-3, 1e-6, 2e-4
    (t, y, u), = run_poiseuille(20, (0.1,), L, nu, F, viscosity=viscosity)[0]
    exact = poiseuille_series(y, t, L, nu, F)
    err = np.linalg.norm(u - exact) / np.linalg.norm(exact)
    assert math.isfinite(err) and err < 0.02
