"""Time integration of the conduction system dT_a/dt = A T_a + f (eq. 2 of
:mod:`sphfem.heat.system`).

* :class:`ExplicitStepper` -- Heun's method (explicit trapezoid, second order).  Its
  stability interval on the negative real axis is the same as forward Euler's,
  dt |lambda|_max <= 2, so the step of :meth:`HeatSystem.stable_dt` applies.
* :class:`ThetaStepper` -- (I - theta dt A) T^{n+1} = (I + (1 - theta) dt A) T^n + dt f;
  theta = 1 backward Euler (L-stable), theta = 1/2 Crank-Nicolson (A-stable, second
  order).  The matrix is assembled once from the pair conductances and factorised once
  with SuperLU (``scipy.sparse.linalg.splu``) while the geometry and dt stay fixed; when
  another module moves the particles the conductances change every step, and the heat
  module then reassembles and refactorises every step (:meth:`ThetaStepper.refresh`).
  Crank-Nicolson does not damp stiff modes (amplification -> -1), so rough initial data
  (a wall suddenly heated) would ring; ``startup`` Crank-Nicolson steps are replaced by two
  backward-Euler half steps each (Rannacher 1984 time stepping).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit, prange
from scipy.sparse.linalg import splu

from sphfem.heat.ghosts import DIRICHLET, INSULATED


@njit(cache=True)
def apply_ghost_rules(T, gi, gt, gs, tw, ratio, antisymmetric):
    """T_g = T_w (hold) or T_w - r (T_s - T_w) (antisymmetric) for Dirichlet ghosts, T_g = T_s
    for insulated ones (s = source particle); see :mod:`sphfem.heat.ghosts`."""
    for q in range(gi.shape[0]):
        if gt[q] == DIRICHLET:
            if antisymmetric:
                T[gi[q]] = (1.0 + ratio[q]) * tw[q] - ratio[q] * T[gs[q]]
            else:
                T[gi[q]] = tw[q]
        elif gt[q] == INSULATED:
            T[gi[q]] = T[gs[q]]


@njit(cache=True, parallel=True)
def _stage_parallel(T, g, offsets, indices, inv_rc, active, vol, g_out, rate):
    """rate_i = sum_j g_ij (T_j - T_i) / (rho c)_i on active rows (0 elsewhere); returns
    the boundary heat rate sum_a V_a sum_j g_out_aj (T_j - T_a)."""
    n = offsets.shape[0] - 1
    qb = np.zeros(n)
    for i in prange(n):
        if not active[i]:
            rate[i] = 0.0
            continue
        acc = 0.0
        accb = 0.0
        ti = T[i]
        for jj in range(offsets[i], offsets[i + 1]):
            d = T[indices[jj]] - ti
            acc += g[jj] * d
            accb += g_out[jj] * d
        rate[i] = acc * inv_rc[i]
        qb[i] = vol[i] * accb
    return qb.sum()


@njit(cache=True)
def _stage_serial(T, g, offsets, indices, inv_rc, active, vol, g_out, rate):
    """Serial twin of :func:`_stage_parallel` (a separate function: numba's on-disk cache
    does not tell two compilations of one function with different ``parallel`` apart)."""
    n = offsets.shape[0] - 1
    qb = 0.0
    for i in range(n):
        if not active[i]:
            rate[i] = 0.0
            continue
        acc = 0.0
        accb = 0.0
        ti = T[i]
        for jj in range(offsets[i], offsets[i + 1]):
            d = T[indices[jj]] - ti
            acc += g[jj] * d
            accb += g_out[jj] * d
        rate[i] = acc * inv_rc[i]
        qb += vol[i] * accb
    return qb


#: below this many particles the threaded stage costs more than it saves (thread start-up
#: per call is tens of microseconds, far more on a loaded machine)
PARALLEL_MIN = 20000


@njit(cache=True)
def _stage(T, g, offsets, indices, inv_rc, active, vol, g_out, rate):
    if T.shape[0] >= PARALLEL_MIN:
        return _stage_parallel(T, g, offsets, indices, inv_rc, active, vol, g_out, rate)
    return _stage_serial(T, g, offsets, indices, inv_rc, active, vol, g_out, rate)


@njit(cache=True)
def heun_step(T, dt, g, offsets, indices, inv_rc, active, vol, g_out, gi, gt, gs, tw, ratio,
              antisymmetric):
    """One Heun step of eq. (2) in place, ghosts refreshed per stage; returns the boundary
    heat input dt/2 (q(T^n) + q(T*)) [J]."""
    n = T.shape[0]
    k1 = np.empty(n)
    k2 = np.empty(n)
    apply_ghost_rules(T, gi, gt, gs, tw, ratio, antisymmetric)
    q1 = _stage(T, g, offsets, indices, inv_rc, active, vol, g_out, k1)
    T1 = T + dt * k1
    apply_ghost_rules(T1, gi, gt, gs, tw, ratio, antisymmetric)
    q2 = _stage(T1, g, offsets, indices, inv_rc, active, vol, g_out, k2)
    for i in range(n):
        T[i] += 0.5 * dt * (k1[i] + k2[i])
    apply_ghost_rules(T, gi, gt, gs, tw, ratio, antisymmetric)
    return 0.5 * dt * (q1 + q2)


class ExplicitStepper:
    """Heun steps of a :class:`~sphfem.heat.system.HeatSystem` (ghosts refreshed per stage)."""

    def __init__(self, system):
        self.system = system

    def step(self, T: np.ndarray, dt: float) -> float:
        """Advance the full temperature array ``T`` in place by ``dt``; return the heat the
        boundaries supplied during the step [J] (for :class:`~sphfem.heat.energy.EnergyLedger`).
        """
        s = self.system
        return heun_step(T, dt, s.g, s.offsets, s.indices, s.inv_rc, s.active, s.vol,
                         s.g_outside, s.ghost_index, s.ghost_type, s.ghost_source,
                         s.ghost_t_wall, s.ghost_ratio, s.dirichlet_mode == "antisymmetric")


class ThetaStepper:
    """Theta-method steps with one LU factorisation per (theta, dt)."""

    def __init__(self, system, theta: float = 1.0, startup: int = 1, T_held=None):
        if not 0.5 <= theta <= 1.0:
            raise ValueError(f"theta must lie in [0.5, 1] for unconditional stability, got {theta}")
        self.system = system
        self.theta = theta
        self.startup = startup if theta < 1.0 else 0
        self._T_held = T_held
        self.A, self.f = system.matrix(T_held)
        self._lu = {}
        self.steps = 0
        self.factorisations = 0

    def refresh(self) -> None:
        """Reassemble A and f from the system's current conductances (after
        :meth:`HeatSystem.refresh`) and drop the factorisations: the next step factorises
        anew.  Moving particles change A every step, so a moving scene pays one sparse LU
        per step (``factorisations`` counts them)."""
        self.A, self.f = self.system.matrix(self._T_held)
        self._lu = {}

    def _factor(self, theta: float, dt: float):
        key = (theta, dt)
        if key not in self._lu:
            n = self.A.shape[0]
            M = (sp.identity(n, format="csc") - (theta * dt) * self.A).tocsc()
            if len(self._lu) >= 4:  # keep the start-up, main and a final short step
                self._lu.pop(next(iter(self._lu)))
            self._lu[key] = splu(M)
            self.factorisations += 1
        return self._lu[key]

    def _substep(self, T: np.ndarray, theta: float, dt: float) -> float:
        s = self.system
        a = s.active_index
        Ta = T[a]
        q_old = s.boundary_heat_rate(T) if theta < 1.0 else 0.0
        rhs = Ta + dt * self.f
        if theta < 1.0:
            rhs += ((1.0 - theta) * dt) * (self.A @ Ta)
        T[a] = self._factor(theta, dt).solve(rhs)
        s.apply_ghosts(T)
        return dt * (theta * s.boundary_heat_rate(T) + (1.0 - theta) * q_old)

    def step(self, T: np.ndarray, dt: float) -> float:
        """Advance the full temperature array ``T`` in place by ``dt`` (ghosts up to date
        on entry and exit); return the boundary heat input of the step [J]."""
        self.system.apply_ghosts(T)
        if self.steps < self.startup:
            heat = self._substep(T, 1.0, 0.5 * dt) + self._substep(T, 1.0, 0.5 * dt)
        else:
            heat = self._substep(T, self.theta, dt)
        self.steps += 1
        return heat
