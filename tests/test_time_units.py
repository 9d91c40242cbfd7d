"""Scene times in impact times ("4 tc", sphfem.time_units) and c0 = "physical"
(sphfem.sound_speed): parsing, errors naming the key, and a run that ends at 4 D / v."""

from __future__ import annotations

import copy
import re

import pytest

from sphfem.scene import SceneError, parse_scene

R, V = 0.05e-3, 50.0  # droplet radius [m] and speed [m/s]: tc = 2 R / V = 2e-6 s
TC = 2 * R / V


def _scene(**time):
    return {
        "scene": {"name": "tc", "dim": 3},
        "domain": {"lo": [-2e-4, -2e-4, -3e-5], "hi": [2e-4, 2e-4, 2e-4]},
        "sph": {"dx": 1e-5},
        "materials": {"water": {"rho0": 1000.0, "mu": 1e-3, "c0": 500.0},
                      "wall": {"rho0": 1000.0}},
        "blocks": [
            {"name": "wall", "shape": "box", "kind": "wall", "material": "wall",
             "lo": [-2e-4, -2e-4, -3e-5], "hi": [2e-4, 2e-4, 0.0]},
            {"name": "drop", "shape": "sphere", "kind": "fluid", "material": "water",
             "center": [0.0, 0.0, 1e-4], "radius": R, "velocity": [0.0, 30.0, -40.0]},
        ],
        "time": {"t_end": 1e-6, **time},
    }


def _error(data) -> SceneError:
    with pytest.raises(SceneError) as e:
        parse_scene(data, source="s.toml")
    return e.value


def test_times_in_tc_are_seconds_after_validation():
    sc = parse_scene(_scene(t_end="4 tc", dt="0.001tc") | {"output": {"every": " 0.25 tc "}})
    # |v| = sqrt(30^2 + 40^2) = 50 m/s, D = 1e-4 m: tc = 2e-6 s
    assert sc.time.t_end == pytest.approx(4 * TC, rel=1e-15)
    assert sc.time.dt == pytest.approx(1e-3 * TC, rel=1e-15)
    assert sc.output.every == pytest.approx(0.25 * TC, rel=1e-15)
    # numbers stay seconds; the resolved scene round-trips
    assert parse_scene(_scene(t_end=3e-6)).time.t_end == 3e-6
    assert parse_scene(sc.to_dict()) == sc
    from sphfem.time_units import scene_impact_time

    assert scene_impact_time(sc) == pytest.approx(TC, rel=1e-15)


@pytest.mark.parametrize("value", ["4 ms", "tc", "-1 tc", "0 tc", "4 tc tc", True, [4], 0.0])
def test_bad_times_name_the_key(value):
    e = _error(_scene(t_end=value))
    assert e.key == "time.t_end"
    assert '"<x> tc"' in e.message and "positive time in s" in e.message


def test_output_every_bad_value_names_its_key():
    e = _error(_scene() | {"output": {"every": "1 ts"}})
    assert e.key == "output.every" and "positive interval" in e.message


def test_tc_needs_one_moving_fluid_sphere():
    d = _scene(t_end="4 tc")
    d["blocks"][1]["velocity"] = [0.0, 0.0, 0.0]
    e = _error(d)
    assert e.key == "time.t_end" and "the scene has none" in e.message
    # a key other than t_end asking for tc is named
    d2 = _scene() | {"output": {"every": "0.5 tc"}}
    d2["blocks"][1]["velocity"] = [0.0, 0.0, 0.0]
    assert _error(d2).key == "output.every"
    # a box of fluid does not define tc
    d3 = _scene(t_end="4 tc")
    d3["blocks"][1] = {"name": "drop", "shape": "box", "kind": "fluid", "material": "water",
                       "lo": [0.0, 0.0, 1e-5], "hi": [5e-5, 5e-5, 6e-5],
                       "velocity": [0.0, 0.0, -1.0]}
    assert _error(d3).key == "time.t_end"


def test_several_spheres_need_tc_block():
    d = _scene(t_end="4 tc")
    second = copy.deepcopy(d["blocks"][1])
    second.update(name="drop2", center=[1.2e-4, 0.0, 1e-4], radius=2e-5,
                  velocity=[0.0, 0.0, -10.0])
    d["blocks"].append(second)
    e = _error(d)
    assert e.key == "time.t_end" and "tc_block" in e.message and "'drop2'" in e.message
    d["time"]["tc_block"] = "drop2"
    assert parse_scene(d).time.t_end == pytest.approx(4 * 4e-5 / 10.0, rel=1e-15)
    d["time"]["tc_block"] = "drop"
    assert parse_scene(d).time.t_end == pytest.approx(4 * TC, rel=1e-15)


