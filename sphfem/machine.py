"""What a benchmark ran on: CPU, cores, platform, library versions, numba's threads and the
load.

The one copy for every benchmark: the kernel benchmarks (:mod:`sphfem.bench`), the
fluid-step benchmarks (:mod:`sphfem.fluid.bench`), the FEM substrate benchmark
(:mod:`sphfem.fem.bench`) and the PySPH comparison (``benchmarks/pysph/compare.py``).  It
imports nothing of sphfem, so no bench imports another for it.
"""

from __future__ import annotations

import datetime
import os
import platform

import numba
import numpy as np


def machine_info() -> dict:
    """CPU model, core count, platform, python/numba/numpy versions, numba's thread limit
    and threading layer, the UTC date and the 1/5/15-minute load averages."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "numba": numba.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "numba_max_threads": numba.config.NUMBA_NUM_THREADS,
        "threading_layer": threading_layer(),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }


def threading_layer() -> str:
    """numba's threading layer, or "not initialised" before the first parallel run."""
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel function has run yet
        return "not initialised"
