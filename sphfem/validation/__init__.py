"""Named validation cases behind ``sphfem validate CASE``.

A case is a function ``case(quick: bool) -> CaseResult`` registered with :func:`register`.
Each run reports its variant, resolution, particle count, relative L2 and L-infinity errors
and wall seconds; the result carries the observed convergence order per variant, the
criteria with their measured values, and the overall verdict.

Wall seconds exclude numba's compilation where the harness can arrange it: :func:`run_case`
first runs an untimed warm-up (the case's registered ``warmup`` hook, or by default the
case itself at quick settings, stopped at the end of its first timed block: the cheapest
configuration of its first variant), then the timed case.  Every :class:`Timer` block also
measures the seconds numba spent compiling or loading kernels from its cache inside it;
runs that still paid for it are named in the result's notes.
"""

from __future__ import annotations

import importlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

CASES: dict[str, Callable[[bool], CaseResult]] = {}
#: per-case warm-up hooks (None: the default, :func:`_warm_up_first_block`)
WARMUPS: dict[str, Callable[[], None] | None] = {}
_CASE_MODULES = ("sphfem.validation.operators", "sphfem.validation.heat",
                 "sphfem.validation.fluid", "sphfem.validation.fem",
                 "sphfem.validation.solid", "sphfem.validation.fem_axisymmetric",
                 "sphfem.validation.droplet_impact", "sphfem.validation.viscous_stiff",
                 "sphfem.validation.hb_poiseuille",
                 "sphfem.validation.dambreak_incompressible")
#: entry-point group of installed packages that register validation cases of their own
#: (``coupling`` registers ``shear-transfer`` from ``coupling.validation``)
CASE_ENTRY_POINT_GROUP = "sphfem.validation"


@dataclass
class Run:
    """One resolution of one variant."""

    variant: str
    resolution: float
    n_particles: int
    error_l2: float
    error_linf: float
    wall_s: float
    extra: dict = field(default_factory=dict)


@dataclass
class Criterion:
    """A pass/fail check: ``value`` compared against ``limit`` (``op`` is '<=' or '>=')."""

    description: str
    value: float
    limit: float
    op: str = "<="

    @property
    def passed(self) -> bool:
        if self.value is None or (isinstance(self.value, float) and math.isnan(self.value)):
            return False
        return self.value <= self.limit if self.op == "<=" else self.value >= self.limit


@dataclass
class CaseResult:
    case: str
    runs: list[Run]
    criteria: dict[str, Criterion]
    notes: list[str] = field(default_factory=list)
    resolution_label: str = "resolution"
    #: keys of ``Run.extra`` printed as extra table columns, with their headers
    extra_columns: dict[str, str] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.criteria.values())

    @property
    def observed_order(self) -> dict[str, float | None]:
        variants = dict.fromkeys(r.variant for r in self.runs)
        return {v: observed_order(self.runs, v) for v in variants}

    def to_json(self) -> dict:
        return {
            "case": self.case,
            "runs": [asdict(r) for r in self.runs],
            "observed_order": self.observed_order,
            "criteria": {
                k: {**asdict(c), "passed": c.passed} for k, c in self.criteria.items()
            },
            "notes": self.notes,
            "passed": self.passed,
        }


def register(name: str, warmup: Callable[[], None] | None = None):
    """Decorator registering a validation case under ``name``; ``warmup``: an untimed
    callable that compiles what the case's timed runs use (default: the case's own first
    timed block at quick settings, see :func:`run_case`)."""

    def deco(fn):
        CASES[name] = fn
        WARMUPS[name] = warmup
        return fn

    return deco


def load_cases() -> dict[str, Callable]:
    """Import every case module (each registers its cases), sphfem's own and those that
    installed packages declare in :data:`CASE_ENTRY_POINT_GROUP`, and return the registry."""
    from importlib.metadata import entry_points

    for mod in _CASE_MODULES:
        importlib.import_module(mod)
    for ep in entry_points(group=CASE_ENTRY_POINT_GROUP):
        importlib.import_module(ep.value.split(":")[0])
    return CASES


