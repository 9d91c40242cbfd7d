"""A run killed mid-way and resumed with --resume ends equal (1e-12) to an uninterrupted one."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from builders import periodic_box_toml, solid_box

SCENE = periodic_box_toml(
    name="resume_heat", dx=0.02,
    blocks=[solid_box("cold", (0.0, 0.0), (0.5, 1.0), temperature=300.0),
            solid_box("hot", (0.5, 0.0), (1.0, 1.0), temperature=400.0)],
    time={"t_end": 0.02, "dt": 2.0e-6}, output={"every": 1.0e-3, "fields": ["T"]})


def _final_T(out):
    import meshio

    vtus = sorted(out.glob("particles_*.vtu"))
    m = meshio.read(vtus[-1])
    order = np.lexsort(m.points[:, :2].T)
    return m.point_data["T"][order], len(vtus)


def _run(args, **kw):
    cmd = [sys.executable, "-m", "sphfem.cli", "run", *args, "--no-progress"]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def test_kill_and_resume_matches_uninterrupted(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    p = _run([str(scene), "--out", str(ref)])
    assert p.wait(timeout=600) == 0, p.stderr.read().decode()

    p = _run([str(scene), "--out", str(cut)])
    deadline = time.time() + 600
    while time.time() < deadline:  # kill once a few checkpoints have been written
        if len(list(cut.glob("particles_*.vtu"))) >= 6 and (cut / "checkpoint.npz").exists():
            break
        if p.poll() is not None:
            pytest.fail("the run ended before it could be killed; make the scene longer")
        time.sleep(0.05)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert not (cut / "summary.json").exists()  # it really was interrupted

    p = _run([str(scene), "--out", str(cut), "--resume"])
    assert p.wait(timeout=600) == 0, p.stderr.read().decode()
    T_ref, n_ref = _final_T(ref)
    T_cut, n_cut = _final_T(cut)
    assert n_cut == n_ref
    np.testing.assert_allclose(T_cut, T_ref, rtol=1e-12, atol=0)
    # the summary says what the figures of the resumed process cover
    s_ref = json.loads((ref / "summary.json").read_text())
    s_cut = json.loads((cut / "summary.json").read_text())
    assert s_ref["resumed"] is None and s_cut["steps"] == s_ref["steps"]
    r = s_cut["resumed"]
    assert r["processes_before"] == 1 and 0 < r["from_step"] < s_cut["steps"]
    assert r["steps_this_process"] == s_cut["steps"] - r["from_step"]
    assert r["from_t"] == pytest.approx(1e-3 * round(r["from_t"] / 1e-3), rel=1e-9)
    acc = r["accumulated"]
    for k in ("setup_s", "wall_s", "total_s"):
        assert acc[k] > s_cut[k]  # this process plus the killed one up to its checkpoint
    # a completed run removes its checkpoint (nothing left to resume)
    assert not (ref / "checkpoint.npz").exists() and not (cut / "checkpoint.npz").exists()
