"""Command-line contract: exit codes, JSON layout, one-line errors."""

import json
import subprocess
import sys

import pytest

from sphfem.cli import main


def test_help_exits_zero(capsys):
    assert main(["--help"]) == 0
    assert "validate" in capsys.readouterr().out


def test_no_command_is_usage_error(capsys):
    assert main([]) == 2


def test_validate_list(capsys):
    assert main(["validate", "--list"]) == 0
    out = capsys.readouterr().out
    assert "laplacian" in out and "gradient" in out
    assert "stability" in out and "heat-dt-2x-capped" in out and "all" in out


def test_validate_stability_unknown_row_is_usage_error(tmp_path, capsys):
    assert main(["validate", "stability", "--quick", "--only", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown row(s) nope" in err[0]


def test_unknown_case_is_usage_error(capsys):
    assert main(["validate", "no-such-case"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no-such-case" in err[0]


@pytest.mark.parametrize("case", ["laplacian", "gradient"])
def test_validate_json_contract(case, tmp_path, capsys):
    f = tmp_path / f"{case}.json"
    png = tmp_path / f"{case}.png"
    assert main(["validate", case, "--quick", "--json", str(f), "--plot", str(png)]) == 0
    d = json.loads(f.read_text())
    assert d["case"] == case and d["passed"] is True
    assert set(d) >= {"case", "runs", "observed_order", "criteria", "passed"}
    for r in d["runs"]:
        keys = {"variant", "resolution", "n_particles", "error_l2", "error_linf", "wall_s"}
        assert set(r) >= keys
    assert png.stat().st_size > 1000
    out = capsys.readouterr().out
    assert "PASSED" in out


def test_console_script_entry_point():
    r = subprocess.run([sys.executable, "-m", "sphfem.cli", "--help"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "run" in r.stdout


def test_validate_warms_up_unless_told_not_to(tmp_path, capsys):
    """A case's timed runs follow an untimed warm-up (reported in the notes);
    --no-warmup times them cold."""
    assert main(["validate", "laplacian", "--quick", "--json", str(tmp_path / "w.json")]) == 0
    assert "note: untimed warm-up before the timed runs" in capsys.readouterr().out
    assert any("warm-up" in n for n in json.loads((tmp_path / "w.json").read_text())["notes"])
    assert main(["validate", "laplacian", "--quick", "--no-warmup"]) == 0
    assert "warm-up" not in capsys.readouterr().out
