"""The numba warm-up child (``sphfem.jit_warmup``, issue 14: a first run after an install
must not carry numba's compiler memory through the run).

* the coarsened copy of a scene scales every resolution length and nothing else;
* the manifest's kernel key ignores values that do not change compiled code;
* the cache check counts only index entries numba would load now: it turns cold when the
  kernel's source changes (a tiny kernel in a temporary module, own ``NUMBA_CACHE_DIR``);
* end to end (slow): with an empty cache, ``sphfem run`` compiles in the child and the run
  itself compiles nothing; a second run finds the cache warm and starts no child.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sphfem.jit_warmup import coarsened, kernel_key
from sphfem.scene import load_scene, parse_scene

ROOT = Path(__file__).resolve().parent.parent
DROPLET = ROOT / "examples" / "droplet_impact" / "droplet_impact.toml"


def test_coarsened_scales_resolution_lengths_only():
    sc = load_scene(DROPLET)
    d = coarsened(sc, coarsen=3.0, steps=7)
    c = parse_scene(d)  # a valid scene
    assert c.sph.dx == pytest.approx(3.0 * sc.sph.dx, rel=1e-15)
    m0, m1 = sc.coupling.mesh, c.coupling.mesh
    assert m1.h_fine == pytest.approx(3.0 * m0.h_fine, rel=1e-15)
    assert m1.h_coarse == pytest.approx(3.0 * m0.h_coarse, rel=1e-15)
    # lengths that are geometry, not resolution, stay
    assert m1.refine_radius == m0.refine_radius and m1.lo == m0.lo and m1.hi == m0.hi
    assert [b.gap for b in c.blocks] == [None if b.gap is None else 3.0 * b.gap
                                         for b in sc.blocks]  # gap >= R stays true
    assert c.blocks[1].gap >= c.support_radius * (1 - 1e-12)
    same = [{k: v for k, v in b.to_dict().items() if k not in ("gap", "center")}
            for b in (*sc.blocks, *c.blocks)]
    assert same[:2] == same[2:]
    assert c.time.max_steps == 7 and c.time.t_end == sc.time.t_end
    assert kernel_key(c) == kernel_key(sc)  # the child compiles what the scene calls


def test_kernel_key_ignores_values_but_not_choices():
    base = load_scene(DROPLET).to_dict()

    def key(change):
        d = json.loads(json.dumps(base))
        change(d)
        return kernel_key(parse_scene(d))

    k0 = key(lambda d: None)
    assert key(lambda d: d["blocks"][1].update(velocity=[0.0, 0.0, -30.0])) == k0
    assert key(lambda d: d["fluid"].update(alpha=0.05)) == k0
    assert key(lambda d: d["fluid"].update(alpha=0.0)) != k0  # a term switched off
    assert key(lambda d: d["fluid"].update(surface_tension="none")) != k0
    assert key(lambda d: d["heat"].update(laplacian="fatehi_manzari")) != k0


_PROBE = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, sys.argv[1])
    import tinykern
    from sphfem.jit_warmup import _valid_entries, used_kernels
    if sys.argv[2] == "call":
        tinykern.twice(1.5)
    print(json.dumps({"valid": _valid_entries(tinykern.twice),
                      "used": used_kernels().get("tinykern:twice")}))
""")


