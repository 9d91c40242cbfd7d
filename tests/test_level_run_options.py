"""examples/droplet_impact/level_run.py --fluid-option: bad keys and values stop with the
key named, and an override holds for the run only."""

from pathlib import Path

import pytest
from builders import load_example

from sphfem.axisymmetric_scene import AxisymmetricFluidModule

SCRIPT = Path(__file__).parents[1] / "examples" / "droplet_impact" / "level_run.py"


def _level_run():
    return load_example(SCRIPT, "level_run")


@pytest.mark.parametrize("option, message", [
    ("bogus=1", "expected KEY=VALUE with KEY one of"),
    ("wall_tension", "expected KEY=VALUE with KEY one of"),
    ("shifting=0.5", "expected KEY=VALUE with KEY one of"),  # a scene key, not an option
    ("wall_tension=Tru", "the value is not a Python literal"),
])
def test_bad_fluid_option_is_named(tmp_path, capsys, option, message):
    with pytest.raises(SystemExit):
        _level_run().main(["10", "16", "0.05", str(tmp_path / "run"), "--fluid-only",
                           "--fluid-option", option])
    err = capsys.readouterr().err
    assert message in err and repr(option) in err
    assert not (tmp_path / "run").exists()


def test_fluid_option_holds_for_the_run_only(tmp_path, monkeypatch):
    seen = {}
    import sphfem.api

    def fake_run(scene, out, **kw):  # records the options the module would build with
        seen.update(AxisymmetricFluidModule.fluid_options)
        raise RuntimeError("stop here")

    monkeypatch.setattr(sphfem.api, "run", fake_run)
    before = dict(AxisymmetricFluidModule.fluid_options)
    with pytest.raises(RuntimeError, match="stop here"):
        _level_run().main(["10", "16", "0.05", str(tmp_path / "run"), "--fluid-only",
                           "--fluid-option", "wall_tension=False",
                           "--fluid-option", "axis_alpha=0.1"])
    assert seen["wall_tension"] is False and seen["axis_alpha"] == 0.1
    assert seen["csf_axis_curvature"] == before["csf_axis_curvature"]
    assert AxisymmetricFluidModule.fluid_options == before


def test_scene_overrides_index_lists():
    """``section.key=value`` overrides reach a block by its position (``blocks.1.
    sampling=shells``); a name where a list needs a number is an error naming it."""
    from sphfem.validation.droplet_impact import apply_overrides, scene_at

    d = scene_at(10.0, 16, 0.1, overrides=["blocks.1.sampling=shells",
                                          "materials.water.c0=200.0"])
    assert d["blocks"][1]["sampling"] == "shells" and d["blocks"][1]["kind"] == "fluid"
    assert d["materials"]["water"]["c0"] == 200.0
    with pytest.raises(ValueError, match="'droplet' indexes a list"):
        apply_overrides(d, ["blocks.droplet.sampling=shells"])


def _solver_keywords(monkeypatch, overrides=()) -> dict:
    """The keywords AxisymmetricFluidModule builds its AxisymmetricFluid with, for the
    fluid-only 10 m/s droplet scene at D/dx 16 with ``overrides`` (the solver is replaced
    by a recorder that stops the run)."""
    import sphfem.fluid.axisymmetric as fa
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation
    from sphfem.validation.droplet_impact import scene_at

    seen = {}

    class Recorder:
        def __init__(self, *args, **kw):
            seen.update(kw)
            raise RuntimeError("recorded")

    monkeypatch.setattr(fa, "AxisymmetricFluid", Recorder)
    d = scene_at(10.0, 16, 0.05, overrides=list(overrides))
    d["physics"]["modules"] = ["fluid"]
    for key in ("heat", "coupling"):
        d.pop(key, None)
    with pytest.raises(RuntimeError, match="recorded"):
        Simulation(parse_scene(d)).run(None, progress=False)
    return seen


def test_module_keywords_are_its_call(monkeypatch):
    """AxisymmetricFluidModule passes the solver exactly its SCENE_KEYWORDS plus
    ``fluid_options`` (and csf_meridian and bulk_damping_length, scene keys it merges into
    them), so level_run's list of settable options cannot drift from the module's call."""
    seen = _solver_keywords(monkeypatch)
    merged = {"csf_meridian", "bulk_damping_length"}  # scene keys _options merges
    options = set(AxisymmetricFluidModule.fluid_options) | merged
    assert set(seen) - options == AxisymmetricFluidModule.SCENE_KEYWORDS - merged
    assert not (set(AxisymmetricFluidModule.fluid_options)
                & AxisymmetricFluidModule.SCENE_KEYWORDS)


def test_bulk_damping_scene_keys_reach_the_solver(monkeypatch):
    """``fluid.bulk_damping`` and ``fluid.bulk_damping_length`` of an axisymmetric scene are
    the solver's keywords (unset: the module's alpha_b); in a planar scene they are errors
    naming the key."""
    from builders import as_planar_scene

    from sphfem.scene import SceneError, parse_scene
    from sphfem.validation.droplet_impact import scene_at

    for overrides, alpha_b, length in (
            ([], AxisymmetricFluidModule.fluid_options["bulk_damping"], 0.0),
            (["fluid.bulk_damping=1.0", "fluid.bulk_damping_length=2.5e-7"], 1.0, 2.5e-7)):
        seen = _solver_keywords(monkeypatch, overrides)
        assert seen["bulk_damping"] == alpha_b and seen["bulk_damping_length"] == length
    d = as_planar_scene(scene_at(10.0, 16, 0.05, overrides=["fluid.bulk_damping_length=1e-7",
                                                          "fluid.wall_friction=sph"]))
    with pytest.raises(SceneError) as e:
        parse_scene(d)
    assert e.value.key == "fluid.bulk_damping_length"
