"""Honest reporting of a run (issue 14): set-up / stepping / total seconds and peak memory in
summary.json, start-up stage lines on stderr, the human summary of ``sphfem run``, file
modes of the results, the checkpoint of a completed run, and numba's on-disk cache."""

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from builders import periodic_box_toml, solid_box

from sphfem import progress
from sphfem.cli import main
from sphfem.physics import MODULES, PhysicsModule
from sphfem.scene import parse_scene_toml
from sphfem.schema import register_module, unregister
from sphfem.simulation import Simulation, format_summary


def _scene_text(modules=("heat",)) -> str:
    """The periodic unit box (:func:`builders.periodic_box`) at 300 K."""
    return periodic_box_toml(modules, blocks=[solid_box(temperature=300.0)])

INIT_S, STEP_S = 3.0, 0.002  # a set-up sleep far above the loop time, even on a loaded machine


class SlowInit(PhysicsModule):
    """Test module: its set-up takes INIT_S seconds and each step STEP_S (sleeps)."""

    name = "slowinit"

    def init(self, sim):
        time.sleep(INIT_S)

    def step(self, sim, dt):
        time.sleep(STEP_S)


@pytest.fixture
def slow_module():
    register_module("slowinit", target="test_run_reporting:SlowInit")
    yield
    unregister("slowinit")
    MODULES.pop("slowinit", None)


def _scene_file(tmp_path, modules=("heat",)):
    f = tmp_path / "scene.toml"
    f.write_text(_scene_text(modules))
    return f


def test_setup_stepping_and_total_seconds(slow_module, tmp_path):
    """A module's set-up counts in setup_s, not in the stepping loop's wall_s, and
    total_s covers both (the sleeps give lower bounds that the old summary, with only
    the loop's wall_s, could not meet)."""
    scene = parse_scene_toml(_scene_text(("heat", "slowinit")), "mem.toml")
    sim = Simulation(scene)
    s = sim.run(tmp_path, progress=False)
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["setup_s"] == pytest.approx(s["setup_s"])
    assert d["setup_s"] >= INIT_S
    stages = {st["stage"]: st for st in d["setup"]["stages"]}
    assert stages["setting up slowinit"]["s"] >= INIT_S
    assert sum(st["s"] for st in d["setup"]["stages"]) <= d["setup_s"]
    assert d["wall_s"] >= d["steps"] * STEP_S
    assert d["wall_s"] < d["setup_s"] + d["steps"] * STEP_S  # the set-up is not in it
    assert d["total_s"] >= d["setup_s"] + d["wall_s"]
    if d["process_s"] is not None:  # Linux
        assert d["process_s"] >= d["total_s"]
    assert d["peak_rss_mb"] > 0 and "setup_s" in d["timing_scope"]
    assert d["resumed"] is None


def test_peak_memory_unit_matches_proc_status():
    """peak_rss_mb: ru_maxrss is KiB on Linux; it must agree with the kernel's VmHWM and
    rise by an array touched in this process (a KiB/byte mix-up is off by 1024x)."""
    if not sys.platform.startswith("linux"):
        pytest.skip("/proc/self/status is Linux only")
    a = np.ones(64 * 2**20 // 8)  # 64 MB, touched
    peak = progress.peak_rss_mb()
    with open("/proc/self/status") as fh:
        hwm = next(int(ln.split()[1]) for ln in fh if ln.startswith("VmHWM:")) / 1024
    assert peak == pytest.approx(hwm, rel=0.05)
    assert peak >= progress.rss_mb() - 1.0 >= a.nbytes / 2**20
    del a


def test_cli_human_summary_stage_lines_and_json(tmp_path, capsys):
    f = _scene_file(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert cap.out.startswith("sphfem: run completed: 100 steps to t = 0.002 s")
    assert f"outputs: {out}/ (particles.pvd, summary.json)" in cap.out
    assert "peak memory" in cap.out and "set-up" in cap.out
    assert "sphfem: first neighbour list (400 particles)..." in cap.err
    assert "sphfem: setting up heat..." in cap.err
    # --no-progress: no stage lines; --json: the figures as one JSON line
    assert main(["run", str(f), "--out", str(out), "--overwrite", "--no-progress",
                 "--json"]) == 0
    cap = capsys.readouterr()
    assert "sphfem:" not in cap.err
    d = json.loads(cap.out)
    assert d["status"] == "completed" and d["steps"] == 100
    assert {"setup_s", "wall_s", "total_s", "peak_rss_mb"} <= set(d)


def test_format_summary_coupling_lines(tmp_path):
    """Peak von Mises in MPa with its place in um and its time, and the heat handed over,
    taken from the coupling's diagnostics."""
    (tmp_path / "substrate").mkdir()
    (tmp_path / "summary.json").write_text("{}")
    s = {"status": "completed", "message": "", "steps": 7, "t": 3.5e-6,
         "particles": {"total": 10}, "setup_s": 1.0, "wall_s": 2.0, "total_s": 3.5,
         "process_s": 5.0, "peak_rss_mb": 512.0, "resumed": None,
         "diagnostics": {"coupling": {
             "peak_von_mises_Pa": 12.5e6, "peak_von_mises_location_m": [0.0, 2e-6, -5e-6],
             "peak_von_mises_t_s": 1.25e-6,
             "heat": {"heat_to_solid_J": 2.5e-7, "heat_lost_by_fluid_J": 2.6e-7}}}}
    text = format_summary(s, tmp_path)
    assert "peak von Mises 12.5 MPa at (0, 2, -5) um, t = 1.25e-06 s" in text
    assert "heat handed to the substrate: 2.5e-07 J (the fluid lost 2.6e-07 J)" in text
    assert "total 3.5 s (5.0 s with imports); peak memory 512 MB" in text
    assert f"outputs: {tmp_path}/ (substrate/, summary.json)" in text


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600)])
def test_results_respect_the_umask(tmp_path, umask, mode):
    """Atomic writes go through mkstemp (always 0600); results get 0666 & ~umask."""
    old = os.umask(umask)
    try:
        scene = parse_scene_toml(_scene_text(), "mem.toml")
        out = tmp_path / "out"
        Simulation(scene).run(out, progress=False, keep_checkpoint=True)
    finally:
        os.umask(old)
    for name in ("summary.json", "particles.pvd", "particles_00001.vtu", "checkpoint.npz"):
        assert (out / name).stat().st_mode & 0o777 == mode, name