def _probe(tmp_path, mode):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    r = subprocess.run([sys.executable, "-c", _PROBE, str(tmp_path / "mod"), mode],
                       capture_output=True, text=True, env=env, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_cache_check_follows_numbas_validity(tmp_path):
    mod = tmp_path / "mod"
    mod.mkdir()
    src = mod / "tinykern.py"
    src.write_text("from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n"
                   "    return 2.0 * x\n")
    assert _probe(tmp_path, "look") == {"valid": 0, "used": None}  # cold
    assert _probe(tmp_path, "call") == {"valid": 1, "used": 1}  # compiled and cached
    assert _probe(tmp_path, "look") == {"valid": 1, "used": None}  # warm, not called
    src.write_text(src.read_text().replace("2.0 * x", "3.0 * x"))  # edited source
    assert _probe(tmp_path, "look")["valid"] == 0


_SCENE = """
[scene]
name = "tiny_heat"
dim = 2
[domain]
lo = [-0.1, -0.1]
hi = [1.1, 0.6]
[sph]
dx = 0.05
support_factor = 3.0
[materials.m]
rho0 = 1.0
c = 1.0
k = 1.0
[[blocks]]
name = "plate"
shape = "box"
kind = "solid"
material = "m"
lo = [0.0, 0.0]
hi = [1.0, 0.5]
temperature = 300.0
[physics]
modules = ["heat"]
[time]
t_end = 1.0e-3
[output]
every = 5.0e-4
"""


@pytest.mark.slow
def test_first_run_compiles_in_the_child_only(tmp_path):
    """Cold cache: the warm-up child compiles, the run compiles nothing; then warm: no
    child.  (Minutes: numba compiles the neighbour and heat kernels from scratch.)"""
    scene = tmp_path / "tiny.toml"
    scene.write_text(_SCENE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "SPHFEM_CACHE": str(tmp_path / "cache"), "NUMBA_NUM_THREADS": "1"}
    env.pop("SPHFEM_JIT_WARMUP", None)

    def run(out):
        r = subprocess.run([sys.executable, "-m", "sphfem.cli", "run", str(scene), "--out",
                            str(tmp_path / out)], capture_output=True, text=True, env=env)
        assert r.returncode == 0, r.stderr
        return r.stderr, json.loads((tmp_path / out / "summary.json").read_text())

    err, s = run("cold")
    assert "compiling numba kernels in a child process" in err
    assert s["setup"]["numba_compilations"] == 0, s["setup"]["numba_compiled"]
    assert list((tmp_path / "cache" / "jit").glob("*.json"))
    err, s = run("warm")
    assert "child process" not in err
    assert s["setup"]["numba_compilations"] == 0


def test_split_balances_recorded_seconds():
    from sphfem.jit_warmup import split

    entries = [{"kernel": f"m:k{i}", "sigs": ["x"], "s": s}
               for i, s in enumerate([10.0, 7.0, 6.0, 4.0, 3.0, 1.0])]
    groups = split(entries, 2)
    loads = sorted(sum(e["s"] for e in g) for g in groups)
    assert loads == [15.0, 16.0]  # longest first to the lighter list: 10+4+1 | 7+6+3
    assert sorted(e["kernel"] for g in groups for e in g) == sorted(e["kernel"] for e in entries)
    assert split(entries[:1], 2) == [entries[:1]]  # no empty process
    assert len(split(entries, 1)) == 1


_RECORDED = textwrap.dedent("""
    import base64, json, pickle, sys
    sys.path.insert(0, sys.argv[1])
    from numba import types
    import tinykern
    from sphfem.jit_warmup import _compile_recorded, _valid_entries, is_warm, recorded
    from sphfem.scene import parse_scene_toml
    scene = parse_scene_toml(open(sys.argv[2]).read())
    sigs = [base64.b64encode(pickle.dumps(s)).decode() for s in [(types.float64,),
                                                                   (types.int64,)]]
    entries = [{"kernel": "tinykern:twice", "sigs": sigs, "s": 1.0},
               {"kernel": "tinykern:thrice", "sigs": sigs[:1], "s": 0.5}]
    before = is_warm(scene)
    info = _compile_recorded(scene, entries, progress=False)
    print(json.dumps({"before": before, "info": info, "after": is_warm(scene),
                      "valid": [_valid_entries(tinykern.twice),
                                _valid_entries(tinykern.thrice)],
                      "called_here": len(tinykern.twice.overloads)}))
""")


@pytest.mark.slow
def test_recorded_kernels_compile_in_child_processes(tmp_path):
    """A recorded scene's signatures compile in one child per worker into numba's cache
    (this process compiles nothing) and the manifest then says warm."""
    mod = tmp_path / "mod"
    mod.mkdir()
    (mod / "tinykern.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2 * x\n\n"
        "@njit(cache=True)\ndef thrice(x):\n    return 3 * x\n")
    scene = tmp_path / "tiny.toml"
    scene.write_text(_SCENE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "SPHFEM_CACHE": str(tmp_path / "cache"), "SPHFEM_JIT_WORKERS": "2",
           "PYTHONPATH": os.pathsep.join([str(mod), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-c", _RECORDED, str(mod), str(scene)],
                       capture_output=True, text=True, env=env, check=True)
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["before"] is False and out["after"] is True
    assert out["info"] == {"workers": 2, "ok": True, "compiled": 3, "failed": 0}
    assert out["valid"] == [2, 1] and out["called_here"] == 0




def test_shipped_records_resolve():
    """Every kernel of the shipped record exists and its signatures unpickle (a renamed
    kernel would leave a first run to compile it in the run's own process)."""
    import base64
    import importlib
    import pickle

    from sphfem.jit_warmup import SIGNATURES, recorded

    data = json.loads(SIGNATURES.read_text())
    assert data["scenes"]
    checked = 0
    for name in ("droplet_impact.toml", "droplet_impact_axisymmetric.toml"):
        entries = recorded(load_scene(DROPLET.parent / name))
        if entries is None:  # not recorded, or a record of another numba / Python
            continue
        checked += 1
        for e in entries:
            mname, aname = e["kernel"].split(":")
            disp = getattr(importlib.import_module(mname), aname)
            assert hasattr(disp, "compile")
            assert all(isinstance(pickle.loads(base64.b64decode(s)), tuple) for s in e["sigs"])
    if not checked:
        pytest.skip("no record for this numba and Python")


def test_shipped_records_are_not_stale():
    """A record of a shipped scene made with this numba and Python must be found under the
    scene's current kernel key: a scene or section change since the record (a new key, a
    new choice) changes that key, and a stale record makes a first run compile on one core
    (the axisymmetric droplet job's cold start was 60.5 s with a stale record, 41.9 s
    re-recorded, 2026-12-04).  Mend:
    ``python -m sphfem.jit_warmup --record examples/droplet_impact/droplet_impact.toml
    examples/droplet_impact/droplet_impact_axisymmetric.toml``."""
    import numba

    from sphfem.jit_warmup import SIGNATURES, recorded

    scenes = json.loads(SIGNATURES.read_text())["scenes"]
    here = {"numba": numba.__version__, "python": list(sys.version_info[:2])}
    same = [v["scene"] for v in scenes.values()
            if all(v.get(a) == b for a, b in here.items())]
    if not same:
        pytest.skip("no record for this numba and Python")
    for name in same:
        assert recorded(load_scene(DROPLET.parent / name)) is not None, (
            f"the record of {name} is stale: re-record it (see this test's docstring)")
