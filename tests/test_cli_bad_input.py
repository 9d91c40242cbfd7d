"""`sphfem run` on bad input (issue 8): a malformed scene or a set-up fault (mesh file missing
or corrupt, unknown mesh group, overlapping blocks) ends with one line on stderr naming the
key, exit code 2, no traceback, and nothing written -- before any time step.

The scenes are driven through the real command line in-process (``sphfem.cli.main``), plus
one subprocess run.  The load-level property tests of every key are in test_scene.py; here
the point is the whole path file -> CLI -> exit code -> file system.
"""

from __future__ import annotations

import copy
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import pytest
from builders import Raw, to_toml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sphfem import schema
from sphfem.cli import main
from sphfem.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]

# A water droplet over a steel substrate, fluid + heat + FEM coupling (2D, 16 x 16 cells).
SCENE = {
    "scene": {"name": "puddle", "dim": 2, "seed": 7},
    "domain": {"lo": [0.0, -0.004], "hi": [0.02, 0.012]},
    "sph": {"dx": 1.0e-3, "kernel": "wendland_c2"},
    "materials": {
        "water": {"rho0": 1000.0, "c": 4186.0, "k": 0.6, "mu": 1.0e-3, "c0": 10.0},
        "steel": {"rho0": 7850.0, "c": 460.0, "k": 45.0, "E": 2.0e11, "nu": 0.3,
                  "alpha": 1.2e-5},
    },
    "blocks": [
        {"name": "substrate", "shape": "box", "kind": "wall", "material": "steel",
         "lo": [0.0, -0.003], "hi": [0.02, 0.0], "temperature": "20 C"},
        {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
         "center": [0.01, 0.004], "radius": 0.003, "velocity": [0.0, -0.5],
         "temperature": "80 C"},
    ],
    "physics": {"modules": ["fluid", "heat", "coupling"]},
    "fluid": {"alpha": 0.05},
    "heat": {"laplacian": "cleary"},
    "coupling": {"material": "steel", "clamps": ["left", "right"], "every_k_steps": 2,
                 "mesh": {"h_fine": 2.0e-3, "cells": "tri"}},
    "time": {"t_end": 1.0e-3, "max_steps": 3},
    "output": {"every": 5.0e-4},
}


def changed(path: str, value=None, delete: bool = False, base: dict = SCENE) -> dict:
    """A copy of ``base`` with the dotted ``path`` (digits index arrays) set or deleted."""
    d = copy.deepcopy(base)
    *head, last = [int(p) if p.isdigit() else p for p in path.split(".")]
    node = d
    for p in head:
        node = node[p]
    if delete:
        del node[last]
    else:
        node[last] = value
    return d


def key_name(path: str) -> str:
    """Dotted path -> the key as sphfem names it: ``blocks.1.radius`` -> ``blocks[1].radius``."""
    return re.sub(r"\.(\d+)", r"[\1]", path)


# -- running the CLI ------------------------------------------------------------------------

def run_cli(capsys, folder: Path, scene, *extra) -> tuple[int, str, str, Path]:
    """Write ``scene`` (dict, text or bytes) to folder/scene.toml and ``sphfem run`` it."""
    f = folder / "scene.toml"
    if isinstance(scene, dict):
        scene = to_toml(scene)
    if isinstance(scene, str):
        scene = scene.encode("utf-8")
    f.write_bytes(scene)
    out = folder / "out"
    capsys.readouterr()
    rc = main(["run", str(f), "--out", str(out), "--no-progress", *extra])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err, out


def assert_rejected(rc, out, err, out_dir, folder, before, *needles) -> str:
    """Exit 2, one stderr line ``sphfem: error: ...`` holding every needle, no traceback,
    nothing printed on stdout, no output folder, no new file in ``folder``."""
    assert "Traceback" not in out + err, err
    assert rc == 2, (rc, err)
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n") and err.count("\n") == 1, err
    line = lines[0]
    assert line.startswith("sphfem: error: ") and line.strip() != "sphfem: error:", line
    for n in needles:
        assert n in line, (n, line)
    assert out == ""
    assert not out_dir.exists()
    assert sorted(os.listdir(folder)) == before
    return line


