"""Named validation cases behind ``sphfem validate CASE``.

A case is a function ``case(quick: bool) -> CaseResult`` registered with :func:`register`.
Each run reports its variant, resolution, particle count, relative L2 and L-infinity errors
and wall seconds; the result carries the observed convergence order per variant, the
criteria with their measured values, and the overall verdict.
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
_CASE_MODULES = ("sphfem.validation.operators", "sphfem.validation.heat",
                 "sphfem.validation.fluid", "sphfem.validation.fem",
                 "sphfem.validation.solid", "sphfem.validation.coupling")


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


def register(name: str):
    """Decorator registering a validation case under ``name``."""

    def deco(fn):
        CASES[name] = fn
        return fn

    return deco


def load_cases() -> dict[str, Callable]:
    """Import every case module (each registers its cases) and return the registry."""
    for mod in _CASE_MODULES:
        importlib.import_module(mod)
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


class Timer:
    """Context manager measuring wall seconds into ``.s``."""

    def __enter__(self):
        self._t = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.s = time.perf_counter() - self._t


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
