"""The driver: outputs and summary, the shared Verlet-skin neighbour list, cell re-sorting,
and the CLI's refusal of malformed scenes and existing output folders."""

import json

import numpy as np
import pytest
from builders import UNIT_MATERIAL, periodic_box_toml, solid_box

from sphfem.cli import main
from sphfem.geometry import build_particles
from sphfem.physics import MODULES, PhysicsModule
from sphfem.scene import parse_scene_toml
from sphfem.schema import register_module, unregister
from sphfem.simulation import Simulation


def _scene_text(modules=("heat",), **kw) -> str:
    """The periodic unit box (:func:`builders.periodic_box`) with a list rebuilt and
    cell-sorted at every step."""
    return periodic_box_toml(modules, sph={"sort_every": 1, "skin": 0.2}, **kw)


class Drift(PhysicsModule):
    """Test module: translates every particle with a constant velocity (periodic wrap)."""

    name = "drift"
    moves_particles = True
    velocity = np.array([37.0, -21.0])

    def dt_limits(self, ctx):
        return {"drift": 0.5 * ctx.R / np.linalg.norm(self.velocity)}

    def step(self, ctx, dt):
        x = ctx.particles.x
        x += dt * self.velocity
        np.mod(x, 1.0, out=x)


@pytest.fixture
def drift_module():
    register_module("drift", target="test_simulation:Drift")
    yield
    unregister("drift")
    MODULES.pop("drift", None)


def _initial_field(ps):
    x = ps.x
    return 300.0 + np.sin(2 * np.pi * x[:, 0]) * np.cos(2 * np.pi * x[:, 1])


def test_translation_invariance_through_rebuilds_and_resorting(drift_module, tmp_path):
    """Heat conduction in a periodic box is unchanged by a uniform drift of all particles,
    although the drift forces neighbour rebuilds and cell re-sorts (module reorder hooks)."""
    results = {}
    for mods in (["heat"], ["drift", "heat"]):
        scene = parse_scene_toml(_scene_text(mods), "mem.toml")
        ps = build_particles(scene)
        ps.T[:] = _initial_field(ps)
        sim = Simulation(scene, particles=ps)
        out = tmp_path / "_".join(mods)
        out.mkdir()
        summary = sim.run(out, progress=False)
        order = np.argsort(sim.particles.id)
        results[tuple(mods)] = (sim.particles.T[order], summary, sim)
    T0, s0, _ = results[("heat",)]
    T1, s1, sim1 = results[("drift", "heat")]
    assert sim1.rebuilds > 3  # the drift crossed the skin several times
    assert s1["steps"] == s0["steps"] == 100  # the fixed [time] dt controls both runs
    # same physics: only the summation order of the pair sums differs
    np.testing.assert_allclose(T1, T0, rtol=0, atol=1e-11)
    assert abs(s1["diagnostics"]["heat"]["energy_drift_rel"]) < 1e-12


def test_summary_and_outputs(tmp_path):
    scene = parse_scene_toml(_scene_text(), "mem.toml")
    sim = Simulation(scene)
    summary = sim.run(tmp_path, progress=False)
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["status"] == "completed" and d["steps"] == summary["steps"] > 0
    assert d["t"] == pytest.approx(2.0e-3)
    for key in ("scene", "versions", "wall_s", "wall_s_per_module", "dt", "diagnostics"):
        assert key in d
    assert d["dt"]["controlling_limit_counts"]
    pvd = (tmp_path / "particles.pvd").read_text()
    assert pvd.count("<DataSet") == 3  # t = 0, 1e-3, 2e-3


def test_cli_malformed_scene_one_line_exit_2_nothing_written(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(_scene_text(material={**UNIT_MATERIAL, "rho0": -1.0}))
    out = tmp_path / "out"
    assert main(["run", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rho0" in err[0] and "bad.toml" in err[0]
    assert not out.exists()


def test_cli_refuses_existing_output(tmp_path, capsys):
    good = tmp_path / "good.toml"
    good.write_text(_scene_text())
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    assert main(["run", str(good), "--out", str(out), "--no-progress"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "keep.txt").read_text() == "precious"
    assert main(["run", str(good), "--out", str(out), "--no-progress", "--overwrite"]) == 0
    assert (out / "summary.json").exists() and not (out / "keep.txt").exists()


def test_cli_setup_error_before_any_output(tmp_path, capsys):
    """Overlapping blocks are found while building particles: one line, exit 2, no folder."""
    scene = _scene_text(blocks=[solid_box(), solid_box("overlap", (0.2, 0.2), (0.4, 0.4))])
    f = tmp_path / "overlap.toml"
    f.write_text(scene)
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "overlap" in err[0]
    assert not out.exists()


def _run_box(tmp_path, name, output):
    scene = parse_scene_toml(_scene_text(output=output), "mem.toml")
    ps = build_particles(scene)
    ps.T[:] = _initial_field(ps)
    sim = Simulation(scene, particles=ps)
    out = tmp_path / name
    out.mkdir()
    summary = sim.run(out, progress=False)
    order = np.argsort(sim.particles.id)
    return sim.particles.T[order], summary, out


def test_outputs_need_not_shorten_the_step(tmp_path):
    """[output] exact_times = false: the run takes the same steps as without outputs (the
    final state to the bit) and writes after the first step that reaches each output time;
    with the default the step is shortened to land on them (more steps, other state)."""
    import xml.etree.ElementTree as ET

    T_none, s_none, _ = _run_box(tmp_path, "none", {})
    T_free, s_free, out = _run_box(tmp_path, "free", {"every": 0.7e-4, "exact_times": False})
    T_exact, s_exact, _ = _run_box(tmp_path, "exact", {"every": 0.7e-4})
    assert s_none["steps"] == s_free["steps"] == 100  # dt = 2e-5 to 2e-3
    np.testing.assert_array_equal(T_free, T_none)
    assert s_exact["steps"] > 100 and not np.array_equal(T_exact, T_none)
    times = [float(d.get("timestep")) for d in
             ET.parse(out / "particles.pvd").getroot().iter("DataSet")]
    # t = 0, then the first step at or past k 0.7e-4 (k = 1..28), then the end
    want = [0.0] + [2e-5 * np.ceil(k * 0.7e-4 / 2e-5 - 1e-9) for k in range(1, 29)] + [2e-3]
    np.testing.assert_allclose(times, sorted(set(np.round(want, 12))), rtol=0, atol=1e-12)