@pytest.fixture
def no_stepping(monkeypatch):
    """Fail the test if the simulation is ever run (errors must come before any step)."""
    from sphfem.simulation import Simulation

    calls = []

    def refuse(self, *a, **kw):
        calls.append(1)
        raise AssertionError("Simulation.run reached: the error came too late")

    monkeypatch.setattr(Simulation, "run", refuse)
    return calls


def test_writer_round_trips_and_base_scene_is_valid(tmp_path):
    assert tomllib.loads(to_toml(SCENE)) == SCENE
    f = tmp_path / "s.toml"
    f.write_text(to_toml(SCENE))
    s = load_scene(f)
    assert [b.name for b in s.blocks] == ["substrate", "droplet"]
    assert s.physics.modules == ("fluid", "heat", "coupling")


# -- property test: generated malformed scenes ---------------------------------------------

_nasty_text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=8)
_wrong_for_number = st.one_of(
    _nasty_text, st.booleans(), st.lists(st.floats(-10, 10), max_size=3),
    st.dictionaries(st.from_regex(r"[a-z]{1,3}", fullmatch=True), st.integers(), max_size=2),
    st.just(Raw("1979-05-27")), st.just(Raw("07:32:00")))
_wrong_for_string = st.one_of(
    st.integers(-10**6, 10**6), st.floats(allow_nan=False), st.booleans(),
    st.lists(st.integers(), max_size=2), st.just(Raw("1979-05-27T07:32:00Z")))


def _fraction(lo: float, hi: float):  # integral floats (7.0) count as integers
    return st.floats(lo, hi).filter(lambda x: x != int(x))


def _wrong_vector(n: int):
    return st.one_of(
        _nasty_text, st.booleans(), st.floats(-1.0, 1.0),
        st.lists(st.floats(-1e-2, 1e-2), max_size=4).filter(lambda v: len(v) != n),
        st.lists(st.one_of(_nasty_text, st.booleans()), min_size=n, max_size=n))


def _not_in(choices):
    return _nasty_text.filter(lambda t: t not in choices)


def _choices(section: str, name: str):
    return schema.all_sections()[section].param(name).choices


# wrong types: (path, strategy of a value of the wrong type)
WRONG_TYPE = {
    "sph.dx": _wrong_for_number,
    "sph.support_factor": _wrong_for_number,
    "materials.water.rho0": _wrong_for_number,
    "materials.steel.nu": _wrong_for_number,
    "materials.steel.E": _wrong_for_number,
    "time.t_end": _wrong_for_number,
    "output.every": _wrong_for_number,
    "blocks.1.radius": _wrong_for_number,
    "fluid.alpha": _wrong_for_number,
    "scene.dim": st.one_of(_nasty_text, _fraction(1.1, 2.9), st.booleans(),
                           st.lists(st.integers(), max_size=2)),
    "scene.seed": st.one_of(_nasty_text, st.floats(0.1, 0.9), st.lists(st.integers(),
                                                                        max_size=2)),
    "time.max_steps": st.one_of(_nasty_text, _fraction(1.1, 9.9)),
    "sph.kernel": _wrong_for_string,
    "blocks.0.shape": _wrong_for_string,
    "blocks.1.kind": _wrong_for_string,
    "blocks.1.material": _wrong_for_string,
    "heat.laplacian": _wrong_for_string,
    "coupling.material": _wrong_for_string,
    "domain.lo": _wrong_vector(2),
    "blocks.1.center": _wrong_vector(2),
    "blocks.1.velocity": _wrong_vector(2),
    "blocks.1.temperature": st.one_of(st.booleans(), st.lists(st.integers(), max_size=2)),
    "physics.modules": st.one_of(_nasty_text, st.integers(), st.lists(st.integers(),
                                                                      min_size=1, max_size=2)),
    "coupling.clamps": st.one_of(st.integers(), st.lists(st.integers(), min_size=1,
                                                         max_size=2)),
}

