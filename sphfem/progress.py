"""Start-up reporting: one short line per set-up stage on stderr, with its seconds and memory.

A run spends its first seconds (minutes, on a first run) meshing, assembling, factorising
and compiling numba kernels before the first step.  :func:`stage` names such a stage::

    with stage("factorising K (12345 unknowns)"):
        ...

and, when reporting is on (:func:`enable`; the command line turns it on unless
``--no-progress``), prints ``sphfem: factorising K (12345 unknowns)...`` on stderr.  Library
users see nothing unless they enable it.  Whether printed or not, every stage is recorded
(seconds, resident memory after it) for ``summary.json``; :class:`StageLog` collects them.

numba compilations are counted by a listener on numba's ``numba:compile`` event, which fires
only on a cache miss (a kernel loaded from the on-disk cache does not fire it), so
``compiles == 0`` means every kernel came from the cache.  The first compilation of a
process prints one line ("compiling numba kernels (first run only; cached in ...)").
"""

from __future__ import annotations

import os
import resource
import sys
import time
from contextlib import contextmanager

_state = {"enabled": False, "log": None, "compile_noted": False}


def enable(on: bool = True) -> None:
    """Print stage lines on stderr (off by default)."""
    _state["enabled"] = bool(on)
    _install_compile_listener()


def enabled() -> bool:
    return _state["enabled"]


def say(text: str) -> None:
    """One line on stderr when reporting is on."""
    if _state["enabled"]:
        print(f"sphfem: {text}", file=sys.stderr, flush=True)


def rss_mb() -> float:
    """Current resident memory of this process [MB = 2^20 bytes] (Linux ``/proc``; else
    the peak, :func:`peak_rss_mb`)."""
    try:
        with open("/proc/self/statm") as fh:
            pages = int(fh.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return peak_rss_mb()


def process_s() -> float | None:
    """Seconds since this process started (Linux ``/proc``; None elsewhere): with the
    Python imports, which the set-up figures do not include."""
    try:
        with open("/proc/self/stat") as fh:
            start_ticks = int(fh.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        return max(uptime - start_ticks / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return None


def peak_rss_mb() -> float:
    """Peak resident memory of this process [MB] from ``getrusage``: ``ru_maxrss`` is in
    KiB on Linux and in bytes on macOS."""
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return r / 2**20 if sys.platform == "darwin" else r / 2**10


class StageLog:
    """Stages (name, seconds, resident MB after) and numba compilations while active.

    ``with StageLog() as log:`` makes it the current log; :func:`stage` records into it.
    """

    def __init__(self):
        self.stages: list[dict] = []
        self.compiles = 0
        self.compile_s = 0.0
        self.compiled: list[str] = []  # module.qualname of each cache-missing compilation
        self._depth = 0
        self._t0 = 0.0

    def __enter__(self):
        self._prev = _state["log"]
        _state["log"] = self
        _install_compile_listener()
        return self

    def __exit__(self, *exc):
        _state["log"] = self._prev
        return False

    def to_dict(self) -> dict:
        return {"stages": [dict(s) for s in self.stages],
                "numba_compilations": self.compiles,
                "numba_compile_s": self.compile_s,
                "numba_compiled": list(self.compiled)}


@contextmanager
def stage(what: str):
    """Report ``what...`` on stderr (when enabled) and record its seconds and memory."""
    say(f"{what}...")
    t0 = time.perf_counter()
    try:
        yield
    finally:
        log = _state["log"]
        if log is not None:
            log.stages.append({"stage": what, "s": time.perf_counter() - t0,
                               "rss_mb": rss_mb()})


_listener = None


def _install_compile_listener() -> None:
    global _listener
    if _listener is not None:
        return
    from numba.core import event

    class _Compiles(event.Listener):
        """Counts cache-missing compilations (outermost ones timed: they nest)."""

        def on_start(self, ev):
            log = _state["log"]
            if not _state["compile_noted"]:
                _state["compile_noted"] = True
                say("compiling numba kernels (first run only; later runs load them from "
                    "the cache)...")
            if log is not None:
                if log._depth == 0:
                    log._t0 = time.perf_counter()
                log._depth += 1
                log.compiles += 1
                f = getattr(ev.data.get("dispatcher"), "py_func", None)
                log.compiled.append(f"{getattr(f, '__module__', '?')}."
                                    f"{getattr(f, '__qualname__', '?')}")

        def on_end(self, ev):
            log = _state["log"]
            if log is not None and log._depth > 0:
                log._depth -= 1
                if log._depth == 0:
                    log.compile_s += time.perf_counter() - log._t0

    _listener = _Compiles()
    event.register("numba:compile", _listener)
