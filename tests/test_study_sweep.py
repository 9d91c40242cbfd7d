"""``study.py --sweep`` helpers (issue 16): the axisymmetric sweep's scene per case, its
errors, resume and tables.  No simulation runs here: ``sphfem.api.run`` is replaced where a
case would run."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "droplet_impact"


@pytest.fixture(scope="module")
def study():
    from builders import load_example

    return load_example(EXAMPLE / "study.py", "droplet_study_sweep")


@pytest.fixture(scope="module")
def scene():
    from sphfem.scene import parse_scene_toml

    path = EXAMPLE / "droplet_impact_axisymmetric.toml"
    return parse_scene_toml(path.read_text(), source=str(path))


def test_parse_sweep_errors_name_the_known_choices(study):
    with pytest.raises(SystemExit, match="unknown sweep parameter 'velocity'.*speed=.*"
                                         "temperature=.*material="):
        study.parse_sweep(["velocity=10"])
    with pytest.raises(SystemExit, match="unknown material 'copper'; known: alumina, "
                                         "silicon, steel, glass"):
        study.parse_sweep(["material=glass,copper"])
    with pytest.raises(SystemExit, match="must be numbers"):
        study.parse_sweep(["speed=10,fast"])
    with pytest.raises(SystemExit, match="no values"):
        study.parse_sweep(["temperature="])
    with pytest.raises(SystemExit, match="given twice"):
        study.parse_sweep(["speed=10", "speed=30"])
    with pytest.raises(SystemExit, match="> 0"):
        study.parse_sweep(["speed=0"])
    axes = study.parse_sweep(["speed=10,30", "material=steel"])
    assert axes == {"speed": [10.0, 30.0], "temperature": [100.0], "material": ["steel"]}


def test_sweep_case_scales_the_scene(study, scene):
    """D/dx = 32, c0 = 10 V, t_end = 4 tc = 4 D / V, droplet at 60 C, the coupled substrate
    (FEM and its SPH wall block) carries the chosen material's properties."""
    from sphfem.scene import parse_scene

    for speed, mat in ((10.0, "glass"), (30.0, "steel")):
        d = study.sweep_case(scene, speed, 60.0, mat, per_diameter=32, t_end_tc=4.0)
        sc = parse_scene(d, source="test")
        drop = next(b for b in sc.blocks if b.kind == "fluid")
        D = 2.0 * drop.radius
        assert sc.sph.dx == pytest.approx(D / 32, rel=1e-12)
        assert drop.velocity[-1] == -speed and not any(drop.velocity[:-1])
        assert sc.materials[drop.material].c0 == pytest.approx(10.0 * speed)
        assert drop.temperature == pytest.approx(333.15)
        assert sc.time.t_end == pytest.approx(4.0 * D / speed, rel=1e-12)
        assert sc.coupling.material == mat
        wall = next(b for b in sc.blocks if b.name in sc.coupling.blocks)
        assert wall.material == mat
        for k, v in study.MATERIALS[mat].items():
            assert getattr(sc.materials[mat], k) == v
        assert "alumina" not in sc.materials  # no stale copy under the old name
        # every resolution length scaled by the same factor (the heat layer's dx / 2)
        assert sc.coupling.heat.h_lateral == pytest.approx(sc.sph.dx / 2, rel=1e-12)


def _summary(study, scene, speed, temp, mat):
    """A summary.json of a finished case with round figures (no run)."""
    d = study.sweep_case(scene, speed, temp, mat, per_diameter=32, t_end_tc=4.0)
    tc = 1e-4 / speed
    hist = [{"t": tc * f, "T_impact": 293.15 + 10.0} for f in (0.5, 1.0, 1.5)]
    return {
        "scene": d, "status": "completed", "t": 4 * tc, "steps": 100, "wall_s": 12.0,
        "particles": {"total": 1000},
        "diagnostics": {
            "fluid": {"spreading": {"max_ratio": 3.0, "max_t_s": 2 * tc}, "mass_kg": 1e-9},
            "coupling": {
                "t_contact_s": 0.1 * tc, "peak_von_mises_Pa": 5e6,
                "peak_von_mises_t_after_contact_s": 0.2 * tc,
                "peak_von_mises_location_m": [1e-5, -2e-6],
                "substrate_heat": {
                    "heat_to_substrate_J": 2e-6, "ideal_contact_heat_J": 4e-6,
                    "substrate_initial_temperature_K": 293.15,
                    "ideal_contact_temperature_K": 293.15 + 20.0,
                    "T_impact_max_K": 293.15 + 12.0,
                    "fluid_substrate_residual_rel": 1e-12, "history": hist}}}}


def test_sweep_resumes_and_tabulates(study, scene, tmp_path, monkeypatch):
    """A case whose summary.json exists is not run again; a missing one runs once; the
    tables hold the ratios to the ideal contact and no temporary file is left behind."""
    import sphfem.api

    out = tmp_path / "runs"
    done = out / study.case_name(10.0, 100.0, "glass")
    done.mkdir(parents=True)
    (done / "summary.json").write_text(json.dumps(_summary(study, scene, 10.0, 100.0,
                                                           "glass")))
    ran = []

    def fake_run(sc, folder, **kw):
        ran.append(Path(folder).name)
        Path(folder).mkdir(parents=True, exist_ok=True)
        (Path(folder) / "summary.json").write_text(json.dumps(
            _summary(study, scene, 30.0, 100.0, "glass")))

    monkeypatch.setattr(sphfem.api, "run", fake_run)
    specs = ["speed=10,30", "temperature=100", "material=glass"]
    rows = study.sweep(scene, out, specs, table_dir=tmp_path / "tables")
    assert ran == [study.case_name(30.0, 100.0, "glass")]
    assert [r["speed_m_s"] for r in rows] == [10.0, 30.0]
    r = rows[0]
    assert r["heat_over_ideal"] == pytest.approx(0.5)
    assert r["T_impact_rise_over_ideal"] == pytest.approx(0.5)
    assert r["T_contact_ideal_C"] == pytest.approx(40.0)
    assert r["peak_von_mises_MPa"] == pytest.approx(5.0)
    assert r["peak_von_mises_t_after_contact_over_tc"] == pytest.approx(0.2)
    with open(tmp_path / "tables" / "sweep.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [float(t["heat_over_ideal"]) for t in table] == [0.5, 0.5]
    assert sorted(p.name for p in (tmp_path / "tables").iterdir()) == [
        "sweep.csv", "sweep.json", "sweep.md", "sweep.png"]
    # a second call runs nothing; --table-only skips cases never run
    ran.clear()
    study.sweep(scene, out, specs + [], table_dir=tmp_path / "tables")
    rows = study.sweep(scene, out, ["speed=10,50", "material=glass"], table_only=True,
                       table_dir=tmp_path / "t2")
    assert ran == [] and [r["speed_m_s"] for r in rows] == [10.0]


def test_sustained_peak_leaves_out_single_step_spikes(study):
    """max_i min(v_i, v_i+1): a one-step spike does not count, a two-step plateau does."""
    assert study.sustained_peak([1.0, 2.0, 9.0, 2.5, 3.0, 3.0, 1.0]) == 3.0
    assert study.sustained_peak([1.0, 5.0, 5.0, 1.0]) == 5.0
    assert study.sustained_peak([None, 4.0]) is None
