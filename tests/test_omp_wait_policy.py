"""``import sphfem`` sets OMP_WAIT_POLICY=PASSIVE for numba's OpenMP layer unless the user
set it (sphfem/__init__.py)."""

import os
import subprocess
import sys


def _policy(env):
    code = "import os, sphfem; print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True)
    return out.stdout.strip()


def test_passive_by_default_and_user_value_wins():
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    assert _policy(env) == "PASSIVE"
    assert _policy({**env, "OMP_WAIT_POLICY": "ACTIVE"}) == "ACTIVE"
