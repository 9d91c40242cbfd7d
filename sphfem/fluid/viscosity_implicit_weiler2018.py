"""Implicit viscosity by matrix-free conjugate gradients (``viscosity = "weiler-implicit"``).

Weiler, Koschier, Brand & Bender (2018), Comput. Graph. Forum 37(2), 145-155: the viscous
term is integrated by backward Euler and the velocity system is solved by a
Jacobi-preconditioned conjugate-gradient method without assembling a global matrix (the
pair coefficients of each solve are kept in the neighbour list's slots, :class:`Pairs`).
The viscous operator is the pairwise Laplacian the explicit models use (Park 2019 eq.
3.37-3.40 take this form instead of Weiler's 2(d+2) one), with each particle's own
viscosity:

    (L v)_i = sum_j c_ij (v_j - v_i),
    c_ij = 4 m_j (mu_i + mu_j) F_ij r_ij^2 / ((rho_i + rho_j)^2 (r_ij^2 + eps h^2))   "laminar"
    c_ij =   m_j (mu_i + mu_j) F_ij r_ij^2 / (rho_i rho_j (r_ij^2 + eps h^2))         "morris"

(Shao & Lo 2003 / Morris et al. 1997; F_ij = -W'(r)/r, so r_ij . grad_i W_ij = F r^2).
``weiler_form`` chooses the density factor.  The step then solves

    (I - dt L) v' = v^n + dt a_other        (backward Euler, as Weiler et al. 2018)

where ``a_other`` is every other acceleration of the evaluation (pressure, gravity, the
artificial viscosity; surface tension is added after and stays explicit) and v^n the
velocity the step kicks from: the start-of-step velocity of the symplectic integrator
(``v_n``), or the current velocity under a projection pressure model (whose next step is
then assumed to have the length of the last).  Multiplied by the masses, A = M (I - dt L)
is symmetric (m_i c_ij = m_j c_ji) and positive definite, so CG applies; the
preconditioner is its diagonal m_i (1 + dt sum_j c_ij).  Convergence:
|M^-1 (b - A v')| <= ``weiler_tolerance`` |v'| (a bound on the relative velocity error,
see :func:`pcg`).  The acceleration added to ``acc`` is L v', so the kick v^n + dt acc
gives v' (to the CG residual); the fluid-fluid pairs conserve momentum exactly, and each
wall particle receives the exact negative of its pair forces on the fluid in ``f_fluid``.

Walls (Adami et al. 2012 wall particles; a wall neighbour takes the fluid particle's mu,
mu_i + mu_j -> 2 mu_i) enter as known velocities, ``weiler_walls``:

* ``"mirror"`` (default): fluid particle i sees the wall particle at 2 v_w - v_i, its own
  mirror image through the wall (the ghost velocity of Adami et al. with the extrapolated
  fluid velocity replaced by v_i): the pair term 2 c_iw (v_w - v_i) keeps the system
  symmetric and implicit in v_i.  Stable at any step; Poiseuille error 0.85 % at 20
  particles across (first order in dx).
* ``"wall"``: the wall's own velocity v_w (Park 2019 sec. 2.6.4); the no-slip plane then
  lies inside the wall layers (Poiseuille 17 % at 20 across).
* ``"ghost"``: the wall model's 2 v_w - v~_w of this evaluation, exactly the explicit
  models' wall term (so the operators agree, see the tests), but lagged: it diverged at
  2.7e3 x the explicit viscous step in the stiff Poiseuille flow.

Being implicit (:attr:`ViscosityMethod.implicit`), the model removes the viscous time-step
limit; the step comes from the other limits.  Before the first step (no step length yet)
it adds nothing.  Per-solve iteration counts and residuals are kept in the method's state
(:class:`SolveStats`; the solver's diagnostics ``viscosity_solve``) and logged at DEBUG.
The same code serves 2D and 3D.
"""

from __future__ import annotations

import logging
import math
from array import array
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import grad_factor
from sphfem.fluid.viscosity import ViscosityMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param
from sphfem.smallmat import pair_sep

logger = logging.getLogger(__name__)

#: the pair forms (``weiler_form``) -> kernel code
FORMS = {"laminar": 0, "morris": 1}
#: the wall treatments (``weiler_walls``) -> factor of the wall pairs (see the docstring)
WALLS = {"mirror": 2.0, "wall": 1.0, "ghost": 1.0}
NAME = "weiler-implicit"