# out-of-range values
OUT_OF_RANGE = {
    "sph.dx": st.one_of(st.floats(max_value=0.0), st.just(math.nan)),
    "sph.support_factor": st.floats(max_value=1.0),
    "sph.kernel": _not_in(_choices("sph", "kernel")),
    "materials.water.rho0": st.one_of(st.floats(max_value=0.0), st.integers(max_value=0)),
    "materials.steel.rho0": st.floats(max_value=0.0),
    "materials.steel.nu": st.one_of(st.floats(min_value=0.5), st.floats(max_value=-1.0)),
    "time.t_end": st.one_of(st.floats(max_value=0.0), st.integers(-100, 0)),
    "time.cfl": st.one_of(st.floats(max_value=0.0), st.floats(min_value=1.0,
                                                              exclude_min=True)),
    "time.max_steps": st.integers(-100, 0),
    "scene.dim": st.integers(-10, 10).filter(lambda i: i not in (1, 2, 3)),
    "scene.seed": st.integers(-10**6, -1),
    "output.every": st.floats(max_value=0.0),
    "output.format": _not_in(_choices("output", "format")),
    "blocks.0.shape": _not_in(_choices("blocks", "shape")),
    "blocks.1.kind": _not_in(_choices("blocks", "kind")),
    "blocks.1.radius": st.floats(max_value=0.0),
    "blocks.1.temperature": st.one_of(st.floats(max_value=0.0),
                                      st.floats(-1e4, -273.151).map(lambda c: f"{c!r} C")),
    "heat.laplacian": _not_in(_choices("heat", "laplacian")),
    "heat.theta": st.one_of(st.floats(max_value=0.5, exclude_max=True),
                            st.floats(min_value=1.0, exclude_min=True)),
    "fluid.alpha": st.floats(max_value=0.0, exclude_max=True),
    "coupling.every_k_steps": st.integers(-100, 0),
    "coupling.element": _not_in(_choices("coupling", "element")),
    "coupling.mesh.h_fine": st.floats(max_value=0.0),
}

REQUIRED = ["scene.dim", "domain.lo", "domain.hi", "sph.dx", "materials.water.rho0",
            "materials.steel.rho0", "blocks.0.kind", "blocks.1.material", "blocks.0.lo",
            "blocks.1.radius", "time.t_end", "coupling.material"]

# sections a key can be added to, and the keys each already knows
SECTIONS = {
    "scene": "scene", "domain": "domain", "sph": "sph", "time": "time", "output": "output",
    "physics": "physics", "fluid": "fluid", "heat": "heat", "coupling": "coupling",
    "coupling.mesh": "coupling.mesh", "materials.water": "materials",
    "materials.steel": "materials", "blocks.0": "blocks", "blocks.1": "blocks",
}


def _known_keys(kind: str) -> set[str]:
    secs = schema.all_sections()
    if kind == "coupling.mesh":
        return set(secs["coupling"].subsections[0].keys)
    return set(secs[kind].keys)


_ident = st.from_regex(r"[A-Za-z_][A-Za-z0-9_-]{0,11}", fullmatch=True)

# lines that are invalid TOML wherever they stand (between two lines of the scene)
BROKEN_LINES = ["zz_broken = ", "[unclosed", "zz_broken = \"no end quote", "= 1",
                "zz_broken = 1 2", "zz_broken = tru", "zz_broken = 0x", "[[blocks]",
                "zz_broken = [1, 2]]", "zz_broken = 1979-13-45", "zz broken = 1"]


MISTAKES = ["wrong type", "out of range", "unknown key", "unknown section", "missing key",
            "missing section", "unknown material", "not a table", "broken TOML"]


