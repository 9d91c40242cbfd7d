#!/usr/bin/env python
"""Prototype of PROFILE.md's recommendation 1, measured without touching sphfem/.

Superseded: recommendation 1 is implemented in ``sphfem.fluid.passes`` (density_gradient
emits the rows, fluid_forces takes ``cnt``); the source rewrites below no longer match
and the script stops with its "passes.py changed" message.  Kept for the record.

Variants of the current ``passes.density_gradient`` and ``passes.fluid_forces`` are
generated from their source (``inspect``) with two small rewrites:

* ``density_gradient_emit``: also writes every in-R neighbour j of fluid row i into
  ``nb[offsets[i] + c]`` and the count into ``cnt[i]`` (same buffer shape as the Verlet
  list, no prefix sum);
* ``fluid_forces_compact``: loops over ``nb[offsets[i] : offsets[i] + cnt[i]]``.

Wall rows are emitted by ``emit_wall_rows`` (the distance part of adami_wall_state;
in a real implementation the wall pass would emit them).  Checks that acc / drho /
f_fluid agree with the original passes, then times (single calls interleaved 12 times, minimum of each, 1 thread):
original density_gradient + fluid_forces vs emit + wall emission + compact forces.
Run from the repository root: ``python benchmarks/pysph/proto_compact_rows.py``.
"""

from __future__ import annotations

import inspect
import json
import os
import sys
import textwrap

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(1, os.path.dirname(os.path.dirname(HERE)))
import compare  # noqa: E402
import profile_fluid as pf  # noqa: E402
import run_pysph  # noqa: E402

from sphfem.fluid import passes  # noqa: E402
from sphfem.particles import FLUID, WALL  # noqa: E402


def _variant(fn, name, edits):
    src = textwrap.dedent(inspect.getsource(fn))
    src = src[src.index("def "):]  # drop the decorator
    src = src.replace(f"def {fn.__name__}(", f"def {name}(", 1)
    for old, new in edits:
        if old not in src:
            raise RuntimeError(f"prototype rewrite failed ({name}): {old!r} not found; "
                               "passes.py changed")
        src = src.replace(old, new)
    ns = dict(vars(passes))
    exec(compile(src, f"<{name}>", "exec"), ns)
    return numba.njit(parallel=True, fastmath=passes.FASTMATH)(ns[name])


density_gradient_emit = _variant(passes.density_gradient, "density_gradient_emit", [
    ("grad, ok):", "grad, ok, nb, cnt):"),
    ("        ri = rho[i]\n", "        ri = rho[i]\n        c = 0\n"),
    ("            if d2 >= R2 or d2 == 0.0:\n                continue\n",
     "            if d2 >= R2 or d2 == 0.0:\n                continue\n"
     "            nb[offsets[i] + c] = j\n            c += 1\n"),
    ("        M = np.empty((3, 3))\n", "        cnt[i] = c\n        M = np.empty((3, 3))\n"),
])

fluid_forces_compact = _variant(passes.fluid_forces, "fluid_forces_compact", [
    ("offsets, indices, R,", "offsets, indices, cnt, R,"),
    ("for jj in range(offsets[i], offsets[i + 1]):",
     "for jj in range(offsets[i], offsets[i] + cnt[i]):"),
])


@numba.njit(parallel=True, fastmath=passes.FASTMATH)
def emit_wall_rows(x, kind, offsets, indices, R, nb, cnt):
    n, dim = x.shape
    R2 = R * R
    for i in numba.prange(n):
        if kind[i] != WALL:
            continue
        c = 0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            d2 = 0.0
            for k in range(dim):
                d = x[i, k] - x[j, k]
                d2 += d * d
            if d2 < R2:
                nb[offsets[i] + c] = j
                c += 1
        cnt[i] = c


def main():
    res = {"loadavg_start": run_pysph.loadavg()}
    numba.set_num_threads(1)
    s = compare.dambreak3d(80703, 3.0, 1, 0.25)
    for _ in range(2):
        dt, _ = s.stable_dt()
        s.step(dt)
        s.check()
    p, sc, pa, nl = s.p, s._scratch, s.params, s.nbrs
    nb = np.empty_like(nl.indices)
    cnt = np.zeros(p.n, np.int64)
    delta_coef = pa.delta * s.h * pa.c0
    ks = pf.kernels_of(s)
    args_dg = (p.x, p.rho, sc.V, p.kind, nl.offsets, nl.indices, s.R, s.sigma, s.kkind,
               s.period, pa.cond_max, sc.grad, sc.ok)
    tail = (s.R, s.sigma, s.kkind, s.period, s.gravity, pa.eps_visc * s.h * s.h,
            delta_coef, pa.alpha * s.h * pa.c0)

    def orig():
        ks["density_gradient"]()
        ks["pack_rows"]()
        ks["fluid_forces"]()

    def compact():
        density_gradient_emit(*args_dg, nb, cnt)
        emit_wall_rows(p.x, p.kind, nl.offsets, nl.indices, s.R, nb, cnt)
        ks["pack_rows"]()
        fluid_forces_compact(sc.P, p.kind, nl.offsets, nb, cnt, *tail, p.acc, p.drho,
                             p.f_fluid)

    orig()
    ref = (p.acc.copy(), p.drho.copy(), p.f_fluid.copy(), sc.grad.copy())
    compact()
    got = (p.acc.copy(), p.drho.copy(), p.f_fluid.copy(), sc.grad.copy())
    res["max_rel_diff"] = {k: float(np.abs(a - b).max() / max(np.abs(a).max(), 1e-300))
                           for k, a, b in zip(("acc", "drho", "f_fluid", "grad"), ref, got)}
    res["compact_entries"] = int(cnt.sum())
    res["verlet_entries"] = int(nl.n_pairs)
    t = {}
    for _ in range(12):  # single calls, interleaved; min of each
        for name, fn in (("original", orig), ("compact", compact)):
            t[name] = min(t.get(name, np.inf), pf.tmin(fn, 1))
        for name, fn in (
                ("density_gradient", ks["density_gradient"]),
                ("density_gradient_emit", lambda: density_gradient_emit(*args_dg, nb, cnt)),
                ("emit_wall_rows", lambda: emit_wall_rows(p.x, p.kind, nl.offsets,
                                                          nl.indices, s.R, nb, cnt)),
                ("fluid_forces", ks["fluid_forces"]),
                ("fluid_forces_compact", lambda: fluid_forces_compact(
                    sc.P, p.kind, nl.offsets, nb, cnt, *tail, p.acc, p.drho, p.f_fluid))):
            t[name] = min(t.get(name, np.inf), pf.tmin(fn, 1))
    res["ms"] = {k: round(v * 1e3, 2) for k, v in t.items()}
    res["loadavg_end"] = run_pysph.loadavg()
    print(json.dumps(res, indent=1))
    with open(os.path.join(HERE, "proto_compact_rows.json"), "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