class Pairs(NamedTuple):
    """The velocity system's pair coefficients of one evaluation: fluid row i holds its
    fluid neighbours ``nb[offsets[i]:offsets[i] + cnt[i]]`` with coefficients ``coef`` (the
    neighbour list's slots, compacted); ``csum[i]`` = sum_j c_ij over fluid and wall
    neighbours, ``wv[i]`` = sum_w c_iw vw_w (the walls' known part)."""

    offsets: np.ndarray
    nb: np.ndarray
    coef: np.ndarray
    cnt: np.ndarray
    csum: np.ndarray
    wv: np.ndarray


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pair_coefficients(x, rho, meff, mu, vw, kind, offsets, indices, R, sigma, kernel_code,
                      period, eps2, form, wall_factor, nb, coef, cnt, csum, wv):
    """The viscous pair coefficients c_ij of the fluid rows (see :class:`Pairs`).

    Fluid neighbours j go compacted into ``nb``/``coef`` (``cnt`` per row); wall
    neighbours w only into csum[i] and wv[i] = sum_w c_iw vw_w (``vw``: the walls'
    Dirichlet velocity; wall pairs multiplied by ``wall_factor``).  ``form`` 0:
    (rho_i + rho_j)^2 / 4, 1: rho_i rho_j; ``meff`` m of fluid, rho_w V_w of walls; ``eps2``
    = eps_visc h^2.  Non-fluid rows get cnt = 0, csum = 0, wv = 0.
    """
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        s = 0.0
        w0 = 0.0
        w1 = 0.0
        w2 = 0.0
        c_n = 0
        if kind[i] == FLUID:
            for jj in range(offsets[i], offsets[i + 1]):
                j = indices[jj]
                kj = kind[j]
                if kj != FLUID and kj != WALL:
                    continue
                r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                if d2 >= R2 or d2 == 0.0:
                    continue
                F = grad_factor(np.sqrt(d2), R, fac2, kernel_code)
                mus = mu[i] + mu[j] if kj == FLUID else 2.0 * wall_factor * mu[i]
                if form == 0:
                    rs = rho[i] + rho[j]
                    c = 4.0 * meff[j] * mus * F * d2 / ((d2 + eps2) * (rs * rs))
                else:
                    c = meff[j] * mus * F * d2 / ((d2 + eps2) * (rho[i] * rho[j]))
                s += c
                if kj == FLUID:
                    nb[offsets[i] + c_n] = j
                    coef[offsets[i] + c_n] = c
                    c_n += 1
                else:
                    w0 += c * vw[j, 0]
                    if dim > 1:
                        w1 += c * vw[j, 1]
                    if dim > 2:
                        w2 += c * vw[j, 2]
        cnt[i] = c_n
        csum[i] = s
        wv[i, 0] = w0
        if dim > 1:
            wv[i, 1] = w1
        if dim > 2:
            wv[i, 2] = w2


