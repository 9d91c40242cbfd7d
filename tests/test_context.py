"""The seam between the driver and the physics modules (issue 15, docs/architecture.md):
modules see a ``StepContext``; particles a module needs are returned from ``init`` and
appended by the driver (one list rebuild); a moving module asks the context for a valid
list; a resumed run drops the appended ghosts and the module places them anew."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
from builders import periodic_box_toml

from sphfem.context import StepContext
from sphfem.particles import GHOST, SOLID, ParticleSet
from sphfem.physics import MODULES, PhysicsModule
from sphfem.scene import parse_scene_toml
from sphfem.schema import register_module, unregister
from sphfem.simulation import Simulation

ROD = """
[scene]
name = "rod"
dim = 1
[domain]
lo = [-0.1]
hi = [1.1]
[sph]
dx = 0.0125
[materials.rod]
rho0 = 1.0
c = 1.0
k = 1.0
[[blocks]]
name = "rod"
shape = "box"
kind = "solid"
material = "rod"
lo = [0.0]
hi = [1.0]
temperature = 300.0
[physics]
modules = ["heat"]
[heat]
laplacian = "fatehi_manzari"
[[heat.boundaries]]
block = "rod"
face = "xmin"
condition = "dirichlet"
temperature = 300.0
[[heat.boundaries]]
block = "rod"
face = "xmax"
condition = "dirichlet"
temperature = 301.0
[time]
t_end = 4.0e-3
{max_steps}
[output]
every = 1.0e-3
fields = ["T"]
"""

def _box(modules, steps: int):
    """The periodic unit box (:func:`builders.periodic_box`) of a mechanical material,
    list rebuilt and cell-sorted at every step, run for ``steps`` steps."""
    return parse_scene_toml(periodic_box_toml(
        modules, name="box", sph={"skin": 0.2, "sort_every": 1}, material={"rho0": 1.0},
        time={"t_end": 1.0, "max_steps": steps}, output={}), "b.toml")


def _brute_pairs(x, R, period):
    """Every ordered pair (i, j), i != j, with |x_i - x_j| <= R (minimum image)."""
    d = x[:, None, :] - x[None, :, :]
    per = np.asarray(period, float)
    d -= np.where(per > 0, per * np.round(d / np.where(per > 0, per, 1.0)), 0.0)
    r = np.sqrt((d * d).sum(axis=2))
    np.fill_diagonal(r, np.inf)
    return {(int(i), int(j)) for i, j in zip(*np.nonzero(r <= R), strict=True)}


def _listed(nl, R, x, period):
    """The listed ordered pairs closer than R (a skin list holds farther ones too)."""
    rows = np.repeat(np.arange(nl.n), np.diff(nl.offsets))
    close = _brute_pairs(x, R, period)
    return {(int(i), int(j)) for i, j in zip(rows, nl.indices, strict=True)} & close, close


# -- particles requested by init --------------------------------------------------------


def test_heat_ghosts_are_appended_by_the_driver_with_one_rebuild():
    """The rod's Dirichlet ends need ghosts: heat returns them from init, the driver
    appends them after the real particles and rebuilds the list once (first list + one),
    and the heat system is built on that list."""
    sim = Simulation(parse_scene_toml(ROD.format(max_steps=""), "rod.toml"))
    heat = sim.modules[0]
    ps = sim.particles
    n_ghost = int(np.count_nonzero(ps.kind == GHOST))
    assert n_ghost == heat.ghosts.n > 0
    assert np.all(ps.kind[: ps.n - n_ghost] != GHOST)  # appended at the end
    assert np.all(ps.kind[heat._ghost_index] == GHOST)
    assert sim.rebuilds == 2 and sim.nbrs_version == 2
    assert heat._nbrs_version == sim.nbrs_version and sim.nbrs.n == ps.n


class _Appender(PhysicsModule):
    """Returns copies of the first three particles from init, of kind ``KIND``."""

    name = "appender"
    KIND = GHOST

    def init(self, ctx):
        self.version_at_init = ctx.nbrs_version
        self.n_at_init = ctx.particles.n
        p = ctx.particles
        return ParticleSet.from_arrays(p.x[:3] + 0.01, m=p.m[:3], kind=self.KIND,
                                       material=0)

    def appended(self, ctx, index):
        self.index = index
        self.version_at_appended = ctx.nbrs_version

    def dt_limits(self, ctx):
        return {"appender": 1.0}

    def step(self, ctx, dt):
        pass


class _RealAppender(_Appender):
    name = "real_appender"
    KIND = SOLID


@pytest.fixture
def toy_modules():
    names = {"appender": "test_context:_Appender", "real_appender": "test_context:_RealAppender",
             "jumper": "test_context:_Jumper"}
    for name, target in names.items():
        register_module(name, target=target)
    yield
    for name in names:
        unregister(name)
        MODULES.pop(name, None)


def test_appended_hook_gets_the_new_indices_after_one_rebuild(toy_modules):
    sim = Simulation(_box(["appender"], 1))
    mod = sim.modules[0]
    n0 = mod.n_at_init
    np.testing.assert_array_equal(mod.index, np.arange(n0, n0 + 3))
    assert sim.particles.n == n0 + 3 and np.all(sim.particles.kind[mod.index] == GHOST)
    assert mod.version_at_appended == mod.version_at_init + 1 == sim.nbrs_version
    assert sim.nbrs.n == sim.particles.n


def test_only_ghosts_may_be_appended(toy_modules):
    """Real particles come from the scene's blocks; a module asking to append some is a
    programming error, reported with the module's name."""
    with pytest.raises(ValueError, match="real_appender.*ghosts"):
        Simulation(_box(["real_appender"], 1))


