"""Building blocks shared by the pressure-projection methods (IISPH, DFSPH).

Both solvers (:mod:`~sphfem.fluid.pressure_iisph_ihmsen2014`,
:mod:`~sphfem.fluid.pressure_dfsph_bender2017`) work at the positions x^n of the step with
the kernel gradients of one list, so the pairs and their gradients g_ij = grad_i W_ij are
computed once per step (:func:`pairs_and_density`), the fluid rows' pairs are packed with
M_j g_ij in single precision (:func:`pack_pairs`, :data:`PAIR_DTYPE`), and every solver
iteration is two gathers over the packed pairs.  Notation as in
:mod:`sphfem.fluid.passes`: r = x_j - x_i, g_ij = F(r) r with F = -W'(r)/r, so g_ij points
from i to j.

Density by summation over fluid and wall particles (Ihmsen et al. 2014, eq. 1; walls as
Akinci et al. 2012 boundary particles):

    rho_i = sum_j M_j W_ij,   M_j = m_j / S (fluid), M_b = rho0 V_b / S (wall particle b).

Walls: the wall particles' own volumes V_b (``vol``, dx^d on the wall lattice), not
Akinci et al.'s psi_b = rho0 / sum_k W_bk.  The walls here are layers at least R deep, so
the wall particles fill the kernel support behind the wall and their lattice volumes
already complete the fluid's density there (rho = rho0 at the wall); psi_b is made for a
single boundary layer and would count the first of several layers about twice
(sum_k W_bk of a surface particle sees half a support of wall particles).  A wall particle
carries a pressure in the symmetric pair form, extrapolated from its fluid neighbours as
in Adami et al. (2012, eq. 27): q_b = p_b / rho^2 is the Shepard average of the fluid q
(:func:`wall_extrapolate`, inside every iteration) plus the hydrostatic part qh_b
(:func:`wall_hydrostatic_q`, once per step, a known force).  Measured on a 2D column at
rest (H/20, dt = 2 ms, 2 s): mirroring p_i (Akinci et al. 2012, eq. 10) with one term let
the hydrostatic column sag into the walls, with the symmetric factor 2 the wall layer's
pressure checkerboard shook it horizontally (max speed 0.3 sqrt(g H)); the extrapolated
pressure leaves 0.013 sqrt(g H) (DFSPH) and a time-mean pressure within 3.4 % of rho g d.

Density rate, pressure acceleration and the diagonal of the pressure system (all sums over
fluid and wall neighbours j unless marked F, fluid only):

    D_i(u) = sum_j M_j (u_i - u_j) . g_ij                                   (continuity)
    a_i(q) = -sum_j M_j (q_i + q_j) g_ij,   q = p / rho^2
    A_i    = max((s_F + 2 s_W) . (s_F + s_W), 0) + sum_F m_i m_j |g_ij|^2,
    s_F = sum_F M_j g_ij,  s_W = sum_W M_b g_ib

A_i is Bender & Koschier's (2017) denominator of alpha_i (their eq. 11: alpha_i = rho_i /
(|sum_j M_j g_ij|^2 + sum_F |M_j g_ij|^2) for equal masses) with the walls mirroring q_i,
and, times -dt^2 / rho_i^2, Ihmsen et al.'s a_ii (eq. 12): the Jacobi diagonal.  With the
extrapolated wall pressure it over-estimates the true diagonal near walls (a safe
under-relaxation).  The relaxed Jacobi needs omega lambda_max(D^-1 A) < 2: lambda_max is
3.3 on the 2D lattice and 6.2 on the 3D one (R = 3 dx, measured by power iteration), so
omega = 0.5 converges in 2D and diverges in 3D, where omega <= 0.3 is needed.

Rest state: the particles' masses are rho0 dx^d, but inside a lattice the discrete kernel sum
S = sum_k dx^d W(|k| dx) is not exactly one (:func:`lattice_sum`: 1.0051 in 2D, 1.0031 in
3D for the Wendland C2 kernel at R = 3 dx), so the lattice at rest would read rho0 S and be
pushed apart by 0.5 % in the first step.  The sums therefore use M_j / S (the particle
volumes of the summation, calibrated on the lattice once per run, as SPlisHSPlasH sets its
particle volume to 0.8 (2r)^3 for its kernel), and the set-up lattice is at rest at rho0.

The incompressible fluid's density is rho0 where the free surface truncates the kernel
support: ``rho`` of a fluid particle is max(rho_i, rho0) (the solvers' sources are clamped
the same way), and the density error of a step is the mean over fluid particles of
max(rho_i - rho0, 0) / rho0.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import NBLOCKS, _block, grad_factor
from sphfem.kernels import FASTMATH, kernel_dfdq, kernel_f, kernel_sigma
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import pair_sep

logger = logging.getLogger(__name__)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pairs_and_density(x, kind, M, offsets, indices, R, sigma, kernel_code, period, nbj,
                      grad, wgt, cnt, rho):
    """In-range pairs (0 < r < R) of the list rows into the rows' own slots
    ``nbj[offsets[i] : offsets[i] + cnt[i]]`` with g_ij in ``grad`` and W_ij in ``wgt``
    (fluid rows: fluid and wall neighbours; wall rows: fluid neighbours), and
    rho_i = sum_j M_j W_ij (self term included) of fluid rows."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / R2
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for blk in prange(NBLOCKS):  # blocks of equal list length (see _block)
        lo, hi = _block(blk, offsets)
        for i in range(lo, hi):
            ki = kind[i]
            o = offsets[i]
            c = 0
            s = M[i] * sigma * kernel_f(0.0, kernel_code)
            if ki == FLUID or ki == WALL:
                for jj in range(o, offsets[i + 1]):
                    j = indices[jj]
                    kj = kind[j]
                    if not (kj == FLUID or (ki == FLUID and kj == WALL)):
                        continue
                    r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
                    d2 = r0 * r0 + r1 * r1 + r2 * r2
                    if d2 >= R2 or d2 == 0.0:
                        continue
                    d = np.sqrt(d2)
                    F = grad_factor(d, R, fac2, kernel_code)
                    nbj[o + c] = j
                    rr = (r0, r1, r2)
                    for k in range(dim):
                        grad[o + c, k] = F * rr[k]
                    wj = sigma * kernel_f(d / R, kernel_code)
                    wgt[o + c] = wj
                    s += M[j] * wj
                    c += 1
            cnt[i] = c
            rho[i] = s if ki == FLUID else 0.0


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pack_pairs(M, kind, offsets, nbj, grad, cnt, off_c, nb_c, mg_c, A):
    """The fluid rows' in-range pairs of :func:`pairs_and_density`, packed without gaps for
    the solver's iterations, and the diagonal A_i, in one pass over the pairs.

    Packed: row i's pairs at ``off_c[i] : off_c[i + 1]`` (``off_c``: the prefix sum of
    ``cnt`` over fluid rows, no pairs for other rows), neighbour ``nb_c`` (int32) and
    mg_ij = M_j g_ij in ``mg_c`` (its dtype: float32 in the solvers, :data:`PAIR_DTYPE`).

    A_i = max((s_F + 2 s_W) . (s_F + s_W), 0) + sum_F M_i M_j |g_ij|^2 of fluid rows (0
    elsewhere; double precision), s_F = sum_F M_j g_ij, s_W = sum_W M_b g_ib.  The first
    term is the exact diagonal's; it turns negative where a wall is near and the fluid
    support is deficient (s_F ~ -1.5 s_W), and is then dropped: a larger diagonal only
    under-relaxes the Jacobi step, a vanishing one made it blow up (a 3 MPa spike at the 2D
    dam break's wall)."""
    dim = grad.shape[1]
    for blk in prange(NBLOCKS):  # blocks of equal list length (see _block)
        lo, hi = _block(blk, offsets)
        for i in range(lo, hi):
            A[i] = 0.0
            if kind[i] != FLUID:
                continue
            o = offsets[i]
            oc = off_c[i]
            f0 = 0.0
            f1 = 0.0
            f2 = 0.0
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            self_sum = 0.0
            for k in range(cnt[i]):
                j = nbj[o + k]
                nb_c[oc + k] = j
                g0 = M[j] * grad[o + k, 0]
                g1 = M[j] * grad[o + k, 1] if dim > 1 else 0.0
                g2 = M[j] * grad[o + k, 2] if dim > 2 else 0.0
                mg_c[oc + k, 0] = g0
                if dim > 1:
                    mg_c[oc + k, 1] = g1
                if dim > 2:
                    mg_c[oc + k, 2] = g2
                if kind[j] == FLUID:
                    f0 += g0
                    f1 += g1
                    f2 += g2
                    self_sum += M[i] / M[j] * (g0 * g0 + g1 * g1 + g2 * g2)
                else:
                    w0 += g0
                    w1 += g1
                    w2 += g2
            cross = ((f0 + 2.0 * w0) * (f0 + w0) + (f1 + 2.0 * w1) * (f1 + w1)
                     + (f2 + 2.0 * w2) * (f2 + w2))
            A[i] = self_sum + (cross if cross > 0.0 else 0.0)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def density_rate(u, kind, off_c, nb_c, mg_c, out):
    """out_i = sum_j M_j (u_i - u_j) . g_ij of fluid rows over the packed pairs of
    :func:`pack_pairs` (wall rows of ``u``: the walls' velocities, or zeros for a
    pressure acceleration); 0 elsewhere."""
    dim = mg_c.shape[1]
    for blk in prange(NBLOCKS):  # blocks of equal pair count (see _block)
        lo, hi = _block(blk, off_c)
        for i in range(lo, hi):
            s = 0.0
            if kind[i] == FLUID:
                for k in range(off_c[i], off_c[i + 1]):
                    j = nb_c[k]
                    d = (u[i, 0] - u[j, 0]) * mg_c[k, 0]
                    if dim > 1:
                        d += (u[i, 1] - u[j, 1]) * mg_c[k, 1]
                    if dim > 2:
                        d += (u[i, 2] - u[j, 2]) * mg_c[k, 2]
                    s += d
            out[i] = s


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def pressure_acceleration(q, kind, off_c, nb_c, mg_c, scale, out, accumulate):
    """out_i (+)= scale a_i(q) of fluid rows, a_i(q) = -sum_j M_j (q_i + q_j) g_ij over the
    packed pairs of :func:`pack_pairs` (fluid and wall neighbours; q = p / rho^2, a
    wall's q_b from :func:`wall_extrapolate`); rows of other kinds are zeroed unless
    ``accumulate``."""
    dim = mg_c.shape[1]
    for blk in prange(NBLOCKS):  # blocks of equal pair count (see _block)
        lo, hi = _block(blk, off_c)
        for i in range(lo, hi):
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            if kind[i] == FLUID:
                qi = q[i]
                for k in range(off_c[i], off_c[i + 1]):
                    f = -(qi + q[nb_c[k]])
                    a0 += f * mg_c[k, 0]
                    if dim > 1:
                        a1 += f * mg_c[k, 1]
                    if dim > 2:
                        a2 += f * mg_c[k, 2]
            elif accumulate:
                continue
            a = (a0, a1, a2)
            for c in range(dim):
                out[i, c] = out[i, c] + scale * a[c] if accumulate else scale * a[c]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def wall_extrapolate(q, kind, offsets, nbj, wgt, cnt):
    """q_b = sum_f q_f W_bf / sum_f W_bf on wall rows (0 without fluid neighbours): the
    wall particles' pressure (over rho^2) extrapolated from the fluid, the p-dependent part
    of Adami et al. (2012, eq. 27); fluid rows are left alone."""
    for blk in prange(NBLOCKS):  # blocks of equal list length (see _block)
        lo, hi = _block(blk, offsets)
        for b in range(lo, hi):
            if kind[b] != WALL:
                continue
            o = offsets[b]
            sw = 0.0
            sq = 0.0
            for k in range(cnt[b]):
                sw += wgt[o + k]
                sq += q[nbj[o + k]] * wgt[o + k]
            q[b] = sq / sw if sw > 0.0 else 0.0


