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

Compiling on every core.  numba compiles one kernel at a time in one process (its front
end is Python and holds the GIL), so a first run of the droplet job spent 3-4 CPU-minutes
on one core.  For scenes whose kernels are *recorded* in ``jit_signatures.json`` (the
kernel key of the scene -> every cached dispatcher it calls, its argument types pickled,
and the seconds its compilation took; written by ``python -m sphfem.jit_warmup --record
SCENE``), :func:`warm_up` compiles the recorded signatures in one child per core
(``dispatcher.compile(signature)``; the kernels split by their recorded seconds, longest
first, all overloads of a kernel in one child so that no two children write one cache
index) and then writes the manifest; only when that leaves the scene cold (a kernel whose
types do not unpickle, a failed child) does the coarsened-copy child run as well.  The
record is only a list of types: the code compiled is the installed code, and a record of
another numba or Python version is ignored.
"""

from __future__ import annotations

import base64
import json
import logging
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

logger = logging.getLogger(__name__)

#: environment switch: "0" turns the warm-up off
ENV = "SPHFEM_JIT_WARMUP"
#: environment: compile processes of a recorded warm-up (default: the CPUs this process
#: may use)
ENV_WORKERS = "SPHFEM_JIT_WORKERS"
#: the recorded kernels of shipped scenes (see the module docstring)
SIGNATURES = Path(__file__).with_name("jit_signatures.json")


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


def record_key(scene) -> str:
    """The key of ``scene``'s entry in :data:`SIGNATURES`: its kernel choices, numba's and
    Python's versions (pickled numba types are read back by the same numba only)."""
    import numba

    from sphfem.cache import cache_key

    return cache_key({"kernels": kernel_key(scene), "numba": numba.__version__,
                      "python": list(sys.version_info[:2])})


def recorded(scene, path: Path = SIGNATURES) -> list[dict] | None:
    """The recorded kernels of ``scene`` (``[{"kernel": "module:attribute", "sigs": [...],
    "s": seconds}, ...]``) or None."""
    try:
        return json.loads(path.read_text())["scenes"][record_key(scene)]["kernels"]
    except (OSError, ValueError, KeyError):
        return None


def _record_entries(seconds: dict) -> list[dict]:
    """The cached dispatchers this process has called: their signatures (pickled, base64)
    and ``seconds[name]``, the seconds of their outermost compilations."""
    out = []
    for m, a, d in _dispatchers():
        if not d.overloads:
            continue
        name = f"{m}:{a}"
        try:
            sigs = [base64.b64encode(pickle.dumps(tuple(sig))).decode() for sig in d.signatures]
        except Exception:  # a type that does not pickle: left to the scene's own run
            continue
        out.append({"kernel": name, "sigs": sigs, "s": round(seconds.get(name, 0.0), 3)})
    return sorted(out, key=lambda e: -e["s"])


def split(entries: list[dict], workers: int) -> list[list[dict]]:
    """``entries`` in ``workers`` lists of about equal recorded seconds (longest first,
    each to the least loaded list)."""
    bins = [[] for _ in range(max(1, workers))]
    load = [0.0] * len(bins)
    for e in sorted(entries, key=lambda e: -e["s"]):
        k = load.index(min(load))
        bins[k].append(e)
        load[k] += e["s"]
    return [b for b in bins if b]


def _workers() -> int:
    try:
        return max(1, int(os.environ[ENV_WORKERS]))
    except (KeyError, ValueError):
        try:
            return max(1, len(os.sched_getaffinity(0)))
        except AttributeError:
            return os.cpu_count() or 1


def _compile_recorded(scene, entries: list[dict], progress: bool) -> dict:
    """Compile ``entries`` in :func:`_workers` child processes; write the manifest when
    every child succeeded.  Returns ``{"workers", "ok", "compiled", "failed"}``."""
    from sphfem.output import write_json

    groups = split(entries, _workers())
    info = {"workers": len(groups), "ok": False, "compiled": 0, "failed": 0}
    with tempfile.TemporaryDirectory(prefix="sphfem-jit-") as tmp:
        procs = []
        for i, g in enumerate(groups):
            f = Path(tmp) / f"group{i}.json"
            f.write_text(json.dumps({"kernels": g, "tag": f"{i + 1}/{len(groups)}",
                                     "progress": progress}))
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "sphfem.jit_warmup", "--compile", str(f)],
                stdout=subprocess.PIPE, stderr=None if progress else subprocess.DEVNULL,
                text=True))
        ok = True
        for p in procs:
            out, _ = p.communicate()
            try:
                r = json.loads(out.strip().splitlines()[-1])
                info["compiled"] += r["compiled"]
                info["failed"] += r["failed"]
            except (ValueError, IndexError, KeyError):
                ok = False
            ok &= p.returncode == 0
    info["ok"] = ok and info["failed"] == 0
    if info["ok"]:
        manifest = manifest_path(scene)
        manifest.parent.mkdir(parents=True, exist_ok=True)
        write_json(manifest, {"kernels": {e["kernel"]: len(e["sigs"]) for e in entries},
                              "recorded": True})
    return info


