"""Divergence-free SPH of Bender & Koschier (2017) (``pressure = "dfsph"``).

J. Bender, D. Koschier, "Divergence-free SPH for incompressible and viscous fluids", IEEE
TVCG 23 (2017) 1193, Algorithms 1-3; Park (2019) sec. 2.2.1.3, Alg. 2.2-2.4, with the
erratum of DESIGN.md (the density solve divides by the factor).  Two solves of the same
form on the velocities, both by Jacobi iterations at the positions x^n of the step, with
the pairs, g_ij = grad_i W_ij, rho_i and A_i of :mod:`sphfem.fluid.projection`:

* **divergence solve** (Alg. 2) on v^n = v* - dt a_nonp: until the mean of
  dt max(D_i, 0) / rho0 is within ``dfsph_divergence_tolerance`` (per cent; at least one
  iteration), with D_i = sum_j M_j v_ij . g_ij,
      kappa^v_i = D_i / dt * rho_i / A_i;
* **density solve** (Alg. 3) on v* = v^n + dt a_nonp: until the mean of max(rho*_i - rho0, 0)
  / rho0 is within ``dfsph_tolerance`` (per cent; at least two iterations), with the
  predicted density rho*_i = rho_i + dt D_i,
      kappa_i = (rho*_i - rho0) / dt^2 * rho_i / A_i,
  (Bender & Koschier's alpha_i = rho_i / A_i multiplies, i.e. the factor A_i divides;
  DESIGN.md's erratum of the thesis' Alg. 2.4);
* each iteration, with q = kappa / rho = p / rho^2 and the pressure acceleration a_i(q) of
  :mod:`sphfem.fluid.projection` (the walls' q_b extrapolated from the fluid):
      v_i += dt a_i(dq),   dq_i = omega e_i / (dt^2 A_i),   e_i the source above,
  where the step's total Q_i + dq_i is clamped at zero (Ihmsen's clamping of the pressure:
  the free surface gets no tension, and an overshoot is taken back); the errors count
  only compression, max(e_i, 0).

Two departures from the paper, both measured: (1) relaxation omega = 0.5 (as in
SPlisHSPlasH's DFSPH; capped by :func:`sphfem.fluid.projection.relaxation`, 0.27 in 3D):
the paper's unrelaxed increments diverged on the R = 3 dx Wendland stencil (2D column at
rest, blow-up within 5 steps), and with increments clamped at zero instead of the total, an
overshoot could never be taken back (a column at rest sagged at 0.6 m/s); (2) warm start of
the density solve with half the last step's kappa (kept under the particles' ids; the
full kappa kept the solver's checkerboard errors: max speed 0.7 m/s in the same column;
the first step takes the set-up's p, e.g. hydrostatic, in full), on every fluid particle
(limited to the particles predicted to be compressed, as in SPlisHSPlasH, the a/80 dam
break's first steps needed 90-100 iterations instead of 2).  A
shortened step carries only (dt / dt_prev)^2 of the density error
(:func:`sphfem.fluid.projection.carried_weight`).  The divergence solve is warm-started the
same way (Bender & Koschier 2017 warm-start both solves; SPlisHSPlasH's
``warmstartDivergenceSolve``): ``dfsph_divergence_warm_start`` (default 0.5) of the last
step's kappa^v, kept as dt kappa^v so that it does not depend on the new step's dt, applied
on the particles where the flow compresses (:func:`warm_start_divergence`).  Measured
(benchmarks/splishsplash, DamBreakModel, 59,319 fluid particles, cubic R = 2 dx, to 0.25 s,
2 threads, idle machine, side by side): divergence iterations per step 11.6 -> 7.0, density
2.8 -> 2.8, stepping 30.8 -> 25.3 s (an earlier pair: 25.0 -> 18.0 s); at 6,859 particles
4.7 -> 3.4 iterations and no change in time (the warm start costs about one iteration: a
density rate and a pressure application).  The 2D column at rest keeps its bounds (wall
force / weight 0.99997), the 2D dam break's front Z(T = 3) moves by -0.2 % (a/20) and
+1.2 % (a/40).  The full fraction 1 took the 59k case to 1.4 iterations, but the 2D dam
break at a/20 blew up at T = 3.0 (8,800 m/s), and at a/40 its front ran 2.6 % ahead: the
push a warm start gives is not taken back where it overshoots into expansion (the error
counts compression only).

Order within the shared step (:func:`sphfem.fluid.pressure.projection_advance`): the
paper's divergence solve of the end of step n runs at the start of step n+1, at the same
positions x^n and with the same rho and A as the density solve (computed once), so the
non-pressure forces of step n+1 see the velocities before it.  ``p`` of a fluid particle
is rho_i^2 times the step's total q (both solves), the wall particles' ``p`` is the
one the solve gave them, and their ``f_fluid`` gets the exact reaction of the solves'
wall terms.  Iterations, final density and divergence errors per step are in
``diagnostics()["pressure_solve"]``.
"""

