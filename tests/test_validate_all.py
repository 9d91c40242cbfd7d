"""The whole quick validation suite in the default test run: ``sphfem validate all --quick``
(every registered case at its quick resolutions, each warmed up first; about a minute on
two cores).  Fails on any failed or broken case and names them with their failed criteria.
"""

import json

from sphfem.cli import main
from sphfem.validation import load_cases


def test_validate_all_quick(tmp_path, capsys):
    out = tmp_path / "report"
    code = main(["validate", "all", "--quick", "--out", str(out)])
    printed = capsys.readouterr().out
    cases = sorted(load_cases())
    failed = []
    for name in cases:
        f = out / f"{name}.json"
        if not f.exists():  # the case raised: its error is in the report
            failed.append(f"{name}: ERROR (see {out / 'report.md'})")
            continue
        d = json.loads(f.read_text())
        if not d["passed"]:
            bad = [f"{k} = {c['value']} not {c['op']} {c['limit']}"
                   for k, c in d["criteria"].items() if not c["passed"]]
            failed.append(f"{name}: {'; '.join(bad)}")
    assert not failed, "failed validation cases:\n" + "\n".join(failed)
    assert code == 0, printed
    assert len(cases) >= 16 and "PASSED" in printed