@pytest.mark.parametrize("name, words", [("nope", "no block named 'nope'"),
                                         ("wall", "needs a fluid sphere")])
def test_tc_block_errors_name_tc_block(name, words):
    e = _error(_scene(t_end="4 tc", tc_block=name))
    assert e.key == "time.tc_block" and words in e.message


def test_tc_block_without_velocity():
    d = _scene(tc_block="drop")
    d["blocks"][1]["velocity"] = [0.0, 0.0, 0.0]
    e = _error(d)
    assert e.key == "time.tc_block" and "no velocity" in e.message


def test_dt_above_t_end_checked_after_resolution():
    e = _error(_scene(t_end="1 tc", dt="2 tc"))
    assert e.key == "time.dt" and "exceeds t_end" in e.message


def test_scene_in_tc_ends_at_4_D_over_v(tmp_path):
    """A run of a "4 tc" scene stops at t = 4 D / |v| (from t = 0), outputs every tc."""
    from sphfem.api import run

    D, v = 0.5, 2.0  # tc = 0.25 s
    data = {
        "scene": {"name": "tc-run", "dim": 2},
        "domain": {"lo": [-1.0, -1.0], "hi": [1.0, 1.0]},
        "sph": {"dx": 0.1},
        "materials": {"m": {"rho0": 1.0, "c": 1.0, "k": 1e-3}},
        "blocks": [{"name": "disc", "shape": "sphere", "kind": "fluid", "material": "m",
                    "center": [0.0, 0.0], "radius": D / 2, "velocity": [0.0, -v],
                    "temperature": 300.0}],
        "physics": {"modules": ["heat"]},
        "time": {"t_end": "4 tc"},
        "output": {"every": "1 tc", "fields": ["T"]},
    }
    res = run(data, out=tmp_path / "run")
    assert res.summary["t"] == pytest.approx(4 * D / v, rel=1e-12)
    pvd = (tmp_path / "run" / "particles.pvd").read_text()
    times = [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd)]
    assert times == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0], abs=1e-12)


# --------------------------------------------------------------------------------------
# c0 = "physical"


def test_physical_c0_takes_sound_speed():
    d = _scene()
    d["materials"]["water"].update(c0="physical", sound_speed=1480.0)
    sc = parse_scene(d)
    assert sc.materials["water"].c0 == 1480.0
    assert sc.materials["water"].sound_speed == 1480.0
    assert parse_scene(sc.to_dict()) == sc
    # a number stays the artificial c0, sound_speed is then only recorded
    d["materials"]["water"]["c0"] = 500.0
    assert parse_scene(d).materials["water"].c0 == 500.0


def test_physical_c0_reaches_the_fluid():
    from sphfem.fluid.wcsph import params_from_scene

    d = _scene()
    d["materials"]["water"].update(c0="physical", sound_speed=1480.0)
    d["physics"] = {"modules": ["fluid"]}
    assert params_from_scene(parse_scene(d)).c0 == 1480.0


def test_physical_c0_without_sound_speed_names_the_key():
    d = _scene()
    d["materials"]["water"]["c0"] = "physical"
    e = _error(d)
    assert e.key == "materials.water.sound_speed" and "missing" in e.message


@pytest.mark.parametrize("value", ["Physical", "fast", -500.0, 0, True])
def test_bad_c0_names_the_key(value):
    d = _scene()
    d["materials"]["water"]["c0"] = value
    e = _error(d)
    assert e.key == "materials.water.c0" and '"physical"' in e.message


def test_bad_sound_speed_names_the_key():
    d = _scene()
    d["materials"]["water"].update(c0="physical", sound_speed=-1.0)
    assert _error(d).key == "materials.water.sound_speed"


def test_example_scene_with_tc_and_physical_c0():
    """examples/droplet_impact/droplet_impact_physical_c0.toml: 4 tc = 8 us, c0 = 1480."""
    from pathlib import Path

    import coupling  # noqa: F401  (registers the coupling section)
    from sphfem.scene import load_scene

    root = Path(__file__).resolve().parents[1]
    sc = load_scene(root / "examples" / "droplet_impact" / "droplet_impact_physical_c0.toml")
    assert sc.time.t_end == pytest.approx(4 * 0.1e-3 / 50.0, rel=1e-15)
    assert sc.output.every == pytest.approx(0.25 * 0.1e-3 / 50.0, rel=1e-15)
    assert sc.materials["water"].c0 == 1480.0
