"""Test-suite settings.

``sphfem run`` compiles a cold numba cache in a child process first (``sphfem/jit_warmup.py``,
a memory measure for long runs).  The suite's many short CLI runs would each start such a
child for every new scene kind, so the warm-up is off here unless the environment sets
``SPHFEM_JIT_WARMUP``; ``tests/test_jit_warmup.py`` turns it on for its own runs.

``--compile-report FILE`` writes where the suite's time goes (issue 14/15: the default suite
stays under ~10 minutes from an empty numba cache): per test its wall and CPU seconds (own
process and waited-for children), and every numba compilation (a cache miss: numba's
``numba:compile`` event) with the test that paid it, the function, its argument types and
its wall and thread-CPU seconds.  CPU seconds hold on a loaded machine where wall seconds do
not.  Under pytest-xdist each worker writes ``FILE`` with its id before the suffix.
"""

import json
import os
import resource
import time
from pathlib import Path

import pytest

os.environ.setdefault("SPHFEM_JIT_WARMUP", "0")


def pytest_addoption(parser):
    parser.addoption("--compile-report", metavar="FILE", default=None,
                     help="write per-test seconds and numba compilations (JSON) to FILE")


def pytest_configure(config):
    path = config.getoption("--compile-report")
    if path:
        config.pluginmanager.register(_CompileReport(path), "sphfem-compile-report")


def _cpu():
    s = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime, c.ru_utime + c.ru_stime


class _CompileReport:
    """Attributes each outermost numba compilation to the running test."""

    def __init__(self, path):
        from numba.core import event

        worker = os.environ.get("PYTEST_XDIST_WORKER")
        p = Path(path)
        self.path = p.with_name(f"{p.stem}.{worker}{p.suffix}") if worker else p
        self.test = "<collection>"
        self.compiles, self.tests, self._open = [], {}, []
        report = self

        class Listener(event.Listener):
            def on_start(self, ev):
                report._open.append((time.perf_counter(), time.thread_time()))

            def on_end(self, ev):
                w0, c0 = report._open.pop()
                if report._open:  # a callee compiled inside another compilation
                    return
                f = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
                name = f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', '?')}"
                report.compiles.append({
                    "test": report.test, "function": name,
                    "args": str((ev.data or {}).get("args")),
                    "wall_s": time.perf_counter() - w0, "cpu_s": time.thread_time() - c0})

        event.register("numba:compile", Listener())

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(self, item, nextitem):
        self.test = item.nodeid
        w0, (s0, c0) = time.perf_counter(), _cpu()
        yield
        s1, c1 = _cpu()
        self.tests[item.nodeid] = {"wall_s": time.perf_counter() - w0, "cpu_s": s1 - s0,
                                   "children_cpu_s": c1 - c0}
        self.test = "<between tests>"

    def pytest_sessionfinish(self, session):
        cpu, children = _cpu()
        self.path.write_text(json.dumps({"tests": self.tests, "compiles": self.compiles,
                                         "cpu_s": cpu, "children_cpu_s": children}, indent=1))
