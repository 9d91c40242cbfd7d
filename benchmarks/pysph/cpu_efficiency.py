#!/usr/bin/env python
"""CPU time vs wall time of the two pair passes on 1 and 2 threads (run from benchmarks/pysph/):
if 2 threads give CPU ~ 2 x wall the second core is really used."""
import json
import sys
import time

import numba

sys.path.insert(0, ".")
sys.path.insert(1, "../..")
import compare  # noqa: E402
import profile_fluid as pf  # noqa: E402
import run_pysph  # noqa: E402

s = compare.dambreak3d(80703, 3.0, 0, 0.25)
s.params.threads = 0
s.nthreads = 0
for _ in range(2):
    dt, _ = s.stable_dt()
    s.step(dt)
    s.check()
ks = pf.kernels_of(s)
out = {}
for t in (1, 2, 1, 2):
    numba.set_num_threads(t)
    for name in ("density_gradient", "fluid_forces"):
        f = ks[name]
        f()
        w0 = time.perf_counter()
        c0 = time.process_time()
        for _ in range(5):
            f()
        w = (time.perf_counter() - w0) / 5
        c = (time.process_time() - c0) / 5
        out.setdefault(f"{name} t={t}", []).append(
            (round(w * 1e3, 1), round(c * 1e3, 1), run_pysph.loadavg()))
print(json.dumps(out, indent=0))
