"""The fluid's stand-alone runner: the :class:`~sphfem.context.StepContext` that drives a
:class:`~sphfem.fluid.wcsph.FluidSolver` when no :class:`~sphfem.simulation.Simulation`
does (validation cases, benchmarks, tests).

The solver has one life: it always works on a context and, after every drift, asks
``ctx.neighbors()`` for a list valid at the current positions, taking a new one when
``ctx.nbrs_version`` changed.  Driven, the simulation's list service answers; stand-alone,
the :class:`VerletService` of :func:`standalone_context` does, with the fluid's own policy:

* a Verlet list of radius R (1 + skin), rebuilt when some *fluid* particle moved more than
  skin R / 2 since the last build (every drift when skin = 0);
* before a build, positions on periodic axes are wrapped into the box, and every
  ``sort_every``-th build the particles are cell-sorted (cells of the list radius; the
  solver's ``reorder`` permutes its mid-step state);
* the list is built directly as the fluid's view (pair filter of the search,
  :data:`sphfem.fluid.passes.VIEW_KEEP`), so the context says ``fluid_view = True`` and the
  solver skips its filter pass.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from sphfem.context import StepContext
from sphfem.fluid import passes
from sphfem.neighbors import build_neighbor_list, cell_sort_permutation, min_image
from sphfem.particles import FLUID, ParticleSet


@njit(cache=True, parallel=True)
def max_disp_sq(x, xref, v, half_dt, kind, period):
    """max over fluid of |x + half_dt v - xref|^2 (minimum image on periodic axes)."""
    n, dim = x.shape
    out = np.zeros(n)
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        s = 0.0
        for k in range(dim):
            d = min_image(x[i, k] + half_dt * v[i, k] - xref[i, k], period[k])
            s += d * d
        out[i] = s
    return out.max() if n else 0.0


@dataclass(eq=False)
class FluidViewContext(StepContext):
    """A context whose list is already the fluid's view (``fluid_view``)."""

    fluid_view: bool = True


class VerletService:
    """The list service of a stand-alone context (see the module docstring).

    ``params``: read at every call for ``skin`` and ``sort_every`` (the solver's
    :class:`~sphfem.fluid.wcsph.FluidParams`; a benchmark may change them between steps);
    ``wall``: the solver's seconds by stage (the list time goes to ``"neighbors"``);
    ``on_reorder(perm)``: called after a cell sort permuted the particles.
    """

    def __init__(self, ctx: StepContext, params, wall: dict,
                 on_reorder: Callable[[np.ndarray], None]):
        self.ctx = ctx
        self.params = params
        self.wall = wall
        self.on_reorder = on_reorder
        self.builds = 0
        self.xref = None

    @property
    def radius(self) -> float:
        return self.ctx.R * (1.0 + self.params.skin)

    def __call__(self, rebuild: bool) -> None:
        ctx = self.ctx
        if rebuild or ctx.nbrs is None or self.params.skin <= 0 or self._moved():
            self.build()

    def _moved(self) -> bool:
        t0 = time.perf_counter()
        p, lim = self.ctx.particles, 0.5 * self.params.skin * self.ctx.R
        d2 = max_disp_sq(p.x, self.xref, p.v, 0.0, p.kind, self.ctx.period)
        self.wall["neighbors"] += time.perf_counter() - t0
        return d2 > lim * lim

    def build(self) -> None:
        """Wrap periodic positions, cell-sort every ``sort_every`` builds, build the list."""
        t0 = time.perf_counter()
        ctx = self.ctx
        p = ctx.particles
        x = p.x
        for k in range(p.dim):
            L = ctx.period[k]
            if L > 0:
                x[:, k] = ctx.lo[k] + np.mod(x[:, k] - ctx.lo[k], L)
        every = self.params.sort_every
        if every and self.builds % every == 0:
            perm = cell_sort_permutation(x, self.radius, ctx.lo, ctx.hi, ctx.period)
            p.reorder(perm)
            self.on_reorder(perm)
        ctx.nbrs = build_neighbor_list(p.x, self.radius, ctx.lo, ctx.hi, ctx.period,
                                       kind=p.kind, keep=passes.VIEW_KEEP)
        ctx.nbrs_version += 1
        self.builds += 1
        self.xref = p.x.copy()
        self.wall["neighbors"] += time.perf_counter() - t0


def standalone_context(particles: ParticleSet, R: float, sigma: float, kernel_code: int,
                       kernel: str, lo, hi, period, params, wall: dict,
                       on_reorder) -> FluidViewContext:
    """A context for a stand-alone fluid run, served by a :class:`VerletService`."""
    ctx = FluidViewContext(particles, R, sigma, kernel_code, kernel, lo, hi, period, {},
                           moving=True)
    ctx.provide = VerletService(ctx, params, wall, on_reorder)
    return ctx
