"""Axisymmetric SPH heat conduction in the (r, z) half-plane.

Equation: rho c dT/dt = (1/r) d/dr (k r dT/dr) + d/dz (k dT/dz)  =  (1/r) div_2(k r grad_2 T),
div_2 / grad_2 the planar (r, z) operators.  It is the planar heat equation with the
conductivity k r, divided by r, so the Cleary-Brookshaw pair form (Cleary & Monaghan
1999; :mod:`sphfem.heat.conduction`) with conductivity k_ij rbar_ij gives

    rho_i c_i r_i dT_i/dt = sum_j A_j k_ij (r_i + r~_j) F_ij (T_j - T_i)              (1)

with F_ij = -W'(d_ij) / d_ij >= 0 (planar 2D kernel), A_j the meridian area of j,
k_ij = 2 k_i k_j / (k_i + k_j) and rbar_ij = (r_i + r~_j) / 2 the arithmetic mean of the
pair's radii (``r~_j``: the radius that enters j's conductivity, see below).  The factor
(1/r) d/dr(r dT/dr) = T_rr + T_r / r of the cylindrical Laplacian is thus built in, not
added as a separately estimated T_r / r (Brookshaw 1985 form with an r-weighted
conductivity; cf. the 2D-mass formulation of Garcia-Senz & Relano-Pastor 2012, MNRAS 424,
1585).

Conservation: multiplying (1) by 2 pi A_i gives M_i c_i dT_i/dt = sum_j G_ij (T_j - T_i)
with M_i = 2 pi r_i rho_i A_i (the ring mass, :mod:`sphfem.axisymmetric`) and
G_ij = 2 pi A_i A_j k_ij (r_i + r~_j) F_ij, symmetric in i, j when both are real particles.
Ghosts (below) pair real particles with G_ij = G_ji, so the heat sum_i M_i c_i T_i is
conserved to round-off by free surfaces (no ghost), the axis and insulated mirror ghosts.

Ghosts: a ghost g at x_g carries T_g = alpha_g + beta_g T_{s(g)} (source s(g) a real
particle), area A_{s(g)}, conductivity k_{s(g)} and radius r~_g:

* the axis (r = 0): images (-r, z) of particles with r < R (``beta = 1``, ``r~ = r_s``),
  so T is continued evenly across the axis (:func:`sphfem.axisymmetric.axis_mirrors`);
* an insulated plane: the mirror image of s across it (``beta = 1``, ``r~ = r_s``): the
  pair (i, image of j) has the same distance and weight as (j, image of i), G symmetric;
* a Dirichlet plane at T_w: the antisymmetric image (``alpha = 2 T_w``, ``beta = -1``,
  ``r~ = r_g``, the ghost's own radius: the conductivity continues smoothly).

Time stepping: Heun (explicit trapezoid, second order) at the Gershgorin limit
dt <= cfl * 2 / max_i sum_j |a_ij| (a_ij the coefficients of dT_i/dt, ghosts through
their sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.axisymmetric import axis_mirrors
from sphfem.neighbors import build_neighbor_list, min_image
from sphfem.particles import FLUID, GHOST


@dataclass
class Ghosts:
    """Ghost particles of the axisymmetric heat equation (module docstring):
    positions ``x`` (m, 2), source ``src`` (m,), ``alpha``, ``beta`` (T_g = alpha + beta
    T_src) and the radius ``r_cond`` entering the pair conductance."""

    x: np.ndarray
    src: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    r_cond: np.ndarray

    @classmethod
    def empty(cls) -> Ghosts:
        z = np.zeros(0)
        return cls(np.zeros((0, 2)), np.zeros(0, np.int64), z, z.copy(), z.copy())

    def __add__(self, other: Ghosts) -> Ghosts:
        return Ghosts(np.vstack([self.x, other.x]), np.concatenate([self.src, other.src]),
                      np.concatenate([self.alpha, other.alpha]),
                      np.concatenate([self.beta, other.beta]),
                      np.concatenate([self.r_cond, other.r_cond]))

    @property
    def n(self) -> int:
        return self.src.shape[0]


def axis_ghosts(x, R: float) -> Ghosts:
    """Even images across the axis r = 0 of the particles with r < R."""
    xm, src = axis_mirrors(x, R)
    m = src.shape[0]
    return Ghosts(xm, src, np.zeros(m), np.ones(m), np.asarray(x, float)[src, 0].copy())


def plane_ghosts(x, R: float, axis: int, position: float, side: int, bc: str,
                 temperature: float = 0.0, tol: float = 1e-9) -> Ghosts:
    """Images of the particles within R of the plane ``x[axis] = position`` (outward normal
    ``side`` e_axis): ``bc = "insulated"`` (even image) or ``"dirichlet"`` (antisymmetric
    image about ``temperature``).  A radial plane (axis 0) bounds a cylinder r <= position."""
    x = np.asarray(x, float)
    dist = side * (position - x[:, axis])  # depth of the source inside the body
    src = np.flatnonzero((dist > tol * R) & (dist < R))
    xg = x[src].copy()
    xg[:, axis] = position + side * dist[src]
    m = src.shape[0]
    if bc == "insulated":
        return Ghosts(xg, src, np.zeros(m), np.ones(m), x[src, 0].copy())
    if bc == "dirichlet":
        return Ghosts(xg, src, np.full(m, 2.0 * temperature), -np.ones(m), xg[:, 0].copy())
    raise ValueError(f"unknown boundary condition {bc!r}; expected 'insulated' or 'dirichlet'")


@njit(cache=True, parallel=True)
def second_moments(x, A, n, offsets, indices, R, sigma, kernel_code, period, out):
    """mom_i = (1/2) sum_j A_j F_ij d_ij^2 (half the trace of the planar moment matrix
    sum_j A_j F_ij r_ij r_ij, which is the identity in the continuum) for the real rows i < n
    (``A`` filled for the ghosts)."""
    R2 = R * R
    for i in prange(n):
        s = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            d0 = x[j, 0] - x[i, 0]
            d1 = min_image(x[j, 1] - x[i, 1], period[1])
            d2 = d0 * d0 + d1 * d1
            if d2 >= R2 or d2 == 0.0:
                continue
            d = math.sqrt(d2)
            s += A[j] * (-sigma * kernels.kernel_dfdq(d / R, kernel_code) / R) * d
        out[i] = 0.5 * s


@njit(cache=True, inline="always")
def pair_conductance(x, A, k, r_cond, mom, i, j, ri, ki, R, R2, sigma, kernel_code, period):
    """The weight g_ij of pair (i, j) in eq. (1), A_j k_ij (r_i + r_cond,j) F_ij 2 / (mom_i +
    mom_j) with the harmonic k_ij = 2 k_i k_j / (k_i + k_j), >= 0; -1 for no pair (outside
    the support, coincident, or k_i + k_j <= 0) (``ri`` = x[i, 0], ``ki`` = k[i], R2 = R^2)."""
    d0 = x[j, 0] - ri
    d1 = min_image(x[j, 1] - x[i, 1], period[1])
    d2 = d0 * d0 + d1 * d1
    if d2 >= R2 or d2 == 0.0:
        return -1.0
    d = math.sqrt(d2)
    F = -sigma * kernels.kernel_dfdq(d / R, kernel_code) / (R * d)
    kj = k[j]
    ks = ki + kj
    if ks <= 0.0:
        return -1.0
    return A[j] * (2.0 * ki * kj / ks) * (ri + r_cond[j]) * F * 2.0 / (mom[i] + mom[j])


@njit(cache=True, parallel=True)
def heat_rates(x, T, A, k, r_cond, inv_rrc, mom, n, offsets, indices, R, sigma, kernel_code,
               period, out):
    """dT_i/dt of eq. (1) for the real rows i < n (arrays over real + ghost particles:
    ``T``, ``A``, ``k``, ``r_cond`` and ``mom`` already filled for the ghosts; ``inv_rrc[i] =
    1 / (r_i rho_i c_i)``; ``mom``: the pair weight is divided by (mom_i + mom_j) / 2, all
    ones for the plain form).  Returns max_i sum_j |a_ij| (Gershgorin bound)."""
    R2 = R * R
    rows = np.zeros(n)
    for i in prange(n):
        ri = x[i, 0]
        ki = k[i]
        s = 0.0
        w = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            g = pair_conductance(x, A, k, r_cond, mom, i, j, ri, ki, R, R2, sigma,
                                 kernel_code, period)
            if g < 0.0:
                continue
            s += g * (T[j] - T[i])
            w += g
        out[i] = s * inv_rrc[i]
        rows[i] = 2.0 * w * inv_rrc[i]
    best = 0.0
    for i in range(n):
        best = max(best, rows[i])
    return best


@njit(cache=True)
def ring_system(x, m, rho, c, k, real, src, xa, A, ka, rc, inv):
    """The per-row arrays of the ring heat system of
    :class:`sphfem.axisymmetric_scene.AxisymmetricHeatModule` from the particle set's
    positions ``x``, ring masses ``m``, ``rho``, ``c`` and ``k``: the rows ``real`` then
    their axis ghosts (sources ``src``, positions in ``real`` order): positions ``xa`` (ghost
    r negated), meridian areas A = m / (2 pi r rho) (:func:`sphfem.axisymmetric.planar_area`),
    conductivities ``ka``, conductance radii ``rc`` (a ghost: its source's r) and, for the
    real rows, ``inv`` = 1 / (r rho c)."""
    n = real.shape[0]
    two_pi = 2.0 * math.pi
    for q in range(n):
        i = real[q]
        r = x[i, 0]
        xa[q, 0] = r
        xa[q, 1] = x[i, 1]
        A[q] = m[i] / (two_pi * r * rho[i])
        ka[q] = k[i]
        rc[q] = r
        inv[q] = 1.0 / (r * rho[i] * c[i])
    for g in range(src.shape[0]):
        s = src[g]
        xa[n + g, 0] = -xa[s, 0]
        xa[n + g, 1] = xa[s, 1]
        A[n + g] = A[s]
        ka[n + g] = ka[s]
        rc[n + g] = xa[s, 0]


@njit(cache=True)
def ring_temperatures(T, real, src, rate, dt, Ta):
    """Ta over the rows of :func:`ring_system`: T[real] (+ dt ``rate`` when dt != 0, a Heun
    predictor), the ghosts their sources' values."""
    n = real.shape[0]
    for q in range(n):
        Ta[q] = T[real[q]] + dt * rate[q] if dt != 0.0 else T[real[q]]
    for g in range(src.shape[0]):
        Ta[n + g] = Ta[src[g]]


@njit(cache=True, parallel=True)
def heat_conductances(x, A, k, r_cond, inv_rrc, mom, n, offsets, indices, R, sigma,
                      kernel_code, period, count, pair_j, pair_g):
    """The pair weights of :func:`heat_rates` for fixed positions, once: for each real row i
    the pairs j within R with k_i + k_j > 0, in list order, packed at the start of the row's
    slots ``offsets[i]:`` of ``pair_j`` (j) and ``pair_g`` (g_ij = A_j k_ij (r_i + r~_j) F_ij
    2 / (mom_i + mom_j), the same expression), ``count[i]`` of them.  Returns the Gershgorin
    bound of :func:`heat_rates`.  Every rate at these positions is then
    :func:`heat_rates_packed` (a Heun step's two stages: the same rates to the bit)."""
    R2 = R * R
    rows = np.zeros(n)
    for i in prange(n):
        ri = x[i, 0]
        ki = k[i]
        w = 0.0
        pos = offsets[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            g = pair_conductance(x, A, k, r_cond, mom, i, j, ri, ki, R, R2, sigma,
                                 kernel_code, period)
            if g < 0.0:
                continue
            pair_j[pos] = j
            pair_g[pos] = g
            pos += 1
            w += g
        count[i] = pos - offsets[i]
        rows[i] = 2.0 * w * inv_rrc[i]
    best = 0.0
    for i in range(n):
        best = max(best, rows[i])
    return best


@njit(cache=True, parallel=True)
def heat_rates_packed(T, inv_rrc, n, offsets, count, pair_j, pair_g, out):
    """dT_i/dt of eq. (1) for the real rows from the pair weights of
    :func:`heat_conductances` (``T`` over real + ghost rows)."""
    for i in prange(n):
        Ti = T[i]
        s = 0.0
        for jj in range(offsets[i], offsets[i] + count[i]):
            s += pair_g[jj] * (T[pair_j[jj]] - Ti)
        out[i] = s * inv_rrc[i]


class AxisymmetricHeat:
    """Heat conduction on fixed particles in the (r, z) half-plane (module docstring).

    ``x`` (n, 2) positions (r > 0), ``area`` meridian areas [m^2], ``rho`` [kg/m^3],
    ``c`` [J/(kg K)], ``k`` [W/(m K)] (scalars or per particle), ``T`` [K], support radius
    ``R``; ``ghosts`` for the boundaries other than the axis (whose mirrors are added
    here); ``period`` (2,) periodic lengths (0: open; only z may be periodic).

    ``normalise``: divide each pair weight by (mom_i + mom_j) / 2, mom the half trace of the
    particles' planar moment matrices (:func:`second_moments`, ghosts included).  On a
    lattice the plain Brookshaw sum reproduces the Laplacian only up to a constant factor
    (0.9974 for Wendland C2 at R = 3 dx: a zeroth-order error that stops the convergence at
    ~0.3 % of the decay); the normalised form removes it and stays pairwise symmetric (so
    conservative).  At a free surface without ghosts mom_i ~ 1/2, which raises the
    conductance of the surface pairs: use it where the boundaries carry ghosts.
    """

    def __init__(self, x, area, rho, c, k, T, R, ghosts: Ghosts | None = None,
                 period=(0.0, 0.0), kernel: str = "wendland_c2", cfl: float = 0.9,
                 normalise: bool = False):
        self.x = np.ascontiguousarray(x, dtype=np.float64)
        n = self.n = self.x.shape[0]
        if np.any(self.x[:, 0] <= 0.0):
            raise ValueError("axisymmetric heat particles need r > 0")
        self.period = np.asarray(period, dtype=np.float64)
        if self.period[0] != 0.0:
            raise ValueError("the radial axis cannot be periodic")
        self.R = float(R)
        self.kcode = kernels.kernel_code(kernel)
        self.sigma = kernels.kernel_sigma(self.kcode, 2, self.R)
        full = lambda a: np.broadcast_to(np.asarray(a, float), (n,)).copy()  # noqa: E731
        self.A, self.rho, self.c, self.k = full(area), full(rho), full(c), full(k)
        self.T = full(T)
        self.ghosts = axis_ghosts(self.x, self.R) + (ghosts or Ghosts.empty())
        self.cfl = cfl
        self.t = 0.0
        g = self.ghosts
        self._xa = np.ascontiguousarray(np.vstack([self.x, g.x]))
        self._Aa = np.concatenate([self.A, self.A[g.src]])
        self._ka = np.concatenate([self.k, self.k[g.src]])
        self._rca = np.concatenate([self.x[:, 0], g.r_cond])
        self._inv_rrc = 1.0 / (self.x[:, 0] * self.rho * self.c)
        kind = np.concatenate([np.full(n, FLUID, np.int8), np.full(g.n, GHOST, np.int8)])
        keep = [0] * (GHOST + 1)
        keep[FLUID] = (1 << FLUID) | (1 << GHOST)  # real rows see everything, ghost rows nothing
        lo = self._xa.min(axis=0) - self.R
        hi = self._xa.max(axis=0) + self.R
        if self.period[1] > 0:
            hi[1] = lo[1] + self.period[1]
        self.nbrs = build_neighbor_list(self._xa, self.R, lo, hi, self.period, kind=kind,
                                        keep=tuple(keep))
        self._mom = np.ones(n + g.n)
        if normalise:
            mom = np.zeros(n)
            second_moments(self._xa, self._Aa, n, self.nbrs.offsets, self.nbrs.indices, self.R,
                           self.sigma, self.kcode, self.period, mom)
            self._mom = np.concatenate([mom, mom[g.src]])
        self._rate = np.zeros(n)
        self._Ta = np.zeros(n + g.n)
        self.rate(self.T)

    def _fill(self, T) -> np.ndarray:
        g = self.ghosts
        self._Ta[: self.n] = T
        self._Ta[self.n:] = g.alpha + g.beta * T[g.src]
        return self._Ta

    def rate(self, T) -> np.ndarray:
        """dT/dt [K/s] of every real particle for temperatures ``T`` (eq. 1)."""
        nl = self.nbrs
        self.gershgorin = heat_rates(self._xa, self._fill(T), self._Aa, self._ka, self._rca,
                                     self._inv_rrc, self._mom, self.n, nl.offsets, nl.indices,
                                     self.R, self.sigma, self.kcode, self.period, self._rate)
        return self._rate.copy()

    def stable_dt(self) -> float:
        """cfl * 2 / max_i sum_j |a_ij| [s] (Heun's real stability interval is [-2, 0])."""
        return self.cfl * 2.0 / self.gershgorin

    def step(self, dt: float) -> None:
        """One Heun step."""
        k1 = self.rate(self.T)
        k2 = self.rate(self.T + dt * k1)
        self.T = self.T + 0.5 * dt * (k1 + k2)
        self.t += dt

    def run(self, t_end: float) -> int:
        """Step to ``t_end`` with the stable step; returns the number of steps."""
        steps = int(math.ceil((t_end - self.t) / self.stable_dt() * (1 - 1e-12)))
        dt = (t_end - self.t) / max(steps, 1)
        for _ in range(steps):
            self.step(dt)
        return steps

    def ring_masses(self) -> np.ndarray:
        """M_i = 2 pi r_i rho_i A_i [kg]."""
        return 2.0 * math.pi * self.x[:, 0] * self.rho * self.A

    def energy(self) -> float:
        """sum_i M_i c_i T_i [J] (ring masses: the heat of the 3D body)."""
        return float(np.sum(self.ring_masses() * self.c * self.T))
