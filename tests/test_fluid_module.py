"""The fluid as a physics module of the driver: shared Verlet-skin list, reorder hook,
the [fluid] scene section, a fluid + heat scene, the dam-break example scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sphfem.fluid import FluidSolver
from sphfem.fluid.passes import filter_rows
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID, GHOST, SOLID, WALL
from sphfem.scene import SceneError, load_scene, parse_scene_toml
from sphfem.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]

SCENE = """
[scene]
name = "fluid_heat"
dim = 2
[domain]
lo = [-0.02, -0.02]
hi = [0.14, 0.2]
[sph]
dx = 0.005
skin = {skin}
sort_every = 1
[materials.water]
rho0 = 1000.0
mu = 1.0e-3
c0 = 15.0
c = 4186.0
k = 0.6
[materials.steel]
rho0 = 7850.0
c = 500.0
k = 50.0
[[blocks]]
name = "column"
shape = "box"
kind = "fluid"
material = "water"
lo = [0.0, 0.0]
hi = [0.05, 0.1]
velocity = [0.5, 0.0]
temperature = 350.0
[[blocks]]
name = "floor"
shape = "box"
kind = "wall"
material = "steel"
lo = [-0.015, -0.015]
hi = [0.115, 0.0]
temperature = 300.0
[[blocks]]
name = "left"
shape = "box"
kind = "wall"
material = "steel"
lo = [-0.015, 0.0]
hi = [0.0, 0.1]
temperature = 300.0
[physics]
modules = {modules}
[fluid]
gravity = [0.0, -9.81]
alpha = 0.02
[time]
t_end = 0.01
dt = 1.0e-4
max_steps = {steps}
"""


def _scene(modules=("fluid", "heat"), steps=40, skin=0.02):
    mods = "[" + ", ".join(f'"{m}"' for m in modules) + "]"
    return parse_scene_toml(SCENE.format(modules=mods, steps=steps, skin=skin), "mem.toml")


def test_filter_rows_keeps_only_fluid_pairs():
    rng = np.random.default_rng(0)
    x = rng.random((300, 2))
    kind = rng.choice(np.array([FLUID, WALL, SOLID, GHOST], np.int8), 300)
    nl = build_neighbor_list(x, 0.15, [0.0, 0.0], [1.0, 1.0])
    off, idx = filter_rows(nl.offsets, nl.indices, kind)
    for i in range(300):
        got = set(idx[off[i]:off[i + 1]].tolist())
        full = nl.indices[nl.offsets[i]:nl.offsets[i + 1]]
        if kind[i] == FLUID:
            want = {j for j in full if kind[j] in (FLUID, WALL)}
        elif kind[i] == WALL:
            want = {j for j in full if kind[j] == FLUID}
        else:
            want = set()
        assert got == want


def test_fluid_heat_scene_through_simulation(tmp_path):
    """Fluid + heat for a few steps: the column slides and falls, heat flows from the hot water into
    the cold wall, the heat energy is conserved, the list is rebuilt and re-sorted."""
    sim = Simulation(_scene())
    ps0 = sim.particles
    T0 = ps0.T.copy()
    id_fluid = set(ps0.id[ps0.kind == FLUID].tolist())
    (tmp_path / "out").mkdir()
    summary = sim.run(tmp_path / "out", progress=False)
    ps = sim.particles
    assert summary["status"] == "max_steps" and summary["steps"] == 40
    assert sim.rebuilds > 3  # skin 0.02: several rebuilds (each with a cell sort)
    d = summary["diagnostics"]["fluid"]
    assert d["guards"]["status"] == "ok"
    assert set(d["dt_limits_s"]) >= {"acoustic", "viscous", "force"}
    # impulsive start away from the left wall: a rarefaction of |drho/rho| ~ v/c0 = 3.3 %
    assert 1 - 1.5 * 0.5 / 15 < d["rho_ratio_range"][0] <= d["rho_ratio_range"][1] < 1.02
    fl = ps.kind == FLUID
    assert set(ps.id[fl].tolist()) == id_fluid
    assert d["max_speed"] > 0.5  # sliding at 0.5 m/s and falling
    # heat: water cooled, wall warmed, nothing created (Cleary form conserves sum m c T)
    assert ps.T[fl].min() < 350.0 - 1e-3 and ps.T[ps.kind == WALL].max() > 300.0 + 1e-3
    h = summary["diagnostics"]["heat"]
    assert abs(h["energy_drift_rel"]) < 1e-12
    assert T0.max() == 350.0


def test_driven_equals_standalone():
    """The module on the shared list (with rebuilds and cell sorts mid-step) and the
    stand-alone solver on its own list run the same passes: same trajectories."""
    sim = Simulation(_scene(modules=("fluid",), steps=30))
    ref = sim.particles.select(np.ones(sim.particles.n, bool))
    for _ in range(30):
        sim.step(1.0e-4)
    p = sim.modules[0].solver.params
    from dataclasses import replace

    s = FluidSolver(ref, sim.R, sim.lo, sim.hi, sim.period, replace(p, skin=0.3, sort_every=0))
    for _ in range(30):
        s.step(1.0e-4)
    a = sim.particles
    ia, ib = np.argsort(a.id), np.argsort(ref.id)
    assert sim.rebuilds > 3
    np.testing.assert_allclose(a.x[ia], ref.x[ib], rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.rho[ia], ref.rho[ib], rtol=1e-12)


def test_fluid_section_errors():
    text = SCENE.format(modules='["fluid"]', steps=1, skin=0.1)
    with pytest.raises(SceneError, match=r"materials\.water\.c0: missing"):
        parse_scene_toml(text.replace("c0 = 15.0\n", ""), "s.toml")
    with pytest.raises(SceneError, match=r"fluid\.rho_ratio_band"):
        parse_scene_toml(text.replace("alpha = 0.02", "rho_ratio_band = [1.1, 1.2]"), "s.toml")
    with pytest.raises(SceneError, match=r"fluid\.gravty: unknown key.*did you mean 'gravity'"):
        parse_scene_toml(text.replace("gravity =", "gravty ="), "s.toml")


def test_dam_break_example_scene_parses():
    sc = load_scene(ROOT / "examples" / "scenes" / "dam_break_2d.toml")
    assert sc.physics.modules == ("fluid",)
    assert sc.fluid.gravity == (0.0, -9.81)
    fl = [b for b in sc.blocks if b.kind == "fluid"]
    (lo, hi), = [(b.lo, b.hi) for b in fl]
    assert hi[1] - lo[1] == pytest.approx(2 * (hi[0] - lo[0]))  # H x 2H column


def test_fluid_packing_from_a_scene():
    """[fluid.packing]: the fluid block is packed once before the first step (reported in
    the diagnostics); below the free boundaries the packing force over fluid + walls is
    below the tolerance, the column left its lattice, nothing entered a wall."""
    from sphfem import kernels

    text = SCENE.format(modules='["fluid"]', steps=1, skin=0.1)
    text += "[fluid.packing]\niterations = 20000\ntolerance = 1e-6\n"
    sc = parse_scene_toml(text, "pack.toml")
    assert sc.fluid.packing.iterations == 20000 and sc.fluid.packing.jitter == 0.1
    lattice_sim = Simulation(_scene(modules=("fluid",), steps=1))
    sim = Simulation(sc)
    d = sim.modules[0].diagnostics(sim)["packing"]
    assert d["converged"] and d["residual"] <= 1e-6 and d["max_shift_over_dx"] > 0.1
    ps = sim.particles
    fl = ps.kind == FLUID
    x, xw, dx, R = ps.x[fl], ps.x[ps.kind == WALL], sc.sph.dx, sim.R
    assert fl.sum() == (lattice_sim.particles.kind == FLUID).sum()
    allx = np.concatenate([x, xw])
    d_ = x[:, None, :] - allx[None, :, :]
    r = np.sqrt((d_**2).sum(-1))
    q = np.minimum(r / R, 1.0)
    sig = kernels.kernel_sigma(kernels.WENDLAND_C2, 2, R)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where((r > 0) & (r < R), sig * (-20 * q * (1 - q) ** 3) / R / r, 0.0) * dx * dx
    g = (f[..., None] * d_).sum(1)
    inner = (x[:, 0] < 0.05 - R - dx) & (x[:, 1] < 0.1 - R - dx)  # free: right and top
    assert inner.sum() > 20
    assert np.sqrt((g[inner] ** 2).sum(1)).max() * R < 1e-5
    assert (x[:, 0] > 0).all() and (x[:, 1] > 0).all()
    with pytest.raises(SceneError, match=r"fluid\.packing\.jitter"):
        parse_scene_toml(text.replace("tolerance = 1e-6", "jitter = 0.9"), "pack.toml")
