"""``sphfem run`` is :func:`sphfem.api.run` (issue 15: one run logic): the command line and
the library write the same ``summary.json`` and outputs, show the same set-up stage lines,
and treat ``--overwrite`` / ``--resume`` / ``--keep-checkpoint`` alike; the command line only
words the errors for a shell (one line, exit code 2) and prints a summary.

The scene is the heat-rod example (the stopped run: test_api_docs' unstable fluid column).
"""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest
from builders import to_toml
from test_api_docs import UNSTABLE

import sphfem
from sphfem import api
from sphfem.cli import main
from sphfem.errors import OutputFolderError, SceneError

ROOT = Path(__file__).resolve().parents[1]
#: the heat-rod example (1D, 80 particles, implicit heat), with an output half-way so that
#: a checkpoint is written
HEAT_ROD = tomllib.loads((ROOT / "examples" / "heat_rod" / "heat_rod.toml").read_text())
HEAT_ROD["output"] = {"every": HEAT_ROD["time"]["t_end"] / 2}

#: summary.json entries that measure the machine (seconds, memory, dates, compilations)
#: rather than the run; every other entry must be equal between the two ways of running
MEASURED = re.compile(r"(_s|_mb|_per_s)$|^(setup|process_s|versions|numba|started|"
                      r"finished|date|host|wall_s_per_module|compil)")


def _scene(tmp_path, scene=HEAT_ROD):
    f = tmp_path / f"{scene['scene']['name']}.toml"
    f.write_text(to_toml(scene))
    return f


def _shape(d, path=""):
    """Every key path of a nested dict, e.g. ``dt.min``."""
    if not isinstance(d, dict):
        return set()
    out = set()
    for k, v in d.items():
        p = f"{path}.{k}" if path else k
        out |= {p} | _shape(v, p)
    return out


def _run_figures(d):
    """The entries of a summary that describe the run, not the machine or the folder."""
    if isinstance(d, dict):
        return {k: _run_figures(v) for k, v in d.items()
                if not MEASURED.search(k) and k not in ("checkpoint", "scene_file", "out")}
    if isinstance(d, list):
        return [_run_figures(v) for v in d]
    return d


def _summary(out):
    return json.loads((out / "summary.json").read_text())


def test_cli_and_api_write_the_same_run(tmp_path, capsys):
    f = _scene(tmp_path)
    assert main(["run", str(f), "--out", str(tmp_path / "cli")]) == 0
    cli_err = capsys.readouterr().err
    res = sphfem.run(f, out=tmp_path / "api", progress=True)
    api_err = capsys.readouterr().err
    a, b = _summary(tmp_path / "cli"), _summary(tmp_path / "api")
    assert res.summary == b
    assert _shape(a) == _shape(b)
    assert a["status"] == b["status"] == "completed" and a["steps"] == b["steps"] > 0
    assert _run_figures(a) == _run_figures(b)
    assert sorted(p.name for p in (tmp_path / "cli").iterdir()) == \
        sorted(p.name for p in (tmp_path / "api").iterdir())

    def stages(err):  # the stage lines without their figures (seconds, MB); numba compiles
        return [re.sub(r"[-+]?\d[\d.e+-]*", "#", ln) for ln in err.splitlines()  # once
                if ln.startswith("sphfem: ") and "compiling numba" not in ln]

    assert stages(cli_err) and stages(cli_err) == stages(api_err)


