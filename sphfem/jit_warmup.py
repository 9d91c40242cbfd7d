"""Compile a scene's numba kernels in a short child process when numba's cache is cold.

numba compiles a kernel at its first call and, with ``cache=True``, writes the machine code
to its on-disk cache (next to the sources, or in ``$NUMBA_CACHE_DIR``); a later process
loads it from there.  The compiler's memory does not leave the process that compiled: the
LLVM modules of every kernel and of the functions inlined into it, numba's type-inference
records and the heap LLVM fragmented stay resident.  On the droplet-impact main job that
is ~250 MB, which a first run after an install carries through set-up and stepping.

:func:`warm_up` moves the compilation out of the run: when the cache does not hold the
scene's kernels it runs a *coarsened copy* of the scene (every resolution length -- ``sph.dx``,
per-block ``dx`` and ``gap``, the ``h_*`` sizes of ``[coupling.mesh]`` -- times ``coarsen``, at most
``steps`` steps, outputs in a temporary folder) in a child process.  A kernel's machine
code depends on its argument types (dtypes, dimensions, layouts), not on array sizes, so
the child compiles and caches the kernels the full scene calls; the parent then loads
them all from the cache and never holds the compiler.  The child's peak adds to the
parent's imports only while the parent waits (no FEM, no particles yet).

A manifest (``cache_root()/jit/<key>.json``, key = the scene's kernel choices, numba,
Python, the cache folder) lists the kernels the child used with the number of cached
overloads of each.  :func:`is_warm` checks that numba's index of each of them still holds
that many entries valid for the current source code and CPU (numba's own validity test:
source stamp, byte-code hash, CPU magic), so an edited source file or a cleared cache makes
the scene cold again.  Anything unexpected (a numba without these internals, a child that
fails) leaves the parent to compile as before: slower and larger, never wrong.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

logger = logging.getLogger(__name__)

#: environment switch: "0" turns the warm-up off
ENV = "SPHFEM_JIT_WARMUP"


def kernel_key(scene) -> dict:
    """The parts of a scene that choose which kernels run and with which argument types:
    dimension, kernel, modules, block kinds and samplings, and every module section with
    its numbers reduced to zero / non-zero (a zero coefficient may skip a kernel; its value
    does not change the compiled code)."""

    def reduce(v):
        if isinstance(v, bool) or v is None or isinstance(v, str):
            return v
        if isinstance(v, (int, float)):
            return "0" if v == 0 else "x"
        if isinstance(v, dict):
            return {k: reduce(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [reduce(x) for x in v]
        return type(v).__name__

    d = scene.to_dict()
    return {"dim": d["scene"]["dim"], "kernel": d["sph"]["kernel"],
            "periodic": d["domain"]["periodic"], "modules": d["physics"]["modules"],
            "blocks": sorted({(b["kind"], b["shape"], b["sampling"]) for b in d["blocks"]}),
            "sections": {k: reduce(d[k]) for k in scene.sections}}


def coarsened(scene, coarsen: float = 3.0, steps: int = 100) -> dict:
    """The scene as a dict (``parse_scene`` accepts it) with every resolution length times
    ``coarsen`` (``sph.dx``, per-block ``dx``, the ``h_*`` keys of module sub-tables such
    as ``[coupling.mesh]``, and a block's ``gap``, which must stay >= R) and at most
    ``steps`` steps."""
    from sphfem.resolution import scaled_resolution

    d = scaled_resolution(scene, coarsen)
    ms = d["time"].get("max_steps")
    d["time"]["max_steps"] = steps if ms is None else min(int(ms), steps)
    return d


def manifest_path(scene) -> Path:
    """Where the manifest of ``scene``'s kernels lives (see the module docstring)."""
    import numba

    from sphfem.cache import cache_key, cache_root

    key = cache_key({"kernels": kernel_key(scene), "numba": numba.__version__,
                     "python": sys.version, "cache_dir": os.environ.get("NUMBA_CACHE_DIR", ""),
                     "executable": sys.executable})
    return cache_root() / "jit" / f"{key}.json"


def _dispatchers():
    """(module name, attribute name, dispatcher) of every module-level numba dispatcher
    with an on-disk cache in the imported modules (any package: physics packages other
    than sphfem register through entry points)."""
    from numba.core.dispatcher import Dispatcher

    for mname, mod in list(sys.modules.items()):
        try:
            attrs = list(vars(mod).items())
        except TypeError:
            continue
        for aname, obj in attrs:
            if isinstance(obj, Dispatcher) and getattr(obj, "_cache", None) is not None \
                    and getattr(obj, "__module__", None) == mname:
                yield mname, aname, obj


def _valid_entries(disp) -> int:
    """Entries of ``disp``'s on-disk cache index that the current process would load: the
    index is fresh for the source file (numba checks its stamp when loading the index) and
    an entry's key equals the key numba computes now (byte code, closure, CPU)."""
    cache = disp._cache
    codegen = disp.targetctx.codegen()
    index = cache._cache_file._load_index()
    return sum(1 for key in index if key == cache._index_key(key[0], codegen))


def used_kernels() -> dict:
    """``{"module:attribute": number of overloads}`` of the dispatchers this process has
    called and whose overloads are all in the on-disk cache (one that numba cannot cache
    compiles in every process; a warm-up cannot help it)."""
    out = {}
    for m, a, d in _dispatchers():
        n = len(d.overloads)
        try:
            if n and _valid_entries(d) >= n:
                out[f"{m}:{a}"] = n
        except Exception:  # a numba without these internals: record nothing
            continue
    return out


def is_warm(scene) -> bool:
    """True when numba's cache holds every kernel the manifest of ``scene`` lists."""
    import importlib

    path = manifest_path(scene)
    try:
        kernels = json.loads(path.read_text())["kernels"]
        for name, n in kernels.items():
            mname, aname = name.split(":")
            disp = getattr(importlib.import_module(mname), aname)
            if _valid_entries(disp) < n:
                return False
    except Exception:  # no manifest, a renamed kernel, a numba without these internals
        return False
    return True


def warm_up(scene, coarsen: float = 3.0, steps: int = 100, progress: bool = False) -> dict:
    """Compile ``scene``'s kernels in a child process unless numba's cache holds them
    (``progress``: say so on stderr, :mod:`sphfem.progress`).

    Returns what happened: ``{"cold": False}`` when the cache was warm (or the warm-up is
    off: ``$SPHFEM_JIT_WARMUP=0``, or numba's cache is disabled), else ``{"cold": True,
    "ok": ..., "s": seconds, "child_peak_rss_mb": ..., "compiled": kernels compiled}``.
    A failed child (a scene the run itself will refuse, or one whose coarsened copy cannot
    be built) is logged at INFO level and leaves the compilation to this process.
    """
    import numba

    if os.environ.get(ENV, "1") == "0" or numba.config.DISABLE_JIT:
        return {"cold": False, "skipped": True}
    if is_warm(scene):
        return {"cold": False}
    from sphfem import progress as report

    t0 = time.perf_counter()
    info = {"cold": True, "ok": False}
    with tempfile.TemporaryDirectory(prefix="sphfem-jit-") as tmp:
        src = Path(tmp) / "scene.json"
        src.write_text(json.dumps({"scene": coarsened(scene, coarsen, steps),
                                   "source": scene.source,  # relative mesh_file paths
                                   "manifest": str(manifest_path(scene)),
                                   "out": str(Path(tmp) / "out")}))
        was = report.enabled()
        report.enable(progress or was)
        try:
            with report.stage("compiling numba kernels in a child process on a coarsened copy "
                              "of the scene (first run only; later runs load them from the "
                              "cache)"):
                r = subprocess.run([sys.executable, "-m", "sphfem.jit_warmup", str(src)],
                                   capture_output=True, text=True)
        finally:
            report.enable(was)
        try:
            info.update(json.loads(r.stdout.strip().splitlines()[-1]))
            info["ok"] = r.returncode == 0
        except (ValueError, IndexError):
            pass
        if not info["ok"]:
            tail = " | ".join(r.stderr.strip().splitlines()[-3:])
            # not a warning: the run's own set-up reports a scene's errors in its words
            logger.info("numba warm-up child failed (exit %s): %s; compiling in this "
                        "process instead", r.returncode, tail)
    info["s"] = time.perf_counter() - t0
    return info


def _child(path: str) -> int:
    """Run the coarsened scene of ``path`` (written by :func:`warm_up`), write the manifest,
    print one JSON line: peak memory, compilations."""
    from sphfem.output import write_json
    from sphfem.progress import StageLog, peak_rss_mb
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation, SimulationStopped

    job = json.loads(Path(path).read_text())
    scene = parse_scene(job["scene"], source=job.get("source") or "<numba warm-up>")
    sim = None
    try:
        sim = Simulation(scene)
        sim.run(job["out"], progress=False)
    except SimulationStopped:  # the kernels of the steps taken are cached all the same
        pass
    log = sim.stage_log if sim is not None else StageLog()
    kernels = used_kernels()
    manifest = Path(job["manifest"])
    manifest.parent.mkdir(parents=True, exist_ok=True)
    write_json(manifest, {"kernels": kernels, "numba_compilations": log.compiles})
    print(json.dumps({"child_peak_rss_mb": peak_rss_mb(), "compiled": log.compiles,
                      "kernels": len(kernels)}))
    return 0


if __name__ == "__main__":
    sys.exit(_child(sys.argv[1]))
