"""Semi-implicit viscosity by fixed-point iteration (``viscosity = "park-semi-implicit"``).

Park (2019), PhD thesis, sec. 2.6.3 (eq. 2.155-2.161): the viscous acceleration is
integrated by the implicit trapezoidal rule and the resulting system is solved by a
fixed-point iteration.  With the pair Laplacian L of
:mod:`sphfem.fluid.viscosity_implicit_weiler2018` (per-particle mu, eq. 2.146-2.147 with the
density factor of DESIGN.md's erratum) the step solves

    v' = v^n + dt a_other + dt/2 (L v' + L v^n)                              (2.155)

(v^n the velocity the kick starts from, ``a_other`` the evaluation's other accelerations)
by the iteration v^{k+1} = Psi(v^k) of eq. 2.161, here with each particle's own velocity
taken at the new iterate (a Jacobi sweep):

    v_i^{k+1} = (r_i + dt/2 sum_j c_ij v_j^k) / (1 + dt/2 sum_j c_ij),
    r = v^n + dt a_other + dt/2 L v^n  (+ the walls' known part),

stopped when the residual of the iterate is below ``park_tolerance`` |v^{k+1}| (2-norms
over the fluid; :func:`fixed_point`).
Two deviations from the thesis, both stated: (1) the thesis' plain Picard map
v^{k+1} = r + dt/2 L v^k contracts only for dt/2 rho(L) < 1, i.e. at the explicit step, so
the diagonal is taken implicitly (the matrix I - dt/2 L is diagonally dominant, so the
sweep converges for every dt, with a rate 1 - O(1 / (dt rho(L))) that makes large steps
costly); (2) positions are not iterated (the thesis iterates r and u together): the
neighbour list and the coefficients are those of the evaluation, the time integrator moves
the particles.  The acceleration added is (L v' + L v^n) / 2, so the kick gives v' (to the
iteration's tolerance), with the walls' reaction in ``f_fluid``.  The trapezoidal rule is
second order and A-stable but does not damp the stiffest modes (amplification -> -1 as
dt rho(L) -> infinity), unlike the backward Euler of ``weiler-implicit``.

Walls as ``weiler-implicit`` (``park_walls``).  Implicit: no viscous time-step limit.
Before the first step it adds nothing.  Iterations per step in the solver's diagnostics
``viscosity_solve``.
"""

from __future__ import annotations

import math

from numba import njit, prange

from sphfem.fluid import viscosity_implicit_weiler2018 as weiler
from sphfem.fluid.viscosity import ViscosityMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID
from sphfem.schema import Param

NAME = "park-semi-implicit"


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _sweep(offsets, nb, coef, cnt, csum, kind, half_dt, r, x, y):
    n, dim = x.shape
    dd = 0.0
    yy = 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        diag = 1.0 + half_dt * csum[i]
        s = weiler._row_sum(nb, coef, offsets[i], offsets[i] + cnt[i], x, dim)
        for k in range(dim):
            yk = (r[i, k] + half_dt * s[k]) / diag
            d = diag * (yk - x[i, k])  # the residual r - (I - dt/2 L0) x of the iterate x
            y[i, k] = yk
            dd += d * d
            yy += yk * yk
    return dd, yy


def jacobi_sweep(pairs: weiler.Pairs, kind, half_dt: float, r, x, y):
    """y_i = (r_i + dt/2 sum_j c_ij x_j) / (1 + dt/2 sum_j c_ij) over fluid rows (fluid
    neighbours j); returns (|D (y - x)|^2, |y|^2), D (y - x) = r - (I - dt/2 L0) x being the
    residual of x."""
    return _sweep(pairs.offsets, pairs.nb, pairs.coef, pairs.cnt, pairs.csum, kind, half_dt,
                  r, x, y)


def fixed_point(pairs: weiler.Pairs, kind, half_dt: float, r, x, y, tol: float,
                max_iter: int):
    """Jacobi sweeps from ``x`` until the residual of the last iterate is at most tol times
    the new one, |r - (I - dt/2 L0) x^k| <= tol |x^{k+1}| (which bounds the relative error:
    (I - dt/2 L0)^-1 is a contraction; the change |x^{k+1} - x^k| alone does not, its ratio
    to the error being ~ 1 / (1 - rate) with a rate close to 1 at large steps); the result
    is in ``x`` (``y``: work array).  Returns (iterations, last relative residual)."""
    rel = math.inf
    it = 0
    while it < max_iter:
        it += 1
        dd, yy = jacobi_sweep(pairs, kind, half_dt, r, x, y)
        x, y = y, x
        if not math.isfinite(dd):
            raise FloatingPointError("semi-implicit viscosity: non-finite iterate")
        rel = math.sqrt(dd / yy) if yy > 0.0 else 0.0
        if rel <= tol:
            break
    if it % 2 == 1:  # the last sweep wrote into the caller's y
        y[:] = x
    return it, rel


def _accelerate(solver, state):
    pa = solver.params
    if state is None:
        state = weiler.SolveStats(NAME, pa.park_tolerance, pa.park_max_iter)
    dt = solver.step_dt
    if dt is None:  # the initial evaluation: no step yet, no viscous velocity change
        return state
    a = weiler.prepare(solver, state, 0, pa.park_walls)
    p = solver.p
    fl = p.kind == FLUID
    v0 = weiler.start_velocity(solver)
    lv0 = a["z"]
    weiler.apply_laplacian(a["pairs"], p.kind, v0, lv0)
    r = a["b"]
    r[fl] = v0[fl] + dt * p.acc[fl] + 0.5 * dt * (lv0[fl] + a["wv"][fl])
    x = a["x"]
    x[fl] = (2.0 * p.v[fl] - v0[fl]) if solver.pressure_method.eos else r[fl]
    it, rel = fixed_point(a["pairs"], p.kind, 0.5 * dt, r, x, a["r"], state.tolerance,
                          state.max_iter)
    state.record(solver.t, it, rel, rel <= state.tolerance)
    mean = a["p"]
    mean[fl] = 0.5 * (x[fl] + v0[fl])
    weiler.add_viscous(solver, a, mean, 0)
    return state


METHOD = register(ViscosityMethod(
    name=NAME,
    doc="Newtonian or per-particle mu, semi-implicit after Park (2019) sec. 2.6.3: implicit "
        "trapezoidal rule for the laminar pair Laplacian solved by a fixed-point (Jacobi) "
        "iteration each step; no viscous time-step limit, but the iteration count grows "
        "with dt / (explicit viscous step)",
    params=(
        Param("park_tolerance", float, 1e-6, positive=True, when=("viscosity", (NAME,)),
              doc="fixed-point stop: residual |r - (I - dt/2 L) v^k| <= tolerance |v^{k+1}| "
                  "(about the relative velocity error)"),
        Param("park_max_iter", int, 2000, positive=True, when=("viscosity", (NAME,)),
              doc="iteration limit per step (beyond: counted and logged as not converged)"),
        Param("park_walls", str, "mirror", choices=tuple(weiler.WALLS),
              when=("viscosity", (NAME,)),
              doc="wall particles' velocity in the solve, as `weiler_walls`"),
    ),
    fused=False,
    accelerate=_accelerate,
    implicit=True,
))
