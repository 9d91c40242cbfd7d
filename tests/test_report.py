"""``sphfem validate all``: a report section per case; a failing or broken case is reported,
the others still run, and the verdict fails."""

import json

from sphfem.cli import main
from sphfem.validation import CaseResult, Criterion, Run
from sphfem.validation import report as rep


def _good(quick):
    runs = [Run("v", h, 10, 0.1 * h**2, 0.2 * h**2, 0.01) for h in (0.1, 0.05)]
    return CaseResult("good", runs, {"order": Criterion("observed order", 2.0, 1.5, ">=")})


def _broken(quick):
    raise RuntimeError("mesh file missing")


def test_validate_all_report(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(rep, "load_cases", lambda: {"good": _good, "broken": _broken})
    out = tmp_path / "report"
    assert main(["validate", "all", "--quick", "--out", str(out)]) == 1
    text = (out / "report.md").read_text()
    assert "## good: PASSED" in text and "## broken: ERROR" in text
    assert "mesh file missing" in text and "| good | passed |" in text
    assert json.loads((out / "good.json").read_text())["passed"] is True
    assert (out / "good.png").stat().st_size > 1000
    # an existing report folder is not clobbered without --overwrite
    assert main(["validate", "all", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_validate_all_needs_out(capsys):
    assert main(["validate", "all"]) == 2
    assert "--out" in capsys.readouterr().err


def test_update_readme_replaces_marked_block(tmp_path, monkeypatch):
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{rep.README_BEGIN}\nold table\n{rep.README_END}\nrest\n")
    monkeypatch.setattr(rep, "load_cases", lambda: {"good": _good})
    assert main(["validate", "all", "--out", str(tmp_path / "r"),
                 "--update-readme", str(readme)]) == 0
    text = readme.read_text()
    assert "old table" not in text and "| good | passed |" in text
    assert text.startswith("intro\n") and text.endswith("rest\n")