@njit(cache=True, parallel=True)
def mean_excess(rho, kind, rho0):
    """Mean over fluid particles of max(rho_i - rho0, 0) / rho0 (strict maths)."""
    n = rho.shape[0]
    s = 0.0
    nf = 0
    for i in prange(n):
        if kind[i] == FLUID:
            nf += 1
            if rho[i] > rho0:
                s += rho[i] - rho0
    return s / (rho0 * nf) if nf > 0 else 0.0


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def wall_hydrostatic_q(x, rho, acc, kind, offsets, nbj, wgt, cnt, gravity, period, rho0, qh):
    """qh_b = (g - a_b) . sum_f rho_f (x_b - x_f) W_bf / (sum_f W_bf rho0^2) on wall rows
    (0 elsewhere): the hydrostatic part of the wall pressure of Adami et al. (2012, eq. 27),
    over rho0^2; it does not depend on p."""
    n, dim = x.shape
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for blk in prange(NBLOCKS):  # blocks of equal list length (see _block)
        lo, hi = _block(blk, offsets)
        for b in range(lo, hi):
            qh[b] = 0.0
            if kind[b] != WALL:
                continue
            o = offsets[b]
            sw = 0.0
            sh = 0.0
            for k in range(cnt[b]):
                f = nbj[o + k]
                r0, r1, r2 = pair_sep(x, f, b, dim, period, periodic)  # x_b - x_f
                h = (gravity[0] - acc[b, 0]) * r0
                if dim > 1:
                    h += (gravity[1] - acc[b, 1]) * r1
                if dim > 2:
                    h += (gravity[2] - acc[b, 2]) * r2
                sw += wgt[o + k]
                sh += rho[f] * h * wgt[o + k]
            qh[b] = sh / (sw * rho0 * rho0) if sw > 0.0 else 0.0


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def wall_reaction(q, m, M, kind, offsets, nbj, grad, cnt, single, f):
    """f_b = -sum_i m_i M_b (q_i + q_b) g_bi on wall rows b: the exact negative of the wall
    terms of m_i a_i(q) (fluid rows left alone).  ``single``: the fluid's terms used
    mg_ib = M_b g_ib rounded to float32 (:func:`pack_pairs`), so the same rounding is
    applied here (g_ib = -g_bi exactly) and the balance stays exact."""
    dim = grad.shape[1]
    for blk in prange(NBLOCKS):  # blocks of equal list length (see _block)
        lo, hi = _block(blk, offsets)
        for b in range(lo, hi):
            if kind[b] != WALL:
                continue
            o = offsets[b]
            for c in range(dim):
                f[b, c] = 0.0
            for k in range(cnt[b]):
                i = nbj[o + k]
                s = m[i] * (q[i] + q[b])
                for c in range(dim):
                    mg = M[b] * -grad[o + k, c]  # M_b g_ib
                    if single:
                        mg = np.float64(np.float32(mg))
                    f[b, c] += s * mg


