"""Test-suite settings.

``sphfem run`` compiles a cold numba cache in a child process first (``sphfem/jit_warmup.py``,
a memory measure for long runs).  The suite's many short CLI runs would each start such a
child for every new scene kind, so the warm-up is off here unless the environment sets
``SPHFEM_JIT_WARMUP``; ``tests/test_jit_warmup.py`` turns it on for its own runs.
"""

import os

os.environ.setdefault("SPHFEM_JIT_WARMUP", "0")
