"""Cold start of a scene: seconds from a fresh install to its first step, stage by stage.

Each measurement runs ``sphfem run SCENE`` (a copy of the scene with ``[time] max_steps``
= 1) in a new process with *empty* caches in a temporary folder: ``NUMBA_CACHE_DIR``
(numba's compiled kernels) and ``SPHFEM_CACHE`` (meshes, Poisson samples, warm-up
manifests), so nothing computed earlier is reused -- what a user sees after
``pip install``.  ``--repeat-warm`` runs it a second time with the same caches (a second
run).  Reported per run: the wall seconds from launch to the end of the first step and to
each ``sphfem: ...`` stage line on stderr, the process CPU seconds (user + system of the
run and of every child it waited for, so the warm-up child's compilation is included),
the load average before and after (the machine is shared: wall seconds stretch with the
load, CPU seconds much less), the peak resident memory and the set-up figures of the
run's ``summary.json``.

``--profile`` runs the scene in this script's own child with a listener on numba's
``numba:compile`` event (fired on a cache miss only) and reports each compiled kernel's
seconds (exclusive of the kernels compiled inside it), its signatures and the total; the
warm-up child is switched off there (``SPHFEM_JIT_WARMUP=0``) so every compilation happens
in the profiled process.

    python benchmarks/coldstart.py examples/droplet_impact/droplet_impact.toml \
        examples/droplet_impact/droplet_impact_axisymmetric.toml --repeat-warm --json cs.json
    python benchmarks/coldstart.py SCENE --profile --json profile.json
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scene_copy(scene: Path, dest: Path, steps: int) -> Path:
    """``scene`` with ``max_steps = steps`` in its ``[time]`` table (text edit: an existing
    ``max_steps`` line is replaced, else one is added below ``[time]``)."""
    text = scene.read_text()
    if re.search(r"(?m)^\s*max_steps\s*=", text):
        text = re.sub(r"(?m)^\s*max_steps\s*=.*$", f"max_steps = {steps}", text)
    else:
        text, n = re.subn(r"(?m)^\[time\]\s*$", f"[time]\nmax_steps = {steps}", text)
        if n != 1:
            raise SystemExit(f"{scene}: no [time] table to add max_steps to")
    out = dest / scene.name
    out.write_text(text)
    return out


def run_once(scene: Path, tmp: Path, tag: str, steps: int, warmup: bool, profile: bool,
             threads: int | None) -> dict:
    """One ``sphfem run`` of ``scene`` with the caches of ``tmp`` (see the module docstring)."""
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(tmp / "numba")
    env["SPHFEM_CACHE"] = str(tmp / "sphfem")
    env["SPHFEM_JIT_WARMUP"] = "1" if warmup and not profile else "0"
    if threads:
        env["NUMBA_NUM_THREADS"] = str(threads)
    src = scene_copy(scene, tmp, steps)
    out = tmp / f"out-{tag}"
    args = ["run", str(src), "--out", str(out), "--overwrite"]
    prof = tmp / f"profile-{tag}.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--inner", str(prof), "--", *args] \
        if profile else [sys.executable, "-m", "sphfem.cli", *args]
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env=env, cwd=ROOT)
    lines = []

    def read():
        for line in proc.stderr:
            lines.append((time.perf_counter() - t0, line.rstrip()))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    reader.join()
    stdout = proc.stdout.read()
    proc.returncode = os.waitstatus_to_exitcode(status)
    res = {"scene": str(scene), "run": tag, "warmup": env["SPHFEM_JIT_WARMUP"] == "1",
           "wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime,
           "peak_rss_mb_max_process": ru.ru_maxrss / 1024.0,
           "loadavg_before": load0, "loadavg_after": os.getloadavg(),
           "returncode": proc.returncode,
           "stages": [{"t_s": round(t, 2), "line": s} for t, s in lines
                      if s.startswith("sphfem:")]}
    first = [t for t, s in lines if s.startswith("sphfem: stepping from")]
    res["to_stepping_s"] = first[0] if first else None
    try:
        summary = json.loads((out / "summary.json").read_text())
        res["setup"] = {k: summary.get(k) for k in ("setup_s", "wall_s", "steps", "peak_rss_mb")}
        st = summary.get("setup", {})
        res["setup"]["numba_compilations"] = st.get("numba_compilations")
        res["setup"]["numba_compile_s"] = st.get("numba_compile_s")
        res["setup"]["stages"] = [{"stage": s["stage"], "s": round(s["s"], 2),
                                   "rss_mb": round(s["rss_mb"])} for s in st.get("stages", [])]
    except (OSError, ValueError):
        res["stderr_tail"] = [s for _, s in lines[-15:]]
        res["stdout_tail"] = stdout[-2000:]
    if profile and prof.exists():
        res["profile"] = json.loads(prof.read_text())
    return res


def _inner(path: str, argv: list[str]) -> int:
    """Run ``sphfem.cli.main(argv)`` with a compile listener; write the kernels' seconds."""
    from numba.core import event

    stack, records = [], []

    class Timer(event.Listener):
        def on_start(self, ev):
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev):
            t0, inner = stack.pop()
            dt = time.perf_counter() - t0
            if stack:
                stack[-1][1] += dt
            d = ev.data.get("dispatcher")
            f = getattr(d, "py_func", None)
            name = f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', '?')}"
            parallel = bool(getattr(d, "targetoptions", {}).get("parallel"))
            records.append({"kernel": name, "sig": str(ev.data.get("args")),
                            "s": dt - inner, "inclusive_s": dt, "parallel": parallel,
                            "nested": bool(stack)})

    event.register("numba:compile", Timer())
    from sphfem.cli import main

    try:
        return main(argv)
    finally:
        Path(path).write_text(json.dumps(records))