def lattice_sum(kernel_code: int, dim: int, R_over_dx: float) -> float:
    """S = sum_k dx^d W(|k| dx) over a Cartesian lattice of spacing dx (k in Z^d): the
    discrete kernel sum of a particle inside a lattice (1.0051 in 2D, 1.0031 in 3D for the
    Wendland C2 kernel at R = 3 dx)."""
    m = int(np.ceil(R_over_dx))
    axis = np.arange(-m, m + 1, dtype=float)
    k = np.stack(np.meshgrid(*([axis] * dim), indexing="ij"), -1).reshape(-1, dim)
    q = np.sqrt((k * k).sum(axis=1)) / R_over_dx
    sigma = kernel_sigma(kernel_code, dim, R_over_dx)  # R in units of dx
    return float(sigma * sum(kernel_f(float(v), kernel_code) for v in q))


#: storage of the packed pairs' M_j g_ij that every solver iteration reads
#: (:func:`pack_pairs`): single precision halves the memory the two gathers of an
#: iteration stream (measured at 59,319 fluid particles, 2 threads: density rate 10.0 ->
#: 4.2 ms, pressure acceleration 12.4 -> 3.6 ms, against 7.0 / 5.2 ms packed in double);
#: the operator then differs from the double one by ~1e-7 relative, far below the solves'
#: tolerances (0.01-0.1 %), and :func:`wall_reaction` rounds alike, so momentum between
#: fluid and walls still balances to round-off.  SPlisHSPlasH computes in single
#: precision throughout.
PAIR_DTYPE = np.float32
SINGLE_PAIRS = PAIR_DTYPE == np.float32