from __future__ import annotations

import logging

import numpy as np
from numba import njit, prange

from sphfem.fluid import projection
from sphfem.fluid.pressure import PressureMethod, register
from sphfem.fluid.projection import (
    ProjectionState,
    add_reaction,
    density_rate,
    pressure_acceleration,
    wall_extrapolate,
)
from sphfem.particles import FLUID
from sphfem.schema import Param

logger = logging.getLogger(__name__)

#: least iterations of the divergence and density solves (Bender & Koschier, Alg. 2-3)
MIN_ITERATIONS_DIVERGENCE = 1
MIN_ITERATIONS_DENSITY = 2
#: fraction of the last step's kappa applied as warm start of the density solve
WARM_FRACTION = 0.5
#: relaxation of the Jacobi increments (SPlisHSPlasH's DFSPH: 0.5; see the module docstring)
RELAX = 0.5


@njit(cache=True, parallel=True)
def stiffness(rho, rate, A, kind, rho0, dt, density, Q, dq, beta, relax):
    """Increment dq_i of q_i = kappa_i / rho_i on fluid rows: the paper's
    e_i / (dt^2 A_i) with e_i = beta (rho_i - rho0) + dt D_i (``density``; beta:
    :func:`sphfem.fluid.projection.carried_weight`) or dt D_i (divergence),
    D_i = ``rate``, clamped so that the step's total Q_i + dq_i stays >= 0; returns the
    mean of max(e_i, 0) / rho0 over fluid particles (strict maths)."""
    n = rho.shape[0]
    s = 0.0
    nf = 0
    for i in prange(n):
        dq[i] = 0.0
        if kind[i] != FLUID:
            continue
        nf += 1
        e = dt * rate[i] + (beta * (rho[i] - rho0) if density else 0.0)
        if e > 0.0:
            s += e
        if A[i] > 0.0:
            new = Q[i] + relax * e / (dt * dt * A[i])
            dq[i] = (new if new > 0.0 else 0.0) - Q[i]
    return s / (rho0 * nf) if nf > 0 else 0.0


def jacobi(solver, w, dt: float, density: bool, tol: float, min_it: int, max_it: int,
           relax: float, beta: float = 1.0):
    """Jacobi iterations of one solve on ``solver.p.v`` (fluid rows), accumulating q in
    ``w.Q`` (density) or ``w.Qv`` (divergence); returns (iterations, final error)."""
    p, nl, rho0 = solver.p, solver.nbrs, solver.params.rho0
    pairs = projection.solve_pairs(solver, w)
    Q = w.Q if density else w.Qv
    it = 0
    while True:
        density_rate(p.v, *pairs, w.rate)
        err = stiffness(w.rho, w.rate, w.A, p.kind, rho0, dt, density, Q, w.q, beta, relax)
        if (err <= tol and it >= min_it) or it >= max_it:
            return it, err
        wall_extrapolate(w.q, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt)
        pressure_acceleration(w.q, *pairs, dt, p.v, True)
        Q += w.q
        it += 1


def warm_start_divergence(solver, state: ProjectionState, w, dt: float) -> None:
    """Apply the fraction f = ``dfsph_divergence_warm_start`` of the last step's divergence
    solve, as SPlisHSPlasH's warm start: q^v_i = f (dt_prev kappa^v_prev,i) / (dt rho_i)
    into ``w.Qv`` on the fluid particles whose flow compresses (D_i(v^n) > 0), 0 on the
    others (and on a particle without a stored value, e.g. at the first step), then
    v += dt a(q^v) on every fluid particle.  The pair form of a(q) is antisymmetric, so the
    warm start conserves momentum and the walls' reaction (from the step's total q) stays
    exact; applying the velocity change only to the compressing particles instead made the
    resting ink drop of tests/test_dfsph_coupled.py load its substrate with 1.2 % more than
    its weight.  The stored q^v of an expanding particle is dropped: kept, its push is never
    taken back (the solve's error counts compression only) and the 2D dam break's front at
    a/30 ran 0.7 % ahead."""
    p = solver.p
    w.Qv[:] = 0.0
    frac = solver.params.dfsph_divergence_warm_start
    if frac == 0.0:
        return
    impulse = state.warm_v.get(p.id)  # dt kappa^v of the last step, >= 0
    on = (p.kind == FLUID) & (w.rho > 0) & (impulse > 0.0)
    if not on.any():
        return
    nl = solver.nbrs
    pairs = projection.solve_pairs(solver, w)
    density_rate(p.v, *pairs, w.rate)  # D_i at v^n, before the warm start
    on &= w.rate > 0.0  # only where the flow compresses (SPlisHSPlasH)
    w.Qv[on] = frac * impulse[on] / (dt * w.rho[on])
    wall_extrapolate(w.Qv, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt)
    pressure_acceleration(w.Qv, *pairs, dt, p.v, True)


