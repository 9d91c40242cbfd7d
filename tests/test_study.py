"""``study.py --plots-only`` analyses the run's own scene (issue 14, bug 6).

It used to analyse the default scene unless ``--scene`` was given: a 30 m/s run was
reported at 50 m/s with the wrong tc = D / v.  The scene now comes from the run's
summary.json (which records the resolved scene); a ``--scene`` that differs from it is an
error.
"""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "droplet_impact"


@pytest.fixture(scope="module")
def study():
    from builders import load_example

    return load_example(EXAMPLE / "study.py", "droplet_study")


def _toml(data: dict) -> str:
    """Minimal TOML writer for a scene dict (tables, arrays of tables, scalars, lists)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    lines = []

    def table(name, d):
        subs = {k: x for k, x in d.items() if isinstance(x, dict)}
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {val(x)}" for k, x in d.items()
                     if x is not None and not isinstance(x, dict))
        for k, x in subs.items():
            table(f"{name}.{k}", x)

    for name, d in data.items():
        if isinstance(d, list):
            for item in d:
                lines.append(f"[[{name}]]")
                lines.extend(f"{k} = {val(x)}" for k, x in item.items() if x is not None)
        else:
            table(name, d)
    return "\n".join(lines) + "\n"


def _run_dir(tmp_path, speed):
    """A run folder whose summary.json records the default scene at ``speed`` m/s."""
    from sphfem.scene import parse_scene

    data = tomllib.loads((EXAMPLE / "droplet_impact.toml").read_text())
    data = copy.deepcopy(data)
    next(b for b in data["blocks"] if b["kind"] == "fluid")["velocity"] = [0.0, 0.0, -speed]
    scene = parse_scene(data, source="recorded")
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"scene": scene.to_dict()}))
    return out, data


def test_plots_only_analyses_the_recorded_scene(tmp_path, monkeypatch, study):
    out, data = _run_dir(tmp_path, speed=30.0)
    seen = {}
    monkeypatch.setattr(study, "analyse", lambda o, d: seen.update(out=o, data=d) or {})
    assert study.main(["--out", str(out), "--plots-only"]) == 0
    assert seen["out"] == out
    drop = next(b for b in seen["data"]["blocks"] if b["kind"] == "fluid")
    assert drop["velocity"] == [0.0, 0.0, -30.0]  # the old code analysed 50 m/s
    D, v, tc = study.case_scales(seen["data"])
    assert (D, v) == (1.0e-4, 30.0)
    assert tc == pytest.approx(1.0e-4 / 30.0, rel=1e-15)

    # the same scene given explicitly is accepted; the default (50 m/s) one is refused
    same = tmp_path / "same.toml"
    same.write_text(_toml(data))
    assert study.main(["--out", str(out), "--plots-only", "--scene", str(same)]) == 0
    with pytest.raises(SystemExit, match="is not the scene of the run"):
        study.main(["--out", str(out), "--plots-only", "--scene",
                    str(EXAMPLE / "droplet_impact.toml")])


def test_plots_only_without_a_finished_run_says_so(tmp_path, study):
    with pytest.raises(SystemExit, match="needs a finished run"):
        study.main(["--out", str(tmp_path), "--plots-only"])