def test_checkpoint_deleted_after_completion_unless_kept(tmp_path):
    scene = parse_scene_toml(_scene_text(), "mem.toml")
    a, b = tmp_path / "a", tmp_path / "b"
    sa = Simulation(scene).run(a, progress=False)
    sb = Simulation(scene).run(b, progress=False, keep_checkpoint=True)
    assert not (a / "checkpoint.npz").exists() and sa["checkpoint"] is None
    assert (b / "checkpoint.npz").exists() and sb["checkpoint"] == str(b / "checkpoint.npz")


def _run_json(scene, out, env):
    r = subprocess.run([sys.executable, "-m", "sphfem.cli", "run", str(scene), "--out",
                        str(out), "--overwrite", "--no-progress", "--json"],
                       capture_output=True, text=True, env=env, timeout=1800)
    assert r.returncode == 0, r.stderr
    return json.loads((out / "summary.json").read_text())["setup"]


def test_second_process_compiles_nothing(tmp_path):
    """numba's on-disk cache works across processes: whatever the first process had to
    compile, a second identical run loads every kernel (no ``numba:compile`` event)."""
    f = _scene_file(tmp_path)
    env = dict(os.environ)
    _run_json(f, tmp_path / "o1", env)
    second = _run_json(f, tmp_path / "o2", env)
    assert second["numba_compilations"] == 0, second


@pytest.mark.slow
def test_fresh_cache_compiles_once(tmp_path):
    """From an empty cache folder (a fresh install): the first run compiles, the second
    compiles nothing."""
    f = _scene_file(tmp_path)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    first = _run_json(f, tmp_path / "o1", env)
    second = _run_json(f, tmp_path / "o2", env)
    assert first["numba_compilations"] > 0
    assert second["numba_compilations"] == 0, second


def _lattice_pairs(k: int, r2_max: int, strict: bool) -> int:
    """Directed pairs of a k^3 unit lattice within sqrt(r2_max) (exact: each offset
    (a, b, c) occurs (k - |a|)(k - |b|)(k - |c|) times)."""
    total = 0
    for a in range(-3, 4):
        for b in range(-3, 4):
            for c in range(-3, 4):
                r2 = a * a + b * b + c * c
                if r2 and (r2 < r2_max if strict else r2 <= r2_max):
                    total += (k - abs(a)) * (k - abs(b)) * (k - abs(c))
    return total


def test_neighbour_bench_counts_pairs_inside_the_support():
    """The micro-benchmark's pairs are the interacting ones, r < R (as the fluid bench and
    PySPH count); the list's r = R pairs (zero weight; 30 of 122 per interior particle)
    are reported apart."""
    from sphfem.bench import run_bench

    res = run_bench("neighbors", quick=True, threads=(1,), repeats=1, verbose=False)
    c = res["cases"][0]
    k = round(c["n"] ** (1 / 3))
    assert k**3 == c["n"]
    assert c["pairs"] == _lattice_pairs(k, 9, strict=True)
    assert c["list_pairs"] == _lattice_pairs(k, 9, strict=False)
    assert c["pairs_per_s"] == pytest.approx(c["pairs"] / c["density_s"])
