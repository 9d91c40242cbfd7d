"""What a benchmark ran on: CPU, cores, library versions, numba's threads and the load.

Shared by the kernel benchmarks (:mod:`sphfem.bench`) and the fluid-step benchmarks
(:mod:`sphfem.fluid.bench`); it imports nothing of sphfem, so neither bench imports the other
for it.
"""

from __future__ import annotations

import datetime
import os
import platform

import numba
import numpy as np


def machine_info() -> dict:
    """CPU model, core count, numba/numpy versions and the numba thread limit."""
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
        "numba": numba.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "numba_max_threads": numba.config.NUMBA_NUM_THREADS,
        "threading_layer": _threading_layer(),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }


def _threading_layer() -> str:
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel function has run yet
        return "not initialised"