def test_overwrite_resume_and_keep_checkpoint_alike(tmp_path, capsys):
    f = _scene(tmp_path)
    cli, lib = tmp_path / "cli", tmp_path / "api"
    assert main(["run", str(f), "--out", str(cli), "--no-progress", "--keep-checkpoint"]) == 0
    sphfem.run(f, out=lib, keep_checkpoint=True)
    assert (cli / "checkpoint.npz").exists() and (lib / "checkpoint.npz").exists()
    # an existing folder is refused, each in its own words, and left as it was
    capsys.readouterr()
    assert main(["run", str(f), "--out", str(cli), "--no-progress"]) == 2
    assert "pass --overwrite to replace it" in capsys.readouterr().err
    with pytest.raises(sphfem.OutputExistsError, match="pass overwrite=True to replace it"):
        sphfem.run(f, out=lib)
    # --resume continues from the checkpoint (at t_end: no further step), then deletes it
    assert main(["run", str(f), "--out", str(cli), "--no-progress", "--resume"]) == 0
    sphfem.run(f, out=lib, resume=True)
    a, b = _summary(cli), _summary(lib)
    assert a["resumed"] and _shape(a) == _shape(b)
    assert _run_figures(a) == _run_figures(b)
    assert not (cli / "checkpoint.npz").exists() and not (lib / "checkpoint.npz").exists()
    # --overwrite starts afresh
    assert main(["run", str(f), "--out", str(cli), "--no-progress", "--overwrite"]) == 0
    sphfem.run(f, out=lib, overwrite=True)
    a, b = _summary(cli), _summary(lib)
    assert not a.get("resumed") and _run_figures(a) == _run_figures(b)


def test_a_failed_set_up_is_a_scene_error_with_the_cli_line(tmp_path, capsys, monkeypatch):
    """A set-up failing on the scene's inputs (here a stand-in ValueError) stops before
    any output: the library raises SceneError naming the file (the cause chained), the
    command line prints the same text as its one error line."""
    from sphfem.simulation import Simulation

    def broken(self, scene, source=None, particles=None):
        raise ValueError("mesh  group\n'top' is empty")

    monkeypatch.setattr(Simulation, "__init__", broken)
    f = _scene(tmp_path)
    with pytest.raises(SceneError) as info:
        sphfem.run(f, out=tmp_path / "api")
    assert str(info.value) == f"{f}: set-up failed: mesh group 'top' is empty"
    assert isinstance(info.value.__cause__, ValueError)
    capsys.readouterr()
    assert main(["run", str(f), "--out", str(tmp_path / "cli"), "--no-progress"]) == 2
    assert capsys.readouterr().err == f"sphfem: error: {info.value}\n"
    assert not (tmp_path / "api").exists() and not (tmp_path / "cli").exists()


def test_an_output_folder_that_cannot_be_made(tmp_path, capsys, monkeypatch):
    """Under a regular file: refused before the set-up, by both, in the same words."""
    from sphfem.simulation import Simulation

    def never(*a, **k):
        raise AssertionError("set-up reached")

    monkeypatch.setattr(Simulation, "__init__", never)
    f = _scene(tmp_path)
    with pytest.raises(OutputFolderError) as info:
        api.run(f, out=f / "out")
    assert isinstance(info.value, OSError)
    assert str(info.value) == f"{f / 'out'}: cannot create the output folder: {f} is not a folder"
    capsys.readouterr()
    assert main(["run", str(f), "--out", str(f / "out"), "--no-progress"]) == 2
    assert capsys.readouterr().err == f"sphfem: error: {info.value}\n"


def test_a_stopped_run(tmp_path, capsys):
    """A guard's stop: the library raises RunStopped with the
    written result, the command line prints the same message and exits 1; both write the
    same summary."""
    f = _scene(tmp_path, UNSTABLE)  # a fixed step moves the fluid a whole dx per step
    with pytest.raises(api.RunStopped) as info:
        sphfem.run(f, out=tmp_path / "api")
    assert info.value.result.status == "stopped"
    capsys.readouterr()
    assert main(["run", str(f), "--out", str(tmp_path / "cli"), "--no-progress"]) == 1
    assert capsys.readouterr().err == f"sphfem: run stopped: {info.value}\n"
    assert _run_figures(_summary(tmp_path / "cli")) == _run_figures(_summary(tmp_path / "api"))