#: the relaxed Jacobi's omega lambda_max(D^-1 A) is kept at or below this (2 diverges)
OMEGA_LAMBDA = 1.7


def jacobi_lambda(kernel_code: int, dim: int, R_over_dx: float, nk: int = 24) -> float:
    """lambda_max of D^-1 A on a periodic lattice of spacing dx, from the operator's Fourier
    symbol: with S(k) = sum_j sin(k . r_j) g_j over the lattice neighbours r_j,
    lambda(k) = |S(k)|^2 / sum_j |g_j|^2 (3.33 in 2D, 6.25 in 3D for the Wendland C2
    kernel at R = 3 dx; a power iteration on the particle operator gives 3.30 and 6.16)."""
    m = int(np.ceil(R_over_dx))
    axis = np.arange(-m, m + 1, dtype=float)
    r = np.stack(np.meshgrid(*([axis] * dim), indexing="ij"), -1).reshape(-1, dim)
    d = np.sqrt((r * r).sum(axis=1))
    keep = (d > 0) & (d < R_over_dx)
    r, d = r[keep], d[keep]
    F = -np.array([kernel_dfdq(float(q), kernel_code) for q in d / R_over_dx]) / d
    g = F[:, None] * r
    k1 = np.linspace(0.0, np.pi, nk)
    K = np.stack(np.meshgrid(*([k1] * dim), indexing="ij"), -1).reshape(-1, dim)
    S = np.sin(K @ r.T) @ g
    return float((S * S).sum(axis=1).max() / (g * g).sum())