def relative_errors(approx: np.ndarray, exact: np.ndarray) -> tuple[float, float]:
    """Relative L2 (sqrt(sum e^2 / sum exact^2)) and L-infinity (max|e| / max|exact|) errors."""
    e = np.asarray(approx, float) - np.asarray(exact, float)
    ex = np.asarray(exact, float)
    l2d = math.sqrt(float(np.sum(ex**2))) or 1.0
    lid = float(np.max(np.abs(ex))) if ex.size else 1.0
    lid = lid or 1.0
    return math.sqrt(float(np.sum(e**2))) / l2d, float(np.max(np.abs(e))) / lid if e.size else 0.0


def observed_order(runs: list[Run], variant: str) -> float | None:
    """Observed order of the L2 error between the two finest resolutions of ``variant``.

    ``resolution`` is the particle spacing (smaller is finer).  None when fewer than two
    runs exist or an error is at round-off (below 1e-12), where an order means nothing.
    """
    rs = sorted((r for r in runs if r.variant == variant), key=lambda r: r.resolution)
    if len(rs) < 2:
        return None
    f, c = rs[0], rs[1]
    if f.error_l2 < 1e-12 or c.error_l2 < 1e-12 or f.resolution == c.resolution:
        return None
    return math.log(c.error_l2 / f.error_l2) / math.log(c.resolution / f.resolution)


class WarmedUp(BaseException):
    """Raised at the end of the first :class:`Timer` block of a warm-up run (a
    BaseException, so that a case's own ``except Exception`` does not swallow it)."""


class _Session:
    """The timed blocks of one case run (``warmup``: stop after the first)."""

    def __init__(self, warmup: bool = False):
        self.warmup = warmup
        self.blocks: list[Timer] = []


_SESSION: list[_Session] = []


def _compile_listener():
    """A numba event listener summing the seconds of outermost ``numba:compiler_lock``
    events: compilations and loads from the on-disk cache (they nest)."""
    from numba.core import event

    class _Clock(event.Listener):
        def __init__(self):
            self.s, self._depth, self._t0 = 0.0, 0, 0.0

        def on_start(self, ev):
            if self._depth == 0:
                self._t0 = time.perf_counter()
            self._depth += 1

        def on_end(self, ev):
            self._depth -= 1
            if self._depth == 0:
                self.s += time.perf_counter() - self._t0

    return _Clock()


class Timer:
    """Context manager measuring wall seconds into ``.s`` and, of them, the seconds numba
    spent compiling or loading kernels from its cache into ``.compile_s``.  Inside
    :func:`run_case` each block is recorded; in its warm-up the first block ends the case
    (:class:`WarmedUp`)."""

    def __enter__(self):
        from numba.core import event

        self._clock = _compile_listener()
        event.register("numba:compiler_lock", self._clock)
        self._t = time.perf_counter()
        return self

    def __exit__(self, exc_type, *exc):
        from numba.core import event

        self.s = time.perf_counter() - self._t
        event.unregister("numba:compiler_lock", self._clock)
        self.compile_s = self._clock.s
        if _SESSION:
            _SESSION[-1].blocks.append(self)
            if _SESSION[-1].warmup and exc_type is None:
                raise WarmedUp


def _warm_up_first_block(fn: Callable[[bool], CaseResult]) -> None:
    """The default warm-up: ``fn(True)`` up to the end of its first timed block (cases time
    their coarsest resolution first)."""
    _SESSION.append(_Session(warmup=True))
    try:
        fn(True)
    except WarmedUp:
        pass
    finally:
        _SESSION.pop()


#: a timed block that spent more than this in numba's compiler is named in the notes
COMPILE_NOTE_S = 0.05