def test_resumed_run_places_the_ghosts_anew_and_ends_equal(tmp_path):
    """A run stopped at max_steps (checkpoint kept) and resumed ends equal (1e-12) to an
    uninterrupted one, with the same ghosts: the driver drops the checkpoint's ghosts and
    heat's init places them again."""
    ref = Simulation(parse_scene_toml(ROD.format(max_steps=""), "rod.toml"))
    s_ref = ref.run(tmp_path / "ref", progress=False)
    cut_scene = parse_scene_toml(ROD.format(max_steps=f"max_steps = {s_ref['steps'] // 2}"),
                                 "rod.toml")
    s_cut = Simulation(cut_scene).run(tmp_path / "cut", progress=False)
    assert s_cut["status"] == "max_steps" and s_cut["checkpoint"] is not None
    res = Simulation(parse_scene_toml(ROD.format(max_steps=""), "rod.toml"))
    s_res = res.run(tmp_path / "cut", progress=False, resume=True)
    assert s_res["resumed"] is not None and s_res["steps"] == s_ref["steps"]
    a, b = ref.particles, res.particles
    assert a.n == b.n and np.count_nonzero(b.kind == GHOST) == res.modules[0].ghosts.n
    ia, ib = np.argsort(a.x[:, 0] + 10 * (a.kind == GHOST)), np.argsort(
        b.x[:, 0] + 10 * (b.kind == GHOST))
    np.testing.assert_array_equal(a.x[ia], b.x[ib])
    np.testing.assert_allclose(b.T[ib], a.T[ia], rtol=1e-12, atol=0)


# -- lists ------------------------------------------------------------------------------


class _Jumper(PhysicsModule):
    """Moves every particle by 0.3 R along x inside its step (three times the skin test's
    0.1 R) and asks the context for a valid list after the move."""

    name = "jumper"
    moves_particles = True

    def init(self, ctx):
        self.checks = []

    def dt_limits(self, ctx):
        return {"jumper": 1.0}

    def step(self, ctx, dt):
        before = ctx.nbrs_version
        x = ctx.particles.x
        x[:, 0] = np.mod(x[:, 0] + 0.3 * ctx.R, 1.0)
        nl = ctx.neighbors()
        listed, close = _listed(nl, ctx.R, ctx.particles.x, ctx.period)
        self.checks.append((ctx.nbrs_version - before, listed == close, nl is ctx.nbrs))


def test_a_moving_module_gets_a_valid_list_mid_step(toy_modules):
    sim = Simulation(_box(["jumper"], 3))
    for _ in range(3):
        sim.step(1.0)
    checks = sim.modules[0].checks
    assert [c[0] for c in checks] == [1, 1, 1]  # one new list per mid-step request
    assert all(c[1] and c[2] for c in checks)  # every pair closer than R listed


def test_a_hand_made_context_builds_its_own_list():
    """Without a driver (tests, a stand-alone runner) the context builds a list of radius
    R on request; the version counts the builds."""
    g = np.arange(0.0, 1.0, 0.1)
    x = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    ps = ParticleSet.from_arrays(x, m=0.01, kind=SOLID)
    period = np.array([1.0, 0.0])
    ctx = StepContext(ps, R=0.23, sigma=1.0, kernel_code=0, kernel="wendland_c2",
                      lo=np.zeros(2), hi=np.ones(2), period=period, materials={})
    nl = ctx.neighbors()
    listed, close = _listed(nl, 0.23, x, period)
    assert ctx.nbrs_version == 1 and nl.n_pairs == len(close) and listed == close
    assert ctx.neighbors() is nl and ctx.nbrs_version == 1  # valid: kept
    ps.x[:, 1] *= 0.5
    nl2 = ctx.neighbors(rebuild=True)
    assert ctx.nbrs_version == 2 and nl2.n_pairs == len(_brute_pairs(ps.x, 0.23, period))


# -- material constants come from the scene ---------------------------------------------


def test_coupling_takes_c0_from_the_fluid_materials():
    """The coupling's time scale uses the fluid's c0 (the materials of the fluid blocks),
    not another material's, and falls back to the largest declared c0."""
    from coupling.driver import fluid_c0

    mats = {"water": SimpleNamespace(c0=50.0), "steel": SimpleNamespace(c0=5000.0),
            "air": SimpleNamespace(c0=None)}
    blocks = [SimpleNamespace(kind="fluid", material="water"),
              SimpleNamespace(kind="solid", material="steel")]
    assert fluid_c0(SimpleNamespace(blocks=blocks), mats) == 50.0
    assert fluid_c0(SimpleNamespace(blocks=blocks[1:]), mats) == 5000.0
    assert fluid_c0(SimpleNamespace(blocks=[]), {"air": mats["air"]}) is None


def test_the_summary_reports_each_module_through_the_context(tmp_path):
    sim = Simulation(parse_scene_toml(ROD.format(max_steps=""), "rod.toml"))
    sim.run(tmp_path, progress=False)
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["particles"]["ghost"] == sim.modules[0].ghosts.n
    assert d["diagnostics"]["heat"]["system_builds"] == 1  # nothing moved: built once