def relaxation(state, omega: float) -> float:
    """``omega`` capped at OMEGA_LAMBDA / lambda_max (:func:`jacobi_lambda` of the run's
    kernel and spacing, set by :func:`prepare`): 0.5 stays 0.5 in 2D, 0.27 in 3D."""
    return min(omega, OMEGA_LAMBDA / state.jacobi_lambda)


class IdStore:
    """Per-particle values kept between steps under the particles' stable ``id`` (a cell
    sort or appended particles do not disturb them): the solvers' warm starts."""

    def __init__(self):
        self.values = np.zeros(0)

    def get(self, ids: np.ndarray) -> np.ndarray:
        out = np.zeros(ids.shape[0])
        ok = ids < self.values.shape[0]
        out[ok] = self.values[ids[ok]]
        return out

    def put(self, ids: np.ndarray, values: np.ndarray) -> None:
        top = int(ids.max()) + 1 if ids.size else 0
        if self.values.shape[0] < top:
            self.values = np.concatenate([self.values, np.zeros(top - self.values.shape[0])])
        self.values[ids] = values


@dataclass
class Work:
    """Work arrays of one step (recomputed every step; sized to the particle set and the
    list, reallocated when they grow)."""

    n: int = 0
    pairs: int = 0
    dim: int = 0
    arrays: dict = field(default_factory=dict)

    def fit(self, n: int, pairs: int, dim: int) -> None:
        a = self.arrays
        if pairs > self.pairs or dim != self.dim:
            self.pairs = pairs + pairs // 4
            a["nbj"] = np.zeros(self.pairs, dtype=np.int64)
            a["grad"] = np.zeros((self.pairs, dim))
            a["wgt"] = np.zeros(self.pairs)
        if n != self.n or dim != self.dim:
            a["cnt"] = np.zeros(n, dtype=np.int64)
            for k in ("rho", "M", "A", "rate", "q", "Q", "Qv", "aux", "qh"):
                a[k] = np.zeros(n)
            for k in ("u", "acc_p", "f"):
                a[k] = np.zeros((n, dim))
        if n != self.n or dim != self.dim or "off_c" not in a:
            a["off_c"] = np.zeros(n + 1, dtype=np.int64)
        self.n, self.dim = n, dim

    def fit_packed(self, pairs: int) -> None:
        """Room for ``pairs`` packed fluid-row pairs (:func:`pack_pairs`)."""
        a = self.arrays
        if "nb_c" not in a or a["nb_c"].shape[0] < pairs or a["mg_c"].shape[1] != self.dim:
            size = pairs + pairs // 4
            a["nb_c"] = np.zeros(size, dtype=np.int32)
            a["mg_c"] = np.zeros((size, self.dim), dtype=PAIR_DTYPE)

    def __getattr__(self, name):
        try:
            return self.__dict__["arrays"][name]
        except KeyError:
            raise AttributeError(name) from None