@njit(cache=True, inline="always")
def _row_sum(nb, coef, start, stop, x, dim):
    """sum_j c_ij x_j over one compacted row (3 components, zero-padded)."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for jj in range(start, stop):
        j = nb[jj]
        c = coef[jj]
        s0 += c * x[j, 0]
        if dim > 1:
            s1 += c * x[j, 1]
        if dim > 2:
            s2 += c * x[j, 2]
    return s0, s1, s2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _laplacian(offsets, nb, coef, cnt, csum, wv, kind, v, out):
    n, dim = v.shape
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        s = _row_sum(nb, coef, offsets[i], offsets[i] + cnt[i], v, dim)
        for k in range(dim):
            out[i, k] = wv[i, k] - csum[i] * v[i, k] + s[k]


def apply_laplacian(pairs: Pairs, kind, v, out) -> None:
    """out[i] = (L v)_i = sum_j c_ij (v_j - v_i) for fluid rows (wall neighbours at their
    Dirichlet velocity, through ``wv``); other rows are left alone."""
    _laplacian(pairs.offsets, pairs.nb, pairs.coef, pairs.cnt, pairs.csum, pairs.wv, kind, v,
               out)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _matvec_kernel(offsets, nb, coef, cnt, csum, m, kind, dt, x, y):
    n, dim = x.shape
    xy = 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        d = 1.0 + dt * csum[i]
        s = _row_sum(nb, coef, offsets[i], offsets[i] + cnt[i], x, dim)
        for k in range(dim):
            yk = m[i] * (d * x[i, k] - dt * s[k])
            y[i, k] = yk
            xy += x[i, k] * yk
    return xy


def matvec(pairs: Pairs, m, kind, dt: float, x, y) -> float:
    """y = M (I - dt L0) x over fluid rows (L0: L with the wall velocities set to zero);
    returns x . y."""
    return _matvec_kernel(pairs.offsets, pairs.nb, pairs.coef, pairs.cnt, pairs.csum, m, kind,
                          dt, x, y)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _precondition(r, dinv, m, kind, z):
    """z = D^-1 r over fluid rows; returns (r . z, |M^-1 r|^2)."""
    n, dim = r.shape
    rz = 0.0
    rr = 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        for k in range(dim):
            z[i, k] = dinv[i] * r[i, k]
            rz += r[i, k] * z[i, k]
            rv = r[i, k] / m[i]
            rr += rv * rv
    return rz, rr


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _update(x, r, p, q, alpha, dinv, m, kind, z):
    """x += alpha p, r -= alpha q, z = D^-1 r over fluid rows; returns (r . z, |M^-1 r|^2,
    x . x)."""
    n, dim = x.shape
    rz = 0.0
    rr = 0.0
    xx = 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        for k in range(dim):
            xk = x[i, k] + alpha * p[i, k]
            rk = r[i, k] - alpha * q[i, k]
            zk = dinv[i] * rk
            x[i, k] = xk
            r[i, k] = rk
            z[i, k] = zk
            rz += rk * zk
            rv = rk / m[i]
            rr += rv * rv
            xx += xk * xk
    return rz, rr, xx


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _new_direction(p, z, beta, kind):
    n, dim = p.shape
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        for k in range(dim):
            p[i, k] = z[i, k] + beta * p[i, k]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def _residual(b, Ax, x, m, kind, r):
    """r = b - Ax over fluid rows; returns (|M^-1 b|^2, |M^-1 r|^2, x . x)."""
    n, dim = b.shape
    bb = 0.0
    rr = 0.0
    xx = 0.0
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        for k in range(dim):
            r[i, k] = b[i, k] - Ax[i, k]
            bv = b[i, k] / m[i]
            rv = r[i, k] / m[i]
            bb += bv * bv
            rr += rv * rv
            xx += x[i, k] * x[i, k]
    return bb, rr, xx


def pcg(pairs: Pairs, m, kind, dt: float, b, x, tol: float, max_iter: int, work):
    """Jacobi-preconditioned CG for M (I - dt L0) x = b (fluid rows of ``x``, warm start on
    entry, the solution on return).  ``work``: four arrays shaped like ``x``.

    Stops when |M^-1 (b - A x)| <= tol |x|: since (I - dt L0)^-1 is a contraction in the
    M-norm, this bounds the relative velocity error by about ``tol`` (a criterion relative to
    |b| would not: b holds dt times the body force, which the viscous term cancels).  Returns
    (iterations, |M^-1 r| / |x|); raises FloatingPointError on a non-finite residual."""
    r, z, p, q = work
    matvec(pairs, m, kind, dt, x, q)
    bb, rr, xx = _residual(b, q, x, m, kind, r)
    if bb == 0.0:
        x[kind == FLUID] = 0.0
        return 0, 0.0
    floor = (1e-15) ** 2 * bb  # round-off level of the residual

    def rel(rr, xx):
        return math.sqrt(rr / xx) if xx > 0.0 else math.inf

    if rr <= max(tol * tol * xx, floor):
        return 0, rel(rr, xx)
    dinv = np.where(kind == FLUID, 1.0 / (m * (1.0 + dt * pairs.csum)), 0.0)
    rz, rr = _precondition(r, dinv, m, kind, z)
    p[:] = z
    it = 0
    while it < max_iter:
        it += 1
        alpha = rz / matvec(pairs, m, kind, dt, p, q)
        rz_new, rr, xx = _update(x, r, p, q, alpha, dinv, m, kind, z)
        if not math.isfinite(rr):
            raise FloatingPointError("implicit viscosity: non-finite CG residual")
        if rr <= max(tol * tol * xx, floor):
            break
        _new_direction(p, z, rz_new / rz, kind)
        rz = rz_new
    return it, rel(rr, xx)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def wall_reaction(x, v, vw, rho, meff, mu, kind, offsets, indices, R, sigma, kernel_code,
                  period, eps2, form, wall_factor, f_wall):
    """f_wall[w] += sum_f m_f c_fw (v_f - vw_w) over the fluid neighbours f of each wall
    particle w: the exact negative of the wall's pair forces on the fluid (m_f c_fw uses
    the fluid's mu twice and ``wall_factor``, as in :func:`pair_coefficients`)."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        if kind[i] != WALL:
            continue
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            F = grad_factor(np.sqrt(d2), R, fac2, kernel_code) * wall_factor
            if form == 0:
                rs = rho[i] + rho[j]
                c = 8.0 * meff[i] * meff[j] * mu[j] * F * d2 / ((d2 + eps2) * (rs * rs))
            else:
                c = 2.0 * meff[i] * meff[j] * mu[j] * F * d2 / ((d2 + eps2) * (rho[i] * rho[j]))
            a0 += c * (v[j, 0] - vw[i, 0])
            if dim > 1:
                a1 += c * (v[j, 1] - vw[i, 1])
            if dim > 2:
                a2 += c * (v[j, 2] - vw[i, 2])
        f_wall[i, 0] += a0
        if dim > 1:
            f_wall[i, 1] += a1
        if dim > 2:
            f_wall[i, 2] += a2


