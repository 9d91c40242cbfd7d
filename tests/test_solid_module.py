"""The ``tlsph`` physics module through the scene driver: closed-form thermal states, the
explicit / implicit integrators, the driver's reorder hook, the ``[tlsph]`` section."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sphfem.solid  # noqa: F401  (registers the tlsph module and its section)
from sphfem.scene import SceneError, parse_scene_toml
from sphfem.simulation import Simulation, SimulationStopped

ROOT = Path(__file__).resolve().parents[1]
E, NU, ALPHA, DT = 200e9, 0.3, 1e-5, 100.0

BASE = """
[scene]
dim = 2
[domain]
lo = [-0.005, -0.005]
hi = [0.025, 0.01]
[sph]
dx = 0.001
[materials.steel]
rho0 = 7800.0
E = 200e9
nu = 0.3
alpha = 1e-5
[[blocks]]
name = "bar"
shape = "box"
kind = "solid"
material = "steel"
lo = [0.0, 0.0]
hi = [0.02, 0.004]
temperature = {T}
[physics]
modules = ["tlsph"]
[tlsph]
T0 = 293.15
{tlsph}
{bcs}
[time]
t_end = {t_end}
"""

ROLLERS = """
[[tlsph.boundaries]]
block = "bar"
face = "xmin"
condition = "roller"
components = "x"
[[tlsph.boundaries]]
block = "bar"
face = "xmax"
condition = "roller"
components = "x"
"""


def scene(T=293.15 + DT, tlsph='integrator = "relax"', bcs="", t_end=1.0):
    return parse_scene_toml(BASE.format(T=T, tlsph=tlsph, bcs=bcs, t_end=t_end))


def body_arrays(sim):
    ps = sim.particles
    sel = ps.tl_id > 0
    return ps.X0[sel], ps.u[sel], ps.stress[sel].reshape(-1, 3, 3)


def test_free_thermal_expansion_zero_stress(tmp_path):
    """Unsupported bar heated by dT: plane strain x = a X + c with a = 1 + (1 + nu) alpha
    dT + O((alpha dT)^2) (the out-of-plane expansion is constrained), in-plane stress 0,
    sigma_zz = -E alpha dT to first order; exactly (F_e F_theta SVK, v = 1 + alpha dT):
    E_e,zz = (1/v^2 - 1)/2, E_e,xx = -lam E_e,zz / (2 lam + 2 mu), a^2 = v^2 (1 + 2 E_e,xx),
    sigma_zz = v (lam tr E_e + 2 mu E_e,zz) / a^2."""
    sim = Simulation(scene())
    summary = sim.run(tmp_path, progress=False)
    X0, u, st = body_arrays(sim)
    A = np.c_[X0, np.ones(len(X0))]
    grad = np.linalg.lstsq(A, u, rcond=None)[0][:2].T
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    v = 1 + ALPHA * DT
    ez = 0.5 * (1 / v**2 - 1)
    ex = -lam * ez / (2 * lam + 2 * mu)
    a = v * np.sqrt(1 + 2 * ex)
    szz = v * (lam * (2 * ex + ez) + 2 * mu * ez) / a**2
    assert a - 1 == pytest.approx((1 + NU) * ALPHA * DT, rel=2e-3)
    assert np.allclose(np.diag(grad), a - 1, rtol=1e-4)
    assert abs(grad[0, 1]) < 1e-9 and abs(grad[1, 0]) < 1e-9
    ref = E * ALPHA * DT
    assert szz == pytest.approx(-ref, rel=5e-3)
    assert np.abs(st[:, :2, :2]).max() < 1e-4 * ref
    assert np.allclose(st[:, 2, 2], szz, rtol=1e-4)
    d = summary["diagnostics"]["tlsph"]
    assert d["integrator"] == "relax" and d["relax_residual"] <= 1e-6
    assert d["B0_fallbacks"] == 0 and d["particles"] == 80


def test_clamped_bar_thermal_stress_and_vtu(tmp_path):
    """Bar held in x at both ends (3 layers), free in y: sigma_xx = -E alpha dT / (1 - nu)
    (plane strain), sigma_yy = 0; the VTU output carries stress and von Mises."""
    import meshio

    sim = Simulation(scene(bcs=ROLLERS))
    summary = sim.run(tmp_path, progress=False)
    X0, u, st = body_arrays(sim)
    inner = (X0[:, 0] > 0.005) & (X0[:, 0] < 0.015)
    sxx = st[inner, 0, 0]
    exact = -E * ALPHA * DT / (1 - NU)
    assert np.allclose(sxx, exact, rtol=5e-3)
    assert np.abs(st[inner, 1, 1]).max() < 1e-3 * abs(exact)
    d = summary["diagnostics"]["tlsph"]
    assert [b["particles"] for b in d["boundaries"]] == [12, 12]
    assert d["held_components"] == 24
    assert d["max_von_mises_Pa"] > 0.9 * abs(exact)
    m = meshio.read(sorted(tmp_path.glob("particles_*.vtu"))[-1])
    assert m.point_data["stress"].shape == (80, 9)
    assert np.allclose(m.point_data["von_mises"], sim.particles.von_mises)


VERLET_BCS = """
[[tlsph.boundaries]]
block = "bar"
face = "xmin"
condition = "clamp"
[[tlsph.boundaries]]
block = "bar"
face = "xmax"
condition = "traction"
traction = [0.0, -2e6]
"""


def _verlet_run(perm_at=None, steps=60, hourglass=10.0):
    sim = Simulation(scene(T=293.15, tlsph=f'integrator = "verlet"\nhourglass = {hourglass}',
                           bcs=VERLET_BCS, t_end=1.0))
    mod = sim.modules[0]
    rng = np.random.default_rng(1)
    dt, name = sim.stable_dt()
    assert name == "tlsph.explicit"
    for k in range(steps):
        if k == perm_at:
            perm = rng.permutation(sim.particles.n)
            sim.particles.reorder(perm)
            for m in sim.modules:
                m.reorder(sim.ctx, perm)
            sim.update_neighbors()
        sim.step(dt)
    return sim, mod


def test_verlet_energy_and_reorder():
    """Undamped Verlet (cfl 0.8) of a cantilever under a suddenly applied end traction at
    constant temperature, no hourglass control: kinetic + strain - f_ext.u is conserved to
    1e-3 (the hourglass forces are not exactly conservative: with them the balance is only
    bounded).  Permuting the particle set mid-run (the driver's cell sort) changes nothing:
    the reference data follow through tl_id."""
    sim, mod = _verlet_run(hourglass=0.0)
    d = mod.diagnostics(sim.ctx)
    e = d["energy"]
    assert e["kinetic_J"] > 0.05 * e["strain_J"] > 0 and e["hourglass_J"] == 0.0
    assert e["max_abs_drift_J"] < 1e-3 * e["strain_J"]
    assert d["explicit_stable_dt_s"] == pytest.approx(0.8 * 2 / d["omega_max_rad_s"])
    sim, mod = _verlet_run()
    assert mod.diagnostics(sim.ctx)["energy"]["hourglass_J"] > 0
    sim2, _ = _verlet_run(perm_at=25)
    a = sim.particles
    b = sim2.particles
    ia, ib = np.argsort(a.id), np.argsort(b.id)
    assert not np.array_equal(a.id, b.id)
    assert np.allclose(a.x[ia], b.x[ib], rtol=0, atol=1e-15)
    assert np.allclose(a.stress[ia], b.stress[ib], rtol=1e-9, atol=1e-3)


def test_trapezoid_converges_fails_clearly_and_substeps(tmp_path):
    ok = Simulation(scene(T=293.15, tlsph='integrator = "trapezoid"\ncfl = 0.5',
                          bcs=VERLET_BCS, t_end=1.0))
    dt, _ = ok.stable_dt()
    for _ in range(5):
        ok.step(dt)
    d = ok.modules[0].diagnostics(ok)
    assert d["steps"] == 5 and 1 <= d["max_iterations"] < 200 and d["fallbacks"] == 0
    big = 100 * ok.modules[0].dt_explicit
    stop = scene(T=293.15, tlsph=f'integrator = "trapezoid"\ndt = {big}\nmax_iter = 30',
                 bcs=VERLET_BCS, t_end=2 * big)
    (tmp_path / "stop").mkdir()
    (tmp_path / "sub").mkdir()
    with pytest.raises(SimulationStopped, match="did not converge"):
        Simulation(stop).run(tmp_path / "stop", progress=False)
    sub = scene(T=293.15, tlsph=f'integrator = "trapezoid"\ndt = {big}\nmax_iter = 30\n'
                                'on_failure = "substep"', bcs=VERLET_BCS, t_end=big)
    s = Simulation(sub).run(tmp_path / "sub", progress=False)
    d = s["diagnostics"]["tlsph"]
    assert s["status"] == "completed" and d["fallbacks"] == 1
    assert d["fallback_substeps"] == int(np.ceil(big / d["explicit_stable_dt_s"]))


@pytest.mark.parametrize("change, key", [
    ('[[tlsph.boundaries]]\nblock = "bar"\nface = "xmin"\ncondition = "roller"',
     "tlsph.boundaries[0].components"),
    ('[[tlsph.boundaries]]\nblock = "nope"\nface = "xmin"\ncondition = "clamp"',
     "tlsph.boundaries[0].block"),
    ('[[tlsph.boundaries]]\nblock = "bar"\nface = "xmin"\ncondition = "traction"',
     "tlsph.boundaries[0].traction"),
])
def test_section_errors(change, key):
    with pytest.raises(SceneError, match=key.replace("[", r"\[").replace("]", r"\]")):
        scene(bcs=change)


def test_section_heat_order_and_kind():
    text = BASE.format(T=300.0, tlsph="", bcs="", t_end=1.0)
    with pytest.raises(SceneError, match="heat"):
        parse_scene_toml(text.replace('modules = ["tlsph"]', 'modules = ["tlsph", "heat"]')
                         .replace("alpha = 1e-5", "alpha = 1e-5\nc = 1.0\nk = 1.0"))
    with pytest.raises(SceneError, match="solid"):
        parse_scene_toml(text.replace('kind = "solid"', 'kind = "wall"'))


def test_example_bar_heated_runs(tmp_path):
    """The example scene (heat + tlsph) loads and takes a step."""
    from sphfem.scene import load_scene

    sc = load_scene(ROOT / "examples" / "tlsph" / "bar_heated.toml")
    sim = Simulation(sc)
    dt, name = sim.stable_dt()
    assert dt == 5.0
    sim.step(dt)
    d = sim.modules[1].diagnostics(sim.ctx)
    assert d["relax_residual"] <= 1e-6 and d["held_components"] == 60
    T = sim.particles.T[sim.particles.tl_id > 0]
    assert T.max() > 330.0 and sim.particles.von_mises.max() > 1e7
