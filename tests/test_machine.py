"""One machine record for every benchmark (sphfem/machine.py)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numba
import numpy as np

from sphfem.machine import machine_info

ROOT = Path(__file__).resolve().parents[1]


def test_machine_info_has_what_the_benchmarks_report():
    m = machine_info()
    assert m["numba"] == numba.__version__ and m["numpy"] == np.__version__
    assert m["cores"] >= 1 and m["cpu"] and m["platform"] and m["python"]
    assert len(m["load_average"]) == 3 and m["date"].endswith("+00:00")


def test_every_benchmark_uses_the_one_copy():
    for name in ("sphfem.bench", "sphfem.fluid.bench", "sphfem.fem.bench"):
        assert importlib.import_module(name).machine_info is machine_info, name
    sys.path.insert(0, str(ROOT / "benchmarks" / "pysph"))
    try:
        compare = importlib.import_module("compare")
    finally:
        sys.path.remove(str(ROOT / "benchmarks" / "pysph"))
    assert compare.machine_info is machine_info
    assert not hasattr(compare, "machine")
