"""examples/droplet_impact/spreading_axisymmetric.py: the (We, Re) cases' scenes and levels
(the runs themselves are the study's, not the suite's)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from sphfem.scene import parse_scene

PATH = Path(__file__).resolve().parents[1] / "examples" / "droplet_impact" / \
    "spreading_axisymmetric.py"


@pytest.fixture(scope="module")
def study():
    spec = importlib.util.spec_from_file_location("spreading_axisymmetric", PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_levels_put_three_particles_across_the_residual_film(study):
    # h_res / D = 0.79 Re^-0.4: 0.12503 at Re 100 -> 3 / 0.12503 = 23.99 -> 24;
    # 0.049846 at Re 1000 -> 60.19 -> 61
    assert study.particles_across(100.0, 0) == 24
    assert study.particles_across(1000.0, 0) == 61
    assert study.particles_across(100.0, 32) == 32
    assert study.particles_across(1000.0, 0, refine=True) == 87  # ceil(61 sqrt 2)


def test_scene_sets_we_and_re_and_only_the_fluid(study):
    d = study.scene_for(30.0, 300.0, 24, 2.0)
    s = parse_scene(d)
    water = d["materials"]["water"]
    rho, V, D = water["rho0"], study.SPEED, 1e-4
    assert rho * V * D / water["mu"] == pytest.approx(300.0)
    assert rho * V * V * D / water["sigma"] == pytest.approx(30.0)
    assert water["c0"] == pytest.approx(10 * V)
    assert d["physics"]["modules"] == ["fluid"] and "coupling" not in d and "heat" not in d
    assert s.sph.dx == pytest.approx(D / 24)


def test_bad_numbers_are_refused(study, tmp_path, capsys):
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--we", "-3"])
    assert "must be positive" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--re", "ten"])
    assert "--we / --re" in capsys.readouterr().err


def test_overrides_reach_the_scene_and_name_the_files(study):
    sets = ["fluid.film_tension=True", "output.every=0.25 tc"]
    d = study.scene_for(30.0, 1000.0, 24, 2.0, sets)
    assert d["fluid"]["film_tension"] is True
    assert d["output"]["every"] == "0.25 tc"  # applied after the sweep's own output rate
    assert parse_scene(d).fluid.film_tension is True
    assert study.override_tag(sets) == "film_tension-True_every-0.25-tc"
    assert study.override_tag([]) == ""


def test_bad_levels_and_sets_are_refused(study, tmp_path, capsys):
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--n", "61,x"])
    assert "--n" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--n", "2"])
    assert "at least 4" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--set", "film_tension"])
    assert "SECTION.KEY=VALUE" in capsys.readouterr().err
