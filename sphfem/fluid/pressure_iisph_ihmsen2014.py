"""Implicit incompressible SPH of Ihmsen et al. (2014) (``pressure = "iisph"``).

M. Ihmsen, J. Cornelis, B. Solenthaler, C. Horvath, M. Teschner, "Implicit incompressible
SPH", IEEE TVCG 20 (2014) 426, Algorithm 1; Park (2019) sec. 2.2.1.2, eqs. 2.32-2.43.
The pressure Poisson equation of the density-invariance condition, at the positions x^n of
the step (pairs, g_ij = grad_i W_ij, rho_i and A_i of :mod:`sphfem.fluid.projection`):

    rho0 - rho^adv_i = dt^2 sum_j M_j (a_i(p) - a_j(p)) . g_ij =: (A p)_i,
    rho^adv_i = rho_i + dt sum_j M_j v*_ij . g_ij                      (eqs. 2.36-2.39)

(a_j = 0 on wall particles, a_i(p) the symmetric pressure acceleration with the wall
mirroring p_i), solved by relaxed Jacobi iterations with the pressure clamped at zero
(eq. 2.43), so the free surface needs no detection:

    p_i <- max(0, p_i + omega (rho0 - rho^adv_i - (A p)_i) / a_ii),
    a_ii = -dt^2 A_i / rho_i^2                                          (eq. 12 of the paper)

with omega = ``iisph_omega`` (0.5 in the paper; capped by
:func:`sphfem.fluid.projection.relaxation` where it would diverge: 0.27 in 3D), warm
start p^0 = p(t - dt) / 2 (the first step: the set-up's p in full), until the mean
predicted density error max(rho^adv_i + (A p)_i - rho0, 0) / rho0 over the fluid particles is within
``iisph_tolerance`` (per cent; at least two iterations).  Then v^{n+1} = v* + dt a_i(p).
The A p product is two gathers: a_i(p) over the pairs, then its density rate.  A shortened
step carries only (dt / dt_prev)^2 of the last density error
(:func:`sphfem.fluid.projection.carried_weight`).  Wall particles: their own volumes and
the pressure extrapolated from the fluid (see :mod:`sphfem.fluid.projection`); their
``f_fluid`` gets the exact reaction of the wall terms.  Iterations and the final density
error per step are in ``diagnostics()["pressure_solve"]``.
"""

from __future__ import annotations

import logging

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

#: least Jacobi iterations per step (Ihmsen et al. 2014, Alg. 1: l < 2)
MIN_ITERATIONS = 2
#: the warm start p^0 = WARM_FRACTION p(t - dt) (Ihmsen et al. 2014, sec. 3.3)
WARM_FRACTION = 0.5


@njit(cache=True, parallel=True)
def predicted_error(rho_adv, rate_p, kind, rho0, dt, rho_pred):
    """rho_pred_i = rho^adv_i + dt^2 D_i(a^p) of fluid rows; returns the mean of
    max(rho_pred_i - rho0, 0) / rho0 over the fluid particles (strict maths)."""
    n = rho_adv.shape[0]
    s = 0.0
    nf = 0
    for i in prange(n):
        if kind[i] != FLUID:
            rho_pred[i] = 0.0
            continue
        r = rho_adv[i] + dt * dt * rate_p[i]
        rho_pred[i] = r
        nf += 1
        if r > rho0:
            s += r - rho0
    return s / (rho0 * nf) if nf > 0 else 0.0


@njit(cache=True, parallel=True)
def relaxed_jacobi(p, rho_pred, rho, A, kind, rho0, dt, omega):
    """p_i <- max(0, p_i + omega (rho0 - rho_pred_i) / a_ii), a_ii = -dt^2 A_i / rho_i^2,
    on fluid rows (p_i = 0 where A_i = 0: no neighbours)."""
    n = p.shape[0]
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        if A[i] > 0.0:
            new = p[i] + omega * (rho_pred[i] - rho0) * rho[i] * rho[i] / (dt * dt * A[i])
            p[i] = new if new > 0.0 else 0.0
        else:
            p[i] = 0.0


def _solve(solver, dt: float, state):
    return projection.timed_solve(_solve_timed, solver, dt, state)


def _solve_timed(solver, dt: float, state):
    pa = solver.params
    st = state if state is not None else ProjectionState(tolerance=pa.iisph_tolerance)
    w = projection.prepare(solver, st)
    p, nl, rho0 = solver.p, solver.nbrs, pa.rho0
    pairs = projection.solve_pairs(solver, w)
    fl = p.kind == FLUID
    g = solver.body_force(solver.t)
    projection.add_wall_hydrostatic(solver, w, dt, g)
    density_rate(p.v, *pairs, w.rate)
    rho_adv = w.Qv  # work array: rho^adv
    beta = projection.carried_weight(st, dt, solver)
    rho_adv[:] = rho0 + beta * (w.rho - rho0) + dt * w.rate
    P = w.Q  # the pressure being solved for (warm start from the last step's)
    P[:] = 0.0
    first = not st.log.iterations  # the set-up's p (e.g. hydrostatic) in full
    P[fl] = (1.0 if first else WARM_FRACTION) * p.p[fl].clip(min=0.0)
    tol = 0.01 * pa.iisph_tolerance
    omega = projection.relaxation(st, pa.iisph_omega)
    it = 0
    while True:
        w.q[:] = 0.0
        w.q[fl] = P[fl] / (w.rho[fl] * w.rho[fl])
        wall_extrapolate(w.q, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt)
        pressure_acceleration(w.q, *pairs, 1.0, w.acc_p, False)
        density_rate(w.acc_p, *pairs, w.rate)
        err = predicted_error(rho_adv, w.rate, p.kind, rho0, dt, w.aux)
        if (err <= tol and it >= MIN_ITERATIONS) or it >= pa.iisph_max_iterations:
            break
        relaxed_jacobi(P, w.aux, w.rho, w.A, p.kind, rho0, dt, omega)
        it += 1
    p.v[fl] += dt * w.acc_p[fl]
    p.p[fl] = P[fl]
    projection.finish(solver, st, w.q)
    log = st.log
    log.iterations.append(it)
    log.density_error.append(err)
    if it >= pa.iisph_max_iterations:
        log.not_converged += 1
        logger.warning("iisph step %d: iteration limit %d (density error %.3g %%)",
                       solver.step_count, it, 100 * err)
    logger.debug("iisph step %d: %d iterations, density error %.3g %%", solver.step_count,
                 it, 100 * err)
    return st


_WHEN = ("pressure", ("iisph",))

METHOD = register(PressureMethod(
    name="iisph",
    doc="implicit incompressible SPH (Ihmsen et al. 2014): pressure Poisson equation of "
        "the density invariance by relaxed Jacobi iterations with p clamped at 0, "
        "warm-started; time step from the CFL condition (no c0); walls are the wall "
        "particles with their own volumes",
    params=(
        Param("iisph_tolerance", float, 0.1, unit="%", positive=True, when=_WHEN,
              doc="largest mean predicted density error max(rho - rho0, 0)/rho0 over the "
                  "fluid particles, in per cent"),
        Param("iisph_max_iterations", int, 100, ge=1, when=_WHEN,
              doc="iteration limit per step (reaching it is logged and counted in "
                  "steps_not_converged)"),
        Param("iisph_omega", float, 0.5, gt=0.0, le=1.0, when=_WHEN,
              doc="relaxation factor of the Jacobi iteration (Ihmsen et al.: 0.5)"),
    ),
    solve=_solve,
    finish=add_reaction,
))