def _one_mistake(draw, how: str) -> tuple[bytes, str]:
    """(scene file bytes, text the error line must contain): SCENE with one mistake."""
    if how in ("wrong type", "out of range"):
        table = WRONG_TYPE if how == "wrong type" else OUT_OF_RANGE
        path = draw(st.sampled_from(sorted(table)))
        return to_toml(changed(path, draw(table[path]))).encode(), f": {key_name(path)}: "
    if how == "unknown key":
        where = draw(st.sampled_from(sorted(SECTIONS)))
        name = draw(_ident.filter(lambda n: n not in _known_keys(SECTIONS[where])))
        value = draw(st.one_of(st.integers(), st.floats(allow_nan=False), _nasty_text))
        return (to_toml(changed(f"{where}.{name}", value)).encode(),
                f": {key_name(where)}.{name}: ")
    if how == "unknown section":
        name = draw(_ident.filter(lambda n: n not in SCENE))
        return to_toml({**SCENE, name: {"x": 1}}).encode(), f": {name}: "
    if how == "missing key":
        path = draw(st.sampled_from(REQUIRED))
        return to_toml(changed(path, delete=True)).encode(), f": {key_name(path)}: "
    if how == "missing section":
        name = draw(st.sampled_from(["scene", "domain", "sph", "materials", "time", "blocks"]))
        # without [materials], the first block's material is the first unknown name
        key = "blocks[0].material" if name == "materials" else name
        return (to_toml({k: v for k, v in SCENE.items() if k != name}).encode(),
                f": {key}: ")
    if how == "unknown material":
        i = draw(st.sampled_from([0, 1]))
        name = draw(_nasty_text.filter(lambda n: n not in SCENE["materials"]))
        return (to_toml(changed(f"blocks.{i}.material", name)).encode(),
                f": blocks[{i}].material: ")
    if how == "not a table":
        name = draw(st.sampled_from(["scene", "domain", "sph", "time", "output", "physics",
                                     "fluid", "heat", "coupling", "materials",
                                     "materials.water", "blocks", "blocks.1",
                                     "coupling.mesh"]))
        value = draw(st.one_of(st.integers(), _nasty_text, st.lists(st.integers(),
                                                                    max_size=2)))
        key = "blocks[0]" if name == "blocks" and value and isinstance(value, list) else \
            key_name(name)  # [[blocks]] is an array: its first item is the culprit
        return to_toml(changed(name, value)).encode(), f": {key}: "
    lines = to_toml(SCENE).splitlines()
    k = draw(st.integers(0, len(lines)))
    lines.insert(k, draw(st.sampled_from(BROKEN_LINES)))
    return ("\n".join(lines) + "\n").encode(), f": line {k + 1}: "


@pytest.mark.parametrize("how", MISTAKES)
@settings(max_examples=int(os.environ.get("SPHFEM_BAD_INPUT_EXAMPLES", "30")), deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_property_malformed_scene_one_line_exit_2_nothing_written(how, data, capsys,
                                                                   no_stepping):
    """Each generated scene has one mistake of kind ``how`` (invalid by construction)."""
    text, needle = _one_mistake(data.draw, how)
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        rc, out, err, out_dir = run_cli(capsys, folder, text)
        assert_rejected(rc, out, err, out_dir, folder, ["scene.toml"], needle)
    assert not no_stepping


@pytest.mark.parametrize("content, needles", [
    (b"", ["missing required section [scene]"]),
    (b"\xff\xfe[scene]\n", ["not UTF-8"]),
    ("\ufeff" + to_toml(SCENE), ["line 1"]),  # a byte-order mark is not TOML
    (to_toml(SCENE) + "\n[sph]\ndx = 1e-3\n",  # a table declared twice
     [f": line {to_toml(SCENE).count(chr(10)) + 2}: ", "invalid TOML"]),
])
def test_unreadable_scene_text(content, needles, tmp_path, capsys, no_stepping):
    rc, out, err, out_dir = run_cli(capsys, tmp_path, content)
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], *needles)


def test_scene_file_missing_or_a_folder(tmp_path, capsys):
    for target, why in ((tmp_path / "nope.toml", "cannot read scene file"),
                        (tmp_path, "cannot read scene file")):
        rc = main(["run", str(target), "--out", str(tmp_path / "out"), "--no-progress"])
        cap = capsys.readouterr()
        assert_rejected(rc, cap.out, cap.err, tmp_path / "out", tmp_path, [], why)


def test_output_folder_that_cannot_be_made(tmp_path, capsys, no_stepping):
    """--out under a regular file: one line, before the (costly) set-up, not a traceback."""
    f = tmp_path / "scene.toml"
    f.write_text(to_toml(SCENE))
    rc = main(["run", str(f), "--out", str(f / "out"), "--no-progress"])
    cap = capsys.readouterr()
    line = assert_rejected(rc, cap.out, cap.err, tmp_path / "out", tmp_path, ["scene.toml"],
                           "cannot create the output folder", "is not a folder")
    assert str(f) in line


