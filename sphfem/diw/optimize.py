"""Gradient-free optimisation of the toolpath parameters with pymoo's ask/tell interface.

Methods (``method``):

* ``pso``: the thesis' particle swarm (algorithm 3.4; Kennedy & Eberhart 1995, inertia of
  Shi & Eberhart 1998)::

      v_i <- w v_i + C1 r1 (pbest_i - x_i) + C2 r2 (gbest - x_i),    x_i <- x_i + v_i

  with r1, r2 ~ U(0, 1) per component, and each iteration the M members whose last
  evaluation was poorest re-seeded at a uniform random position with a random velocity
  (the thesis' genetic-algorithm-like re-seeding).  pymoo's ``PSO`` with fixed w, C1, C2
  (``adaptive=False``, no perturbation of the best) does the update, including its
  velocity clamp of 20 % of each parameter's range and its bound repair; the re-seeding,
  which pymoo does not have, is :class:`ThesisPSO`.  Defaults w = 0.7298,
  C1 = C2 = 1.49618 (Clerc & Kennedy 2002; the thesis does not give its values).
* ``cma``: CMA-ES (Hansen & Ostermeier 2001) through pymoo's wrapper of ``cma``.
* ``de``: differential evolution DE/rand/1/bin (Storn & Price 1997), pymoo's ``DE``.

:func:`minimize` runs the ask/tell loop until the evaluation budget is spent (whole
batches: the last one may pass the budget by less than one population) or the method
stops by itself (CMA-ES on convergence).  Seeded runs are
deterministic, which the on-disk cache of :mod:`sphfem.diw.evaluate` relies on to resume.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pymoo.algorithms.soo.nonconvex.cmaes import CMAES
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.algorithms.soo.nonconvex.pso import PSO
from pymoo.core.problem import Problem

__all__ = ["METHODS", "OptimizationResult", "ThesisPSO", "make_algorithm", "minimize"]

METHODS = ("pso", "cma", "de")


class ThesisPSO(PSO):
    """pymoo's PSO with fixed w, C1, C2 and the re-seeding of the ``reseed`` (M) poorest
    members every iteration (thesis algorithm 3.4)."""

    def __init__(self, pop_size=20, w=0.7298, c1=1.49618, c2=1.49618, reseed=2, **kw):
        if not 0 <= reseed < pop_size:
            raise ValueError(f"reseed must be in [0, pop_size), got {reseed}")
        super().__init__(pop_size=pop_size, w=w, c1=c1, c2=c2, adaptive=False,
                         pertube_best=False, **kw)
        self.reseed = int(reseed)

    def _infill(self):
        off = super()._infill()
        F = self.particles.get("F")
        if self.reseed and F is not None and len(F) == len(off):
            worst = np.argsort(F[:, 0], kind="stable")[::-1][: self.reseed]
            rng = self.random_state
            xl, xu = self.problem.bounds()
            n = self.problem.n_var
            X = off.get("X")
            V = off.get("V")
            X[worst] = xl + rng.random((len(worst), n)) * (xu - xl)
            V[worst] = rng.random((len(worst), n)) * self.V_max[None, :]
            off.set("X", X)
            off.set("V", V)
        return off


def make_algorithm(method: str, pop_size: int, *, w=0.7298, c1=1.49618, c2=1.49618,
                   reseed: int | None = None, sigma: float = 0.25, initial=None):
    """A pymoo algorithm for ``method`` (one of :data:`METHODS`) with ``pop_size``
    members per iteration.  ``reseed`` (PSO): M, default 10 % of the swarm; ``sigma``
    (CMA-ES): initial step as a fraction of the (normalised) parameter range;
    ``initial``: the first population (PSO, DE: an array (pop_size, n)) or its first
    row as CMA-ES' mean; None: pymoo's Latin hypercube / random start."""
    kw = {} if initial is None else {"sampling": np.asarray(initial, dtype=float)}
    if method == "pso":
        m = max(1, pop_size // 10) if reseed is None else reseed
        return ThesisPSO(pop_size=pop_size, w=w, c1=c1, c2=c2, reseed=m, **kw)
    if method == "cma":
        x0 = None if initial is None else np.asarray(initial, dtype=float)[0]
        return CMAES(popsize=pop_size, sigma=sigma, normalize=True, x0=x0)
    if method == "de":
        return DE(pop_size=pop_size, variant="DE/rand/1/bin", CR=0.9, F=0.8, **kw)
    raise ValueError(f"unknown method {method!r} (known: {', '.join(METHODS)})")


@dataclass
class OptimizationResult:
    """Best point, its objective, and per iteration: evaluations so far, the best objective
    of the iteration and the best so far."""

    method: str
    x: np.ndarray
    objective: float
    n_eval: int
    history: list[dict] = field(default_factory=list)


def minimize(evaluate: Callable, lower, upper, budget: int, method: str = "pso",
             pop_size: int = 20, seed: int = 0, callback: Callable | None = None,
             start=None, **options) -> OptimizationResult:
    """Minimise ``evaluate(X, iteration) -> F`` (a batch of rows -> objectives) over the box
    [lower, upper] with at most ``budget`` evaluations rounded up to whole batches.
    ``start``: a point made a member of the first population (the others uniform random,
    seeded; CMA-ES: its initial mean), e.g. the naive toolpath, so the result is never
    worse than it.  ``options`` go to :func:`make_algorithm`; ``callback(row)`` gets each
    history row."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    problem = Problem(n_var=len(lower), n_obj=1, xl=lower, xu=upper)
    if start is not None:
        rng = np.random.default_rng(seed)
        initial = lower + rng.random((pop_size, len(lower))) * (upper - lower)
        initial[0] = np.clip(start, lower, upper)
        options = {**options, "initial": initial}
    algo = make_algorithm(method, pop_size, **options)
    algo.setup(problem, seed=seed, verbose=False)
    n_eval, it = 0, 0
    best_x, best_f = None, np.inf
    history = []
    while n_eval < budget:
        if not algo.has_next():  # CMA-ES stops by itself once converged (tolx, tolfun)
            break
        pop = algo.ask()
        X = pop.get("X")
        F = np.asarray(evaluate(X, it), dtype=float).reshape(-1)
        pop.set("F", F[:, None])
        algo.tell(infills=pop)
        n_eval += len(X)
        k = int(np.argmin(F))
        if F[k] < best_f:
            best_f, best_x = float(F[k]), X[k].copy()
        row = {"iteration": it, "n_eval": n_eval, "iteration_best": float(F[k]),
               "best": best_f, "best_x": best_x.tolist()}
        history.append(row)
        if callback is not None:
            callback(row)
        it += 1
    return OptimizationResult(method, best_x, best_f, n_eval, history)
