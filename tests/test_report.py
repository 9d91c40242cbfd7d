"""``sphfem validate all``: a report section per case; a failing or broken case is reported,
the others still run, and the verdict fails."""

import json

from sphfem.cli import main
from sphfem.validation import CaseResult, Criterion, Run
from sphfem.validation import report as rep


def _good(quick):
    runs = [Run("v", h, 10, 0.1 * h**2, 0.2 * h**2, 0.01) for h in (0.1, 0.05)]
    return CaseResult("good", runs, {"order": Criterion("observed order", 2.0, 1.5, ">=")})


def _broken(quick):
    raise RuntimeError("mesh file missing")


def test_validate_all_report(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(rep, "load_cases", lambda: {"good": _good, "broken": _broken})
    out = tmp_path / "report"
    assert main(["validate", "all", "--quick", "--out", str(out)]) == 1
    text = (out / "report.md").read_text()
    assert "## good: PASSED" in text and "## broken: ERROR" in text
    assert "mesh file missing" in text and "| good | passed |" in text
    assert json.loads((out / "good.json").read_text())["passed"] is True
    assert (out / "good.png").stat().st_size > 1000
    # an existing report folder is not clobbered without --overwrite
    assert main(["validate", "all", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_validate_all_needs_out(capsys):
    assert main(["validate", "all"]) == 2
    assert "--out" in capsys.readouterr().err


def test_update_readme_replaces_marked_block(tmp_path, monkeypatch):
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{rep.README_BEGIN}\nold table\n{rep.README_END}\nrest\n")
    monkeypatch.setattr(rep, "load_cases", lambda: {"good": _good})
    assert main(["validate", "all", "--out", str(tmp_path / "r"),
                 "--update-readme", str(readme)]) == 0
    text = readme.read_text()
    assert "old table" not in text and "| good | passed |" in text
    assert text.startswith("intro\n") and text.endswith("rest\n")


# --------------------------------------------------------------------------------------
# warm-up before timing


def _fake_case(log, compile_in=None):
    """A case with three timed runs (coarse to fine) that logs what it executes; the run
    named ``compile_in`` compiles a fresh numba function inside its timed block."""
    from sphfem.validation import Timer

    kernel = _fresh_kernel()

    def case(quick):
        log.append(("start", quick))
        runs = []
        for variant, h in (("a", 0.1), ("a", 0.05), ("b", 0.1)):
            try:  # a case's own error handling must not swallow the warm-up's stop
                with Timer() as tm:
                    log.append((variant, h))
                    if (variant, h) == compile_in:
                        kernel(1.0)
            except Exception:
                log.append("swallowed")
            runs.append(Run(variant, h, 10, h, h, tm.s))
        return CaseResult("fake", runs, {"ok": Criterion("always", 0.0, 1.0)})

    return case


def _fresh_kernel():
    """A numba function not compiled before (a new closure each call; no disk cache).
    Its body is large enough that compiling it takes well over ``COMPILE_NOTE_S`` (0.05 s)
    even once LLVM is warm in the process (a one-line body took 0.05 s there: the note
    then depended on the machine's speed)."""
    import numpy as np
    from numba import njit

    k = float(len(_KERNELS))

    @njit
    def f(x):
        a = np.arange(64.0) * x + k
        s = 0.0
        for i in range(a.size):
            for j in range(i):
                s += np.sin(a[i] - a[j]) * np.exp(-abs(a[j])) / (1.0 + a[i] * a[i])
        b = np.sort(a)[::-1]
        c = np.cumsum(b) + np.linalg.norm(a)
        return s + c[-1] + np.median(a) + np.std(a)

    _KERNELS.append(f)
    return f


_KERNELS: list = []


def test_warm_up_runs_the_first_timed_block_untimed():
    from sphfem.validation import run_case

    log = []
    result = run_case("fake", False, fn=_fake_case(log))
    assert log == [("start", True), ("a", 0.1),  # warm-up: quick, up to its first block
                   ("start", False), ("a", 0.1), ("a", 0.05), ("b", 0.1)]
    assert any("untimed warm-up" in n for n in result.notes)
    log.clear()
    run_case("fake", False, warmup=False, fn=_fake_case(log))
    assert log == [("start", False), ("a", 0.1), ("a", 0.05), ("b", 0.1)]


def test_registered_warm_up_hook_replaces_the_default(monkeypatch):
    import sphfem.validation as V

    calls, log = [], []
    monkeypatch.setitem(V.WARMUPS, "fake", lambda: calls.append("hook"))
    V.run_case("fake", True, fn=_fake_case(log))
    assert calls == ["hook"] and log[0] == ("start", True) and len(log) == 4


def test_timer_measures_numba_compilation():
    """A block that compiles a numba function reports its compile seconds; calling the
    compiled function again in a second block reports none."""
    from sphfem.validation import Timer

    f = _fresh_kernel()
    with Timer() as first:
        f(2.0)
    with Timer() as second:
        f(3.0)
    assert first.compile_s > 0.01 and first.compile_s <= first.s
    assert second.compile_s < 1e-3


def test_compilation_left_in_a_timed_run_is_named():
    """The warm-up reaches variant a's first block only: a kernel first compiled in
    variant b's timed block is named in the notes; one compiled in a's first block is
    moved out of the timed runs by the warm-up."""
    from sphfem.validation import run_case

    warm = run_case("fake", True, fn=_fake_case([], compile_in=("a", 0.1)))
    assert not any("compilation inside timed runs" in n for n in warm.notes)
    cold = run_case("fake", True, warmup=False, fn=_fake_case([], compile_in=("a", 0.1)))
    assert any("compilation inside timed runs: a at 0.1" in n for n in cold.notes)
    late = run_case("fake", True, fn=_fake_case([], compile_in=("b", 0.1)))
    assert any("compilation inside timed runs: b at 0.1" in n for n in late.notes)