def _compile_group(path: str) -> int:
    """Child of :func:`_compile_recorded`: compile the kernels of ``path``; print one JSON
    line (compiled and failed signatures, seconds)."""
    import importlib

    job = json.loads(Path(path).read_text())
    t0 = time.perf_counter()
    done = failed = 0
    for e in job["kernels"]:
        t1 = time.perf_counter()
        try:
            mname, aname = e["kernel"].split(":")
            disp = getattr(importlib.import_module(mname), aname)
            for sig in e["sigs"]:
                disp.compile(pickle.loads(base64.b64decode(sig)))
                done += 1
        except Exception as exc:  # left to the scene's run (or the coarsened child)
            failed += 1
            logger.info("warm-up: %s not compiled: %s", e["kernel"], exc)
            continue
        if job.get("progress"):
            print(f"sphfem:   [{job['tag']}] {e['kernel']} "
                  f"({time.perf_counter() - t1:.1f} s)", file=sys.stderr, flush=True)
    wall, cpu = time.perf_counter() - t0, time.process_time()
    if job.get("progress"):
        print(f"sphfem:   [{job['tag']}] done: {done} signatures in {wall:.1f} s "
              f"({cpu:.1f} CPU-s with the imports)", file=sys.stderr, flush=True)
    print(json.dumps({"compiled": done, "failed": failed, "s": wall, "cpu_s": cpu}))
    return 0


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
    entries = recorded(scene)
    if entries:
        was = report.enabled()
        report.enable(progress or was)
        try:
            n = sum(len(e["sigs"]) for e in entries)
            with report.stage(f"compiling the scene's {len(entries)} recorded numba kernels "
                              f"({n} signatures) in {min(_workers(), len(entries))} "
                              f"processes (first run only; later runs load them from the "
                              f"cache)"):
                info["recorded"] = _compile_recorded(scene, entries, progress or was)
        finally:
            report.enable(was)
        if info["recorded"]["ok"] and is_warm(scene):
            info.update(ok=True, s=time.perf_counter() - t0)
            return info
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
    seconds = _time_compilations() if job.get("record") else {}
    sim = None
    try:
        sim = Simulation(scene)
        sim.run(job["out"], progress=False)
    except SimulationStopped:  # the kernels of the steps taken are cached all the same
        pass
    log = sim.stage_log if sim is not None else StageLog()
    if job.get("record"):
        write_json(job["record"], {"kernels": _record_entries(seconds)})
    kernels = used_kernels()
    manifest = Path(job["manifest"])
    manifest.parent.mkdir(parents=True, exist_ok=True)
    write_json(manifest, {"kernels": kernels, "numba_compilations": log.compiles})
    print(json.dumps({"child_peak_rss_mb": peak_rss_mb(), "compiled": log.compiles,
                      "kernels": len(kernels)}))
    return 0


def _time_compilations() -> dict:
    """``{"module:attribute": CPU seconds}`` of this process's outermost numba compilations
    from now on (filled as they happen: a listener on numba's ``numba:compile`` event).
    CPU, not wall, seconds: a record made on a loaded machine still splits the work evenly
    (the records of 64d1e29 hold wall seconds at load ~9: their two children took 77 and
    96 CPU-s on the 3D droplet)."""
    from numba.core import event

    seconds, stack = {}, []

    class Timer(event.Listener):
        def on_start(self, ev):
            stack.append(time.process_time())

        def on_end(self, ev):
            dt = time.process_time() - stack.pop()
            d = ev.data.get("dispatcher")
            f = getattr(d, "py_func", None)
            if not stack and f is not None:
                name = f"{f.__module__}:{f.__name__}"
                seconds[name] = seconds.get(name, 0.0) + dt

    event.register("numba:compile", Timer())
    return seconds


def record(paths: list[str], coarsen: float = 3.0, steps: int = 100,
           out: Path = SIGNATURES) -> dict:
    """Record the kernels of the scenes ``paths`` into ``out``: each scene's coarsened copy
    runs in a child with an empty numba cache (so every kernel compiles and its seconds
    are measured); returns ``{scene path: number of kernels}``."""
    from sphfem.output import write_json
    from sphfem.scene import load_scene

    try:
        data = json.loads(out.read_text())
    except (OSError, ValueError):
        data = {}
    data.setdefault("about", "numba signatures of scenes' kernels for sphfem.jit_warmup; "
                             "python -m sphfem.jit_warmup --record SCENE")
    scenes = data.setdefault("scenes", {})
    done = {}
    for p in paths:
        scene = load_scene(p)
        with tempfile.TemporaryDirectory(prefix="sphfem-jit-record-") as tmp:
            job = Path(tmp) / "scene.json"
            job.write_text(json.dumps({"scene": coarsened(scene, coarsen, steps),
                                       "source": scene.source,
                                       "manifest": str(Path(tmp) / "manifest.json"),
                                       "record": str(Path(tmp) / "record.json"),
                                       "out": str(Path(tmp) / "out")}))
            env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba"),
                   "SPHFEM_CACHE": str(Path(tmp) / "cache")}
            subprocess.run([sys.executable, "-m", "sphfem.jit_warmup", str(job)], env=env,
                           check=True, capture_output=True)
            entries = json.loads((Path(tmp) / "record.json").read_text())["kernels"]
        import numba

        versions = {"numba": numba.__version__, "python": list(sys.version_info[:2])}
        for k in [k for k, v in scenes.items()  # a stale record of the same scene
                  if v.get("scene") == Path(p).name and all(v.get(a) == b
                                                            for a, b in versions.items())]:
            del scenes[k]
        scenes[record_key(scene)] = {"scene": Path(p).name, **versions, "kernels": entries}
        done[p] = len(entries)
    write_json(out, data)
    return done


if __name__ == "__main__":
    if sys.argv[1] == "--compile":
        sys.exit(_compile_group(sys.argv[2]))
    if sys.argv[1] == "--record":
        print(json.dumps(record(sys.argv[2:])))
        sys.exit(0)
    sys.exit(_child(sys.argv[1]))