@dataclass
class SolveStats:
    """Per-solve record of an implicit viscosity model: the tolerance, and for every step
    its time, iterations and final relative residual (compact arrays ``t``, ``iterations``,
    ``residual``: 24 bytes a step); plus the model's work arrays (sized to the particle
    count, rebuilt when it changes; no state is carried between evaluations, so cell sorts
    need nothing)."""

    method: str
    tolerance: float
    max_iter: int
    t: array = field(default_factory=lambda: array("d"))
    iterations: array = field(default_factory=lambda: array("q"))
    residual: array = field(default_factory=lambda: array("d"))
    not_converged: int = 0
    arrays: dict = field(default_factory=dict, repr=False)

    def work(self, n: int, dim: int, m_list: int) -> dict:
        a = self.arrays
        if a.get("n") != n or a.get("dim") != dim:
            a.clear()
            a.update(n=n, dim=dim, csum=np.zeros(n),
                     **{k: np.zeros((n, dim)) for k in ("wv", "b", "x", "v0", "r", "z", "p",
                                                        "q")})
        if a.get("coef") is None or a["coef"].shape[0] < m_list:
            a["coef"] = np.zeros(m_list + m_list // 4)
            a["nb"] = np.zeros(m_list + m_list // 4, dtype=np.int64)
            a["cnt"] = np.zeros(n, dtype=np.int64)
        if a["cnt"].shape[0] != n:
            a["cnt"] = np.zeros(n, dtype=np.int64)
        return a

    def record(self, t: float, iterations: int, residual: float, converged: bool) -> None:
        self.t.append(t)
        self.iterations.append(iterations)
        self.residual.append(residual)
        if not converged:
            self.not_converged += 1
            logger.warning("%s: not converged in %d iterations at t = %.6g s (relative "
                           "residual %.3g > tolerance %.3g)", self.method, iterations, t,
                           residual, self.tolerance)
        else:
            logger.debug("%s: %d iterations, relative residual %.3g at t = %.6g s",
                         self.method, iterations, residual, t)

    def to_dict(self) -> dict:
        its, res = self.iterations, self.residual
        return {
            "method": self.method, "tolerance": self.tolerance, "max_iter": self.max_iter,
            "solves": len(its),
            "iterations_mean": float(np.mean(its)) if its else None,
            "iterations_max": int(max(its)) if its else None,
            "iterations_last": its[-1] if its else None,
            "residual_max": float(max(res)) if res else None,
            "not_converged": self.not_converged,
        }


def start_velocity(solver) -> np.ndarray:
    """The velocity the coming kick starts from: the symplectic integrator's start-of-step
    ``v_n`` (equation-of-state pressure), else (a projection step) the current ``v``."""
    return solver._scratch.v_n if solver.pressure_method.eos else solver.p.v


def prepare(solver, stats: SolveStats, form: int, walls: str) -> dict:
    """Pair coefficients of this evaluation into the state's work arrays; returns them with
    the wall Dirichlet velocity ``vw``."""
    p, s, nl = solver.p, solver._scratch, solver.nbrs
    a = stats.work(p.n, solver.dim, nl.indices.shape[0])
    vw = s.vg if walls == "ghost" else p.v
    a["wall_factor"] = WALLS[walls]
    m_list = nl.indices.shape[0]
    pairs = Pairs(nl.offsets, a["nb"][:m_list], a["coef"][:m_list], a["cnt"], a["csum"],
                  a["wv"])
    pair_coefficients(p.x, p.rho, s.meff, p.mu, vw, p.kind, nl.offsets, nl.indices, solver.R,
                      solver.sigma, solver.kernel_code, solver.period,
                      solver.params.eps_visc * solver.h * solver.h, form, a["wall_factor"],
                      pairs.nb, pairs.coef, pairs.cnt, pairs.csum, pairs.wv)
    a["vw"] = vw
    a["pairs"] = pairs
    return a


def add_viscous(solver, a: dict, v: np.ndarray, form: int) -> None:
    """acc += L v on the fluid rows, f_fluid += the walls' reaction (wall rows)."""
    p, s, nl = solver.p, solver._scratch, solver.nbrs
    out = a["q"]
    apply_laplacian(a["pairs"], p.kind, v, out)
    fl = p.kind == FLUID
    p.acc[fl] += out[fl]
    wall_reaction(p.x, v, a["vw"], p.rho, s.meff, p.mu, p.kind, nl.offsets, nl.indices,
                  solver.R, solver.sigma, solver.kernel_code, solver.period,
                  solver.params.eps_visc * solver.h * solver.h, form, a["wall_factor"], p.f_fluid)


def _accelerate(solver, state):
    pa = solver.params
    if state is None:
        state = SolveStats(NAME, pa.weiler_tolerance, pa.weiler_max_iter)
    dt = solver.step_dt
    if dt is None:  # the initial evaluation: no step yet, no viscous velocity change
        return state
    form = FORMS[pa.weiler_form]
    a = prepare(solver, state, form, pa.weiler_walls)
    p = solver.p
    fl = p.kind == FLUID
    v0 = start_velocity(solver)
    rhs = a["v0"]
    rhs[fl] = v0[fl] + dt * p.acc[fl]  # v^n + dt a_other
    b = a["b"]
    b[fl] = p.m[fl, None] * (rhs[fl] + dt * a["wv"][fl])
    x = a["x"]
    x[fl] = (2.0 * p.v[fl] - v0[fl]) if solver.pressure_method.eos else rhs[fl]  # warm start
    it, res = pcg(a["pairs"], p.m, p.kind, dt, b, x, state.tolerance, state.max_iter,
                  (a["r"], a["z"], a["p"], a["q"]))
    state.record(solver.t, it, res, res <= state.tolerance)
    add_viscous(solver, a, x, form)
    return state


METHOD = register(ViscosityMethod(
    name=NAME,
    doc="Newtonian or per-particle mu, implicit (backward Euler) after Weiler et al. "
        "(2018): the velocity system M (I - dt L) v = M (v + dt a) solved by matrix-free "
        "Jacobi-preconditioned CG each step, L the laminar (or Morris) pair Laplacian; no "
        "viscous time-step limit",
    params=(
        Param("weiler_tolerance", float, 1e-6, positive=True, when=("viscosity", (NAME,)),
              doc="CG stop: |M^-1 (b - A v)| <= tolerance |v| (about the relative velocity "
                  "error)"),
        Param("weiler_max_iter", int, 1000, positive=True, when=("viscosity", (NAME,)),
              doc="CG iteration limit per step (beyond: counted and logged as not "
                  "converged)"),
        Param("weiler_form", str, "laminar", choices=tuple(FORMS),
              when=("viscosity", (NAME,)),
              doc="density factor of the pair Laplacian: laminar (rho_i + rho_j)^2 / 4 "
                  "(Shao & Lo 2003, as `laminar`), morris rho_i rho_j (as `morris`)"),
        Param("weiler_walls", str, "mirror", choices=tuple(WALLS),
              when=("viscosity", (NAME,)),
              doc="wall particles' velocity seen by fluid particle i in the solve: mirror = "
                  "2 v_w - v_i (implicit no-slip), wall = v_w, ghost = the wall model's "
                  "2 v_w - v~_w of the evaluation (lagged; unstable far above the explicit "
                  "viscous step)"),
    ),
    fused=False,
    accelerate=_accelerate,
    implicit=True,
))