def warm_start(solver, state: ProjectionState, w, dt: float) -> None:
    """Apply WARM_FRACTION of the last step's kappa (the first step: kappa = p / rho of the
    set-up's p, in full) to the fluid particles (v* -> v* + dt a(q_warm)); q_warm goes into
    ``w.Q``."""
    p, nl = solver.p, solver.nbrs
    pairs = projection.solve_pairs(solver, w)
    fl = p.kind == FLUID
    first = not state.log.iterations  # the set-up's p (e.g. hydrostatic) in full
    kappa = p.p / np.where(w.rho > 0, w.rho, 1.0) if first else state.warm.get(p.id)
    on = fl & (w.rho > 0)
    w.Q[:] = 0.0
    w.Q[on] = (1.0 if first else WARM_FRACTION) * kappa[on] / w.rho[on]
    if on.any():
        wall_extrapolate(w.Q, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt)
        pressure_acceleration(w.Q, *pairs, dt, p.v, True)


def _solve(solver, dt: float, state):
    return projection.timed_solve(_solve_timed, solver, dt, state)


def _solve_timed(solver, dt: float, state):
    pa = solver.params
    st = state if state is not None else ProjectionState(tolerance=pa.dfsph_tolerance)
    w = projection.prepare(solver, st)
    p = solver.p
    fl = p.kind == FLUID
    p.v[fl] -= dt * p.acc[fl]  # v^n: the divergence solve of the end of step n
    warm_start_divergence(solver, st, w, dt)
    relax = projection.relaxation(st, RELAX)
    itv, errv = jacobi(solver, w, dt, False, 0.01 * pa.dfsph_divergence_tolerance,
                       MIN_ITERATIONS_DIVERGENCE, pa.dfsph_divergence_max_iterations, relax)
    p.v[fl] += dt * p.acc[fl]  # v* of step n+1
    g = solver.body_force(solver.t)
    projection.add_wall_hydrostatic(solver, w, dt, g)
    warm_start(solver, st, w, dt)
    it, err = jacobi(solver, w, dt, True, 0.01 * pa.dfsph_tolerance, MIN_ITERATIONS_DENSITY,
                     pa.dfsph_max_iterations, relax, projection.carried_weight(st, dt, solver))
    st.warm.put(p.id[fl], (w.rho * w.Q)[fl])  # kappa of the density solve
    st.warm_v.put(p.id[fl], (dt * w.rho * w.Qv)[fl])  # dt kappa^v of the divergence solve
    q = w.Q + w.Qv
    p.p[fl] = (w.rho * w.rho * q)[fl]
    projection.finish(solver, st, q)
    log = st.log
    log.iterations.append(it)
    log.divergence_iterations.append(itv)
    log.density_error.append(err)
    log.divergence_error.append(errv)
    if it >= pa.dfsph_max_iterations or itv >= pa.dfsph_divergence_max_iterations:
        log.not_converged += 1
        logger.warning("dfsph step %d: iteration limit (density %d, error %.3g %%; "
                       "divergence %d, error %.3g %%)", solver.step_count, it, 100 * err,
                       itv, 100 * errv)
    logger.debug("dfsph step %d: %d divergence iterations (%.3g %%), %d density "
                 "iterations (%.3g %%)", solver.step_count, itv, 100 * errv, it, 100 * err)
    return st


_WHEN = ("pressure", ("dfsph",))

METHOD = register(PressureMethod(
    name="dfsph",
    doc="divergence-free SPH (Bender & Koschier 2017): a divergence solve and a "
        "constant-density solve by Jacobi iterations, kappa_i = (rho*_i - rho0)/dt^2 "
        "rho_i/A_i, warm-started; time step from the CFL condition (no c0); walls are the "
        "wall particles with their own volumes",
    params=(
        Param("dfsph_tolerance", float, 0.1, unit="%", positive=True, when=_WHEN,
              doc="density solve: largest mean density error max(rho* - rho0, 0)/rho0 "
                  "over the fluid particles, in per cent"),
        Param("dfsph_divergence_tolerance", float, 0.1, unit="%", positive=True,
              when=_WHEN,
              doc="divergence solve: largest mean dt max(Drho/Dt, 0)/rho0, in per cent"),
        Param("dfsph_divergence_warm_start", float, 0.5, ge=0.0, le=1.0, when=_WHEN,
              doc="fraction of the last step's divergence-solve pressure impulse applied "
                  "before the divergence solve, where the flow compresses (Bender & "
                  "Koschier 2017's warm start, as SPlisHSPlasH; 1 is unstable; 0: off)"),
        Param("dfsph_max_iterations", int, 100, ge=1, when=_WHEN,
              doc="iteration limit of the density solve (reaching it is logged and counted "
                  "in steps_not_converged)"),
        Param("dfsph_divergence_max_iterations", int, 100, ge=1, when=_WHEN,
              doc="iteration limit of the divergence solve"),
    ),
    solve=_solve,
    finish=add_reaction,
))
