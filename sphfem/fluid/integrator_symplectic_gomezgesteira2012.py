"""Symplectic position Verlet in predictor-corrector form (``integrator = "symplectic"``).

The scheme of DualSPHysics (Gomez-Gesteira et al. 2012, Comput. Geosci. 48, 289; after
Leimkuhler, Reich & Skeel 1996), second order, one force evaluation per step:

    x* = x + dt/2 v,  v* = v + dt/2 a,  rho* = rho + dt/2 Drho    (a, Drho of the last step)
    a, Drho = forces(x*, v*, rho*)                                  at t + dt/2
    v' = v + dt a,  rho' = rho + dt Drho,  x' = x* + dt/2 v'

Only fluid particles move; the start-of-step v and rho are kept in the solver's work
arrays (``v_n``, ``rho_n``) across the neighbour-list update after the half drift.
"""

from __future__ import annotations

import time

from numba import njit, prange

from sphfem.fluid.integrators import Integrator, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def predict(x, v, rho, acc, drho, kind, dt, v_n, rho_n):
    """Half drift and half kick of the fluid particles; v_n, rho_n := v, rho."""
    n, dim = x.shape
    h = 0.5 * dt
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        rho_n[i] = rho[i]
        rho[i] += h * drho[i]
        for k in range(dim):
            v_n[i, k] = v[i, k]
            x[i, k] += h * v[i, k]
            v[i, k] += h * acc[i, k]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def correct(x, v, rho, acc, drho, kind, dt, v_n, rho_n):
    """Full kick from the start-of-step state, then the second half drift."""
    n, dim = x.shape
    h = 0.5 * dt
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        rho[i] = rho_n[i] + dt * drho[i]
        for k in range(dim):
            v[i, k] = v_n[i, k] + dt * acc[i, k]
            x[i, k] += h * v[i, k]


def advance(solver, dt: float) -> None:
    """One step of length ``dt`` (see the module docstring)."""
    p, s = solver.p, solver._scratch
    t0 = time.perf_counter()
    predict(p.x, p.v, p.rho, p.acc, p.drho, p.kind, dt, s.v_n, s.rho_n)
    solver.wall["integrate"] += time.perf_counter() - t0
    solver.after_drift()
    solver.evaluate(solver.t + 0.5 * dt)
    p, s = solver.p, solver._scratch  # the list update may have cell-sorted the particles
    t0 = time.perf_counter()
    correct(p.x, p.v, p.rho, p.acc, p.drho, p.kind, dt, s.v_n, s.rho_n)
    solver.wall["integrate"] += time.perf_counter() - t0


METHOD = register(Integrator(
    name="symplectic",
    doc="symplectic position Verlet in the predictor-corrector form of DualSPHysics "
        "(Gomez-Gesteira et al. 2012): half drift and kick, forces at the half step, full "
        "kick, second half drift; second order, one force evaluation per step",
    params=(),
    order=2,
    advance=advance,
))
