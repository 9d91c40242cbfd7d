"""The whole quick validation suite in the default test run: every registered case at its
quick resolutions (``sphfem validate CASE --quick``, each warmed up first), one test per
case so that pytest-xdist spreads them over the workers (``validate all --quick`` ran them
in one test, the suite's longest).  A failed or broken case names its failed criteria;
``validate all`` itself (report, README block, no clobbering) is tested in test_report.py.
"""

import json

import pytest

from sphfem.cli import main
from sphfem.validation import load_cases

CASES = sorted(load_cases())
#: quick cases that take over a minute of one worker run with ``-m slow`` only (the
#: axisymmetric droplet job at three spacings: 98 s)
SLOW = {"droplet-impact"}


def test_every_case_is_here():
    assert len(CASES) >= 16


@pytest.mark.parametrize("name", [pytest.param(c, marks=pytest.mark.slow) if c in SLOW
                                  else c for c in CASES])
def test_validate_quick(name, tmp_path, capsys):
    out = tmp_path / f"{name}.json"
    code = main(["validate", name, "--quick", "--json", str(out)])
    printed = capsys.readouterr().out
    d = json.loads(out.read_text())
    bad = [f"{k} = {c['value']} not {c['op']} {c['limit']}"
           for k, c in d["criteria"].items() if not c["passed"]]
    assert d["passed"] and not bad, f"{name}: {'; '.join(bad)}\n{printed}"
    assert code == 0, printed
