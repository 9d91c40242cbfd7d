"""Time integration of the conduction system dT_a/dt = A T_a + f (eq. 2 of
:mod:`sphfem.heat.system`).

* :class:`ExplicitStepper` -- Heun's method (explicit trapezoid, second order).  Its
  stability interval on the negative real axis is the same as forward Euler's,
  dt |lambda|_max <= 2, so the step of :meth:`HeatSystem.stable_dt` applies.
* :class:`ThetaStepper` -- (I - theta dt A) T^{n+1} = (I + (1 - theta) dt A) T^n + dt f;
  theta = 1 backward Euler (L-stable), theta = 1/2 Crank-Nicolson (A-stable, second
  order).  The matrix is assembled once from the pair conductances and factorised once
  with SuperLU (``scipy.sparse.linalg.splu``) while the geometry and dt stay fixed.
  Crank-Nicolson does not damp stiff modes (amplification -> -1), so rough initial data
  (a wall suddenly heated) would ring; ``startup`` Crank-Nicolson steps are replaced by two
  backward-Euler half steps each (Rannacher 1984 time stepping).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu


class ExplicitStepper:
    """Heun steps of a :class:`~sphfem.heat.system.HeatSystem` (ghosts refreshed per stage)."""

    def __init__(self, system):
        self.system = system

    def step(self, T: np.ndarray, dt: float) -> float:
        """Advance the full temperature array ``T`` in place by ``dt``; return the heat the
        boundaries supplied during the step [J] (for :class:`~sphfem.heat.energy.EnergyLedger`).
        """
        s = self.system
        s.apply_ghosts(T)
        k1 = s.rate(T)
        q1 = s.boundary_heat_rate(T)
        T1 = T + dt * k1
        s.apply_ghosts(T1)
        k2 = s.rate(T1)
        q2 = s.boundary_heat_rate(T1)
        T += 0.5 * dt * (k1 + k2)
        s.apply_ghosts(T)
        return 0.5 * dt * (q1 + q2)


class ThetaStepper:
    """Theta-method steps with one LU factorisation per (theta, dt)."""

    def __init__(self, system, theta: float = 1.0, startup: int = 2, T_held=None):
        if not 0.5 <= theta <= 1.0:
            raise ValueError(f"theta must lie in [0.5, 1] for unconditional stability, got {theta}")
        self.system = system
        self.theta = theta
        self.startup = startup if theta < 1.0 else 0
        self.A, self.f = system.matrix(T_held)
        self._lu = {}
        self.steps = 0
        self.factorisations = 0

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