def test_subprocess_malformed_scene(tmp_path):
    """The real process: `python -m sphfem.cli run bad.toml --out OUT` (this checkout)."""
    bad = tmp_path / "bad.toml"
    bad.write_text(to_toml(changed("materials.water.rho0", -1000.0)))
    out = tmp_path / "OUT"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}
    r = subprocess.run([sys.executable, "-m", "sphfem.cli", "run", str(bad), "--out", str(out),
                        "--no-progress"], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path, env=env)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0] == (f"sphfem: error: {bad}: materials.water.rho0: expected a positive "
                        "density in kg/m^3, got -1000.0")
    assert r.stdout == "" and not out.exists()
    assert sorted(os.listdir(tmp_path)) == ["bad.toml"]


# -- set-up faults: meshes and blocks -------------------------------------------------------

@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    """A valid 2D substrate mesh for SCENE (groups top, bottom, left, right) and a 3D one."""
    from sphfem.fem.meshing import substrate_block, substrate_rect

    folder = tmp_path_factory.mktemp("meshes")
    old = os.environ.get("SPHFEM_CACHE")
    os.environ["SPHFEM_CACHE"] = str(folder / "cache")
    try:
        rect = substrate_rect(path=folder / "rect.msh", size=(0.02, 0.003),
                              origin=(0.0, -0.003), h_fine=2e-3, h_coarse=4e-3,
                              refine_center=(0.01, 0.0), refine_radius=0.004, element="tri")
        block = substrate_block(path=folder / "block.msh", size=(0.02, 0.02, 0.003),
                                origin=(0.0, 0.0, -0.003), h_fine=5e-3, h_coarse=1e-2,
                                refine_center=(0.01, 0.01, 0.0), refine_radius=0.004,
                                element="tet")
    finally:
        if old is None:
            os.environ.pop("SPHFEM_CACHE")
        else:
            os.environ["SPHFEM_CACHE"] = old
    return {"rect": Path(rect), "block": Path(block)}


# the set-up tests leave the fluid module out: it only adds JIT compilation on a cold cache
HEAT_ONLY = changed("physics.modules", ["heat", "coupling"])
del HEAT_ONLY["fluid"]


def with_mesh_file(path, **coupling) -> dict:
    d = copy.deepcopy(HEAT_ONLY)
    del d["coupling"]["mesh"]
    d["coupling"]["mesh_file"] = str(path)
    d["coupling"].update(coupling)
    return d


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path.parent / f"{tmp_path.name}-cache"))


def test_control_scene_with_mesh_file_runs(tmp_path, capsys, meshes, cache):
    """The scene the faults below break runs as is (so the faults are what stops them)."""
    rc, out, err, out_dir = run_cli(capsys, tmp_path, with_mesh_file(meshes["rect"]), "--json")
    assert rc == 0, err
    assert json.loads(out)["steps"] >= 1
    assert (out_dir / "summary.json").exists() and (out_dir / "substrate").is_dir()


def test_mesh_file_missing(tmp_path, capsys, cache, no_stepping):
    rc, out, err, out_dir = run_cli(capsys, tmp_path, with_mesh_file("nope.msh"))
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"],
                    ": coupling.mesh_file: ", "mesh file not found", str(tmp_path / "nope.msh"))
    assert not no_stepping


def _nodes_only():
    return (b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n"
            b"$EndNodes\n")