def run_case(name: str, quick: bool, warmup: bool = True,
             fn: Callable[[bool], CaseResult] | None = None) -> CaseResult:
    """Run the registered case ``name`` (or the case function ``fn``) with its timed runs
    warmed up.

    ``warmup``: first run the case's ``warmup`` hook, or by default the case at quick
    settings up to the end of its first timed block, untimed; this moves numba's
    compilation (and first-use costs such as imports) out of the timed runs.  Runs whose
    timed block still spent more than :data:`COMPILE_NOTE_S` compiling (a variant whose
    kernels the warm-up did not reach) are named in the notes, with the warm-up seconds.
    """
    fn = fn if fn is not None else load_cases()[name]
    notes = []
    if warmup:
        t0 = time.perf_counter()
        hook = WARMUPS.get(name)
        if hook is not None:
            hook()
        else:
            _warm_up_first_block(fn)
        notes.append(f"untimed warm-up before the timed runs: {time.perf_counter() - t0:.1f} s")
    session = _Session()
    _SESSION.append(session)
    try:
        result = fn(quick)
    finally:
        _SESSION.pop()
    by_wall = {b.s: b for b in session.blocks}
    slow = [(r, by_wall[r.wall_s]) for r in result.runs
            if r.wall_s in by_wall and by_wall[r.wall_s].compile_s > COMPILE_NOTE_S]
    other = sum(b.compile_s for b in session.blocks
                if b.compile_s > COMPILE_NOTE_S and b not in [t for _, t in slow])
    if slow or other:
        what = ", ".join(f"{r.variant} at {r.resolution:.4g}: {t.compile_s:.2f} of "
                         f"{r.wall_s:.2f} s" for r, t in slow)
        if other:
            what += (", " if what else "") + f"other timed blocks: {other:.2f} s"
        notes.append(f"numba compilation inside timed runs: {what}")
    result.notes.extend(notes)
    return result


def format_table(result: CaseResult) -> str:
    """The human-readable table printed by ``sphfem validate``."""
    head = f"{'variant':<28} {result.resolution_label:>11} {'particles':>9} {'err L2':>10} "
    head += f"{'err Linf':>10} {'wall s':>8}"
    head += "".join(f" {h:>10}" for h in result.extra_columns.values())
    lines = [f"case {result.case}", head, "-" * len(head)]
    for r in result.runs:
        lines.append(
            f"{r.variant:<28} {r.resolution:>11.4g} {r.n_particles:>9d} {r.error_l2:>10.3e} "
            f"{r.error_linf:>10.3e} {r.wall_s:>8.3f}"
            + "".join(f" {_fmt(r.extra.get(k)):>10}" for k in result.extra_columns)
        )
    lines.append("observed order (L2, two finest): " + ", ".join(
        f"{v}: {'-' if o is None else f'{o:.2f}'}" for v, o in result.observed_order.items()
    ))
    for name, c in result.criteria.items():
        mark = "PASS" if c.passed else "FAIL"
        lines.append(f"[{mark}] {name}: {c.description}: {c.value:.3g} {c.op} {c.limit:.3g}")
    lines.extend(f"note: {n}" for n in result.notes)
    lines.append("PASSED" if result.passed else "FAILED")
    return "\n".join(lines)


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (int, np.integer)):
        return str(v)
    return f"{v:.3e}"


def work_precision_plot(result: CaseResult, path) -> None:
    """Log-log plot of relative L2 error against wall seconds, one line per variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for v in dict.fromkeys(r.variant for r in result.runs):
        rs = sorted((r for r in result.runs if r.variant == v), key=lambda r: r.wall_s)
        ax.loglog([max(r.wall_s, 1e-6) for r in rs], [max(r.error_l2, 1e-17) for r in rs],
                  "o-", label=v)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("relative L2 error")
    ax.set_title(f"{result.case}: error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_json(result: CaseResult, path) -> None:
    """Write the case result as JSON (atomically: temp file then rename)."""
    from sphfem.output import atomic_write_text

    atomic_write_text(path, json.dumps(result.to_json(), indent=2, default=_json_default))


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))