@dataclass
class SolveLog:
    """Per-step record of a projection solve: iterations of each solve, the final
    predicted density error (the solver's measure, a fraction of rho0), the density error
    of the summation density at the step's start (the error the last step left), and the
    steps that stopped at the iteration limit."""

    iterations: list = field(default_factory=list)
    divergence_iterations: list = field(default_factory=list)
    density_error: list = field(default_factory=list)
    divergence_error: list = field(default_factory=list)
    start_density_error: list = field(default_factory=list)
    not_converged: int = 0

    def summary(self, tolerance: float) -> dict:
        """JSON figures for ``summary.json`` (errors in per cent of rho0)."""

        def stats(v, pct=False):
            if not v:
                return None
            a = np.asarray(v, float) * (100.0 if pct else 1.0)
            return {"mean": float(a.mean()), "max": float(a.max()), "last": float(a[-1])}

        return {
            "steps": len(self.iterations),
            "tolerance_percent": tolerance,
            "iterations": stats(self.iterations),
            "divergence_iterations": stats(self.divergence_iterations),
            "density_error_percent": stats(self.density_error, True),
            "divergence_error_percent": stats(self.divergence_error, True),
            "start_density_error_percent": stats(self.start_density_error, True),
            "steps_not_converged": self.not_converged,
        }


@dataclass
class ProjectionState:
    """A projection method's state between steps (kept by the solver): warm starts under
    the particles' ids, the work arrays, the per-step log and the pressure reaction on the
    walls (under ids, added to ``f_fluid`` after the evaluation at x^{n+1})."""

    tolerance: float = 0.1
    lattice_sum: float | None = None
    jacobi_lambda: float | None = None
    dt_prev: float | None = None
    warm: IdStore = field(default_factory=IdStore)
    warm_v: IdStore = field(default_factory=IdStore)  # DFSPH: dt kappa^v of the last step
    work: Work = field(default_factory=Work)
    log: SolveLog = field(default_factory=SolveLog)
    reaction: np.ndarray | None = None
    reaction_ids: np.ndarray | None = None

    def to_dict(self) -> dict:
        """The per-step log's summary (``pressure_solve`` of the fluid's diagnostics)."""
        return self.log.summary(self.tolerance)


def prepare(solver, state: ProjectionState) -> Work:
    """Pairs, g_ij, summation density and A_i at the current positions; writes ``rho`` of
    the fluid particles (max(rho_i, rho0)) and logs the start density error."""
    t0 = time.perf_counter()
    p, nl, rho0 = solver.p, solver.nbrs, solver.params.rho0
    w = state.work
    w.fit(p.n, nl.indices.shape[0], p.dim)
    fl = p.kind == FLUID
    if state.lattice_sum is None:
        dx = (float(p.m[fl].mean()) / rho0) ** (1.0 / p.dim) if fl.any() else solver.R / 3
        state.lattice_sum = lattice_sum(solver.kernel_code, p.dim, solver.R / dx)
        state.jacobi_lambda = jacobi_lambda(solver.kernel_code, p.dim, solver.R / dx)
    M = w.M
    M[:] = 0.0
    M[fl] = p.m[fl] / state.lattice_sum
    wall = p.kind == WALL
    M[wall] = rho0 * p.vol[wall] / state.lattice_sum
    pairs_and_density(p.x, p.kind, M, nl.offsets, nl.indices, solver.R, solver.sigma,
                      solver.kernel_code, solver.period, w.nbj, w.grad, w.wgt, w.cnt, w.rho)
    w.off_c[0] = 0
    np.cumsum(np.where(fl, w.cnt, 0), out=w.off_c[1:])
    w.fit_packed(int(w.off_c[-1]))
    pack_pairs(M, p.kind, nl.offsets, w.nbj, w.grad, w.cnt, w.off_c, w.nb_c, w.mg_c, w.A)
    state.log.start_density_error.append(mean_excess(w.rho, p.kind, rho0))
    p.rho[fl] = np.maximum(w.rho[fl], rho0)
    solver.wall["pressure_pairs"] = solver.wall.get("pressure_pairs", 0.0) + (
        time.perf_counter() - t0)
    return w