@pytest.mark.parametrize("name, content", [
    ("garbage.msh", lambda m: b"$MeshFormat\n4.1 0 8\nthis is not a mesh\n"),
    ("empty.msh", lambda m: b""),
    ("binary.msh", lambda m: bytes(range(256)) * 4),
    ("truncated.msh", lambda m: m["rect"].read_bytes()[: len(m["rect"].read_bytes()) // 2]),
    ("nodes_only.msh", lambda m: _nodes_only()),  # used to escape as NotImplementedError
    ("mesh.xyz", lambda m: b"1 2 3\n"),
])
def test_mesh_file_corrupt(name, content, tmp_path, capsys, meshes, cache, no_stepping):
    f = tmp_path / name
    f.write_bytes(content(meshes))
    rc, out, err, out_dir = run_cli(capsys, tmp_path, with_mesh_file(f))
    assert_rejected(rc, out, err, out_dir, tmp_path, sorted([name, "scene.toml"]),
                    ": coupling.mesh_file: ", "could not be read", str(f))
    assert not no_stepping


@pytest.mark.parametrize("change, key", [
    ({"clamps": ["left", "nonexistent"]}, "coupling.clamps[1]"),
    ({"clamps": [], "rollers": {"nonexistent": "y"}}, "coupling.rollers.nonexistent"),
    ({"surface": "nonexistent"}, "coupling.surface"),
])
def test_mesh_without_the_named_group(change, key, tmp_path, capsys, meshes, cache,
                                      no_stepping):
    rc, out, err, out_dir = run_cli(capsys, tmp_path, with_mesh_file(meshes["rect"], **change))
    line = assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], f": {key}: ",
                           "no boundary group 'nonexistent'",
                           "available: bottom, left, right, top", str(meshes["rect"]))
    assert line.startswith(f"sphfem: error: {tmp_path / 'scene.toml'}: {key}: ")
    assert not no_stepping


def test_recipe_mesh_without_the_named_group(tmp_path, capsys, cache, no_stepping):
    """Same check for the mesh [coupling.mesh] builds (the 2D recipe has no 'front')."""
    rc, out, err, out_dir = run_cli(capsys, tmp_path,
                                    changed("coupling.clamps", ["left", "front"], base=HEAT_ONLY))
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], ": coupling.clamps[1]: ",
                    "recipe's mesh has no boundary group 'front'",
                    "available: bottom, left, right, top")
    assert not no_stepping


def test_mesh_file_of_the_wrong_dimension(tmp_path, capsys, meshes, cache, no_stepping):
    rc, out, err, out_dir = run_cli(capsys, tmp_path, with_mesh_file(meshes["block"]))
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], ": coupling.mesh_file: ",
                    "is 3D but the scene is 2D")
    assert not no_stepping


@pytest.mark.parametrize("droplet_first", [False, True])
def test_droplet_inside_the_substrate(droplet_first, tmp_path, capsys, meshes, cache,
                                      no_stepping):
    d = changed("blocks.1.center", [0.01, -0.0015], base=with_mesh_file(meshes["rect"]))
    d = changed("blocks.1.radius", 0.001, base=d)
    if droplet_first:
        d["blocks"].reverse()
    i, j = (0, 1) if droplet_first else (1, 0)
    rc, out, err, out_dir = run_cli(capsys, tmp_path, d)
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], f": blocks[{i}]: ",
                    f"block 'droplet' lies inside block 'substrate' (blocks[{j}])")
    assert not no_stepping


@pytest.mark.parametrize("y", [0.0, 0.5e-3])  # 0.5e-3: lattices staggered by exactly dx/2
def test_overlapping_blocks(y, tmp_path, capsys, meshes, cache, no_stepping):
    """The droplet sunk into the substrate: overlap, named with both blocks."""
    d = changed("blocks.1.center", [0.01, y], base=with_mesh_file(meshes["rect"]))
    rc, out, err, out_dir = run_cli(capsys, tmp_path, d)
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], ": blocks[1]: ",
                    "block 'droplet' overlaps block 'substrate' (blocks[0])",
                    "closer than dx/2")
    assert not no_stepping


def test_two_wall_blocks_overlapping(tmp_path, capsys, cache, no_stepping):
    d = copy.deepcopy(SCENE)
    d["blocks"].append({"name": "post", "shape": "box", "kind": "wall", "material": "steel",
                        "lo": [0.015, -0.001], "hi": [0.018, 0.004]})
    rc, out, err, out_dir = run_cli(capsys, tmp_path, d)
    assert_rejected(rc, out, err, out_dir, tmp_path, ["scene.toml"], ": blocks[2]: ",
                    "block 'post' overlaps block 'substrate' (blocks[0])")
    assert not no_stepping