def summarize_profile(records: list[dict], top: int) -> list[str]:
    by = {}
    for r in records:
        k = by.setdefault(r["kernel"], {"s": 0.0, "sigs": set(), "parallel": r["parallel"]})
        k["s"] += r["s"]
        k["sigs"].add(r["sig"])
    total = sum(v["s"] for v in by.values())
    rows = sorted(by.items(), key=lambda kv: -kv[1]["s"])
    out = [f"  {len(records)} compilations of {len(by)} functions, {total:.1f} s (exclusive "
           f"seconds summed); parallel=True: "
           f"{sum(v['s'] for v in by.values() if v['parallel']):.1f} s"]
    for name, v in rows[:top]:
        out.append(f"  {v['s']:7.2f} s  {len(v['sigs'])} sig  {'par ' if v['parallel'] else ''}"
                   f"{name}")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scenes", nargs="+", type=Path)
    p.add_argument("--steps", type=int, default=1, help="max_steps of the runs (default 1)")
    p.add_argument("--repeat-warm", action="store_true",
                   help="a second run with the caches of the first")
    p.add_argument("--no-warmup", action="store_true",
                   help="SPHFEM_JIT_WARMUP=0: compile in the run's own process")
    p.add_argument("--profile", action="store_true", help="per-kernel compile seconds")
    p.add_argument("--threads", type=int, help="NUMBA_NUM_THREADS of the runs")
    p.add_argument("--top", type=int, default=25, help="kernels listed by --profile")
    p.add_argument("--json", type=Path, help="write every figure as JSON")
    p.add_argument("--keep", type=Path, help="keep the caches and outputs in this folder")
    a = p.parse_args(argv)
    results = []
    for scene in a.scenes:
        scene = scene.resolve()
        with tempfile.TemporaryDirectory(prefix="sphfem-coldstart-") as t:
            tmp = a.keep / scene.stem if a.keep else Path(t)
            tmp.mkdir(parents=True, exist_ok=True)
            tags = ["cold", "warm"] if a.repeat_warm else ["cold"]
            for tag in tags:
                r = run_once(scene, tmp, tag, a.steps, not a.no_warmup, a.profile, a.threads)
                results.append(r)
                la = "/".join(f"{x:.1f}" for x in r["loadavg_before"])
                print(f"{scene.name} [{tag}]: first step after {r['wall_s']:.1f} s wall, "
                      f"{r['cpu_s']:.1f} CPU-s (load {la}), peak RSS "
                      f"{r['peak_rss_mb_max_process']:.0f} MB, exit {r['returncode']}")
                for s in r["stages"]:
                    print(f"  {s['t_s']:7.1f} s  {s['line']}")
                if "setup" in r:
                    su = r["setup"]
                    print(f"  setup_s {su['setup_s']:.1f}, compilations in the run's process "
                          f"{su['numba_compilations']} ({su['numba_compile_s'] or 0:.1f} s)")
                    for s in su["stages"]:
                        print(f"    {s['s']:7.2f} s {s['rss_mb']:6d} MB  {s['stage']}")
                else:
                    print("\n".join(r.get("stderr_tail", [])))
                if "profile" in r:
                    print("\n".join(summarize_profile(r["profile"], a.top)))
    if a.json:
        a.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--inner":
        sys.exit(_inner(sys.argv[2], sys.argv[4:]))
    sys.exit(main())