def timed_solve(solve, solver, dt: float, state):
    """``solve(solver, dt, state)``, its wall seconds added to ``solver.wall`` as
    ``pressure_solve`` less the pair set-up's (:func:`prepare`, its own
    ``pressure_pairs``), so that the timers add up to the step."""
    t0 = time.perf_counter()
    pairs0 = solver.wall.get("pressure_pairs", 0.0)
    st = solve(solver, dt, state)
    inner = solver.wall.get("pressure_pairs", 0.0) - pairs0
    solver.wall["pressure_solve"] = solver.wall.get("pressure_solve", 0.0) + (
        time.perf_counter() - t0 - inner)
    return st


def solve_pairs(solver, w: Work) -> tuple:
    """The arguments (kind, off_c, nb_c, mg_c) of :func:`density_rate` and
    :func:`pressure_acceleration` for the step prepared in ``w``."""
    return solver.p.kind, w.off_c, w.nb_c, w.mg_c


def carried_weight(state: ProjectionState, dt: float, solver) -> float:
    """beta = min(1, (dt / dt_prev)^2): the share of the density error rho_i - rho0 left by
    the last step that a step of length dt removes (the solves' source is then
    beta (rho_i - rho0) + dt D_i).  A step shortened to reach an output time or t_end would
    otherwise remove all of it in a fraction of the time, with (dt_prev / dt)^2 times the
    pressure (measured: a 4x shorter step at the 2D dam break gave MPa pressures and
    70 m/s); with beta the pressure stays that of a full step.  The first step has no
    dt_prev: it is measured against the ``solver``'s own stable step (``stable_dt``), so the
    set-up's density error is removed at the pace of a full step too (measured: a first step
    of 1e-6 s at PySPH's 2D dam break, dx 0.03, threw particles at 165 m/s and held the
    CFL step at 1/50 of its size for the rest of the run).  Records dt."""
    ref = state.dt_prev if state.dt_prev is not None else float(solver.stable_dt()[0])
    beta = min(1.0, (dt / ref) ** 2)
    state.dt_prev = dt
    return beta


def add_wall_hydrostatic(solver, w: Work, dt: float, g: np.ndarray) -> None:
    """v* += dt a_i(qh), qh of :func:`wall_hydrostatic_q` on the walls and 0 on the fluid:
    the p-independent part of the wall pressure term, a known force of the step (kept in
    ``w.qh`` for the wall reaction)."""
    p, nl = solver.p, solver.nbrs
    wall_hydrostatic_q(p.x, w.rho, p.acc, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt, g,
                       solver.period, solver.params.rho0, w.qh)
    pressure_acceleration(w.qh, *solve_pairs(solver, w), dt, p.v, True)


def finish(solver, state: ProjectionState, q: np.ndarray) -> None:
    """After a solve with the step's total q = p / rho^2 (fluid rows): the wall particles'
    q_b (extrapolated plus the hydrostatic ``w.qh``), their ``p`` = rho0^2 q_b and the
    pressure reaction on them, kept under their ids for :func:`add_reaction`."""
    p, nl, w = solver.p, solver.nbrs, state.work
    wall_extrapolate(q, p.kind, nl.offsets, w.nbj, w.wgt, w.cnt)
    wall = p.kind == WALL
    q[wall] += w.qh[wall]
    p.p[wall] = solver.params.rho0 ** 2 * q[wall]  # the pressure the solve gave the walls
    f = w.f
    wall_reaction(q, p.m, w.M, p.kind, nl.offsets, w.nbj, w.grad, w.cnt, SINGLE_PAIRS, f)
    keep = wall & (w.cnt > 0)  # the other wall rows have f = 0
    state.reaction_ids = p.id[keep].copy()
    state.reaction = f[keep].copy()


def add_reaction(solver, state: ProjectionState | None) -> None:
    """Add the last solve's pressure reaction to ``f_fluid`` of the wall particles (the
    evaluation at x^{n+1} wrote their viscous reaction only); matched by particle id."""
    if state is None or state.reaction is None or state.reaction.shape[0] == 0:
        return
    p = solver.p
    row = np.full(int(p.id.max()) + 1, -1, dtype=np.int64)  # id -> row of this step
    row[p.id] = np.arange(p.n)
    ids = state.reaction_ids
    rows = np.where(ids < row.shape[0], row[np.minimum(ids, row.shape[0] - 1)], -1)
    hit = rows >= 0
    hit[hit] = p.kind[rows[hit]] == WALL
    p.f_fluid[rows[hit]] += state.reaction[hit]
