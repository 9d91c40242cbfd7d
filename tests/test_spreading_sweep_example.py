"""examples/droplet_impact/spreading_axisymmetric.py: the (We, Re) cases' scenes and levels
(the runs themselves are the study's, not the suite's)."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

from sphfem.scene import parse_scene
from sphfem.validation import droplet_impact as di

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
    # at We 30, D/dx 87 the capillary pressure at the kernel's scale needs more than 10 V
    water = study.scene_for(30.0, 1000.0, 87, 2.0)["materials"]["water"]
    h = 1.5 * D / 87
    assert water["c0"] == math.ceil(math.sqrt(water["sigma"] / (0.01 * rho * h))) > 10 * V
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


def test_ensemble_members_jitter_the_droplet_and_the_report_tabulates_them(study, tmp_path):
    d0 = study.scene_for(30.0, 1000.0, 24, 2.0)
    d2 = study.scene_for(30.0, 1000.0, 24, 2.0, member=2)
    drop0 = next(b for b in d0["blocks"] if b["kind"] == "fluid")
    drop2 = next(b for b in d2["blocks"] if b["kind"] == "fluid")
    assert drop0.get("jitter", 0.0) == 0.0
    assert drop2["jitter"] == di.ENSEMBLE_JITTER and d2["scene"]["seed"] == 2
    parse_scene(d2)
    band = {"a": 2.0, "b": 2.5}
    recs = [{"We": 30.0, "Re": 1000.0, "n": 61, "member": k, "refined": False,
             "spread": s, "spread_t_tc": 1.5, "max_reached": True, "film_particles": 3.0,
             "correlations": band, "wall_s": 1.0, "spread_wall_row": s + 0.1,
             "detached_at_max": 0.02} for k, s in enumerate((2.9, 3.1, 3.0))]
    recs.append({"We": 30.0, "Re": 1000.0, "n": 87, "refined": True, "spread": 2.7,
                 "spread_t_tc": 1.4, "max_reached": True, "film_particles": 4.3,
                 "correlations": band, "wall_s": 2.0})  # an older record: no new keys
    recs[0]["history_t_tc"], recs[0]["history_ratio"] = [0.0, 1.0, 2.0], [0.0, 2.5, 2.9]
    study.report(recs, tmp_path)
    assert (tmp_path / "spread_history.png").exists()
    assert study.history_plot(recs[1:], tmp_path / "none.png") is False  # no history kept
    table = (tmp_path / "table.md").read_text()
    assert "| 30 | 1000 | 61 | 3 | 3.000 | 2.900-3.100 | 6.7% |" in table
    assert "| 30 | 1000 | 87 | 0 | 4.3 | 2.70 (1.40) | - | - |" in table
    assert (tmp_path / "spreading.png").exists()


def test_the_frame_rate_does_not_perturb_the_runs(study):
    d = study.scene_for(30.0, 1000.0, 24, 2.0, ["output.every=0.25 tc"])
    assert d["output"]["exact_times"] is False
    assert parse_scene(d).output.exact_times is False


def test_member_runs_only_the_named_members(study, tmp_path, monkeypatch, capsys):
    calls = []

    def fake(We, Re, n, t_end, out, refined, sets, tag, k):
        calls.append((n, k))
        return {"spread": 3.0, "spread_t_tc": 2.0, "wall_s": 1.0}

    monkeypatch.setattr(study, "run_case", fake)
    study.main(["--out", str(tmp_path), "--we", "30", "--re", "1000", "--n", "24,32",
                "--member", "2", "--member", "1"])
    assert calls == [(24, 1), (24, 2), (32, 1), (32, 2)]
    calls.clear()
    study.main(["--out", str(tmp_path), "--we", "30", "--re", "1000", "--n", "24",
                "--ensemble", "2"])
    assert calls == [(24, 0), (24, 1)]
    with pytest.raises(SystemExit):
        study.main(["--out", str(tmp_path), "--member", "-1"])
    assert "--member" in capsys.readouterr().err


def test_convergence_of_the_ensemble_means(study):
    """Means following f = 3 + 100 / n^2 exactly: order 2 and limit 3 recovered; the
    finest level's distance counts its members' half-range (0.1 / 3 here, + the rest)."""
    g = {(30.0, 1000.0, n): [3.0 + 100.0 / n**2 - 0.1, 3.0 + 100.0 / n**2 + 0.1]
         for n in (32, 64, 128)}
    g[(100.0, 300.0, 24)] = [2.0]  # a case with one level: no line
    lines = study.convergence_lines(g)
    rows = [row for row in lines if row.startswith("| 30 |")]
    assert len(rows) == 1 and not any(row.startswith("| 100 |") for row in lines)
    cells = [c.strip() for c in rows[0].split("|")[1:-1]]
    assert cells[2] == "32, 64, 128" and cells[4] == "2.00"
    assert cells[5].startswith("3.000 +- ")
    est = 100.0 / 128**2  # finest - limit; GCI = 1.25 * (f3 - f2) / (r^p - 1)
    gci = 1.25 * (100.0 / 64**2 - est) / 3.0
    assert cells[6] == f"{(est + gci + 0.1) / 3.0:.1%}"
    assert study.convergence_lines({(30.0, 1000.0, 32): [3.0]}) == []


def test_a_run_cut_off_midway_continues_from_its_checkpoint(study, tmp_path):
    """A run folder holding a checkpoint (the run was stopped) is continued, not restarted:
    the record's end time is the case's and it says so."""
    from sphfem.api import run

    d = study.scene_for(30.0, 100.0, 8, 0.2)
    name = "We30_Re100_n8"
    run(parse_scene(d, source=name), tmp_path / name, keep_checkpoint=True)
    t_cut = json.loads((tmp_path / name / "summary.json").read_text())["t"]
    rec = study.run_case(30.0, 100.0, 8, 0.4, tmp_path)
    assert rec["resumed"] is True
    assert len(rec["history_ratio"]) == len(rec["history_t_tc"]) > 0
    assert rec["history_t_tc"][-1] == pytest.approx(0.4, rel=0.05)
    # a record written before the history was kept takes it from its run's summary
    path = tmp_path / (name + ".json")
    old = {k: v for k, v in json.loads(path.read_text()).items() if "history" not in k}
    path.write_text(json.dumps(old))
    back = study.run_case(30.0, 100.0, 8, 0.4, tmp_path)
    assert back["history_ratio"] == rec["history_ratio"]
    assert back["history_t_tc"] == pytest.approx(rec["history_t_tc"])
    assert rec["t_end_tc"] == pytest.approx(0.4, rel=1e-3)
    assert t_cut == pytest.approx(0.2 * 1e-4 / study.SPEED, rel=1e-3)
    assert rec["spread"] > 0.0
    rec2 = study.run_case(30.0, 100.0, 8, 0.4, tmp_path / "fresh")
    assert rec2["resumed"] is False
    # the same run cut or not, up to the step sequence (the cut run stepped onto t_cut)
    assert rec2["spread"] == pytest.approx(rec["spread"], rel=1e-2)
