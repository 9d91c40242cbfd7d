"""A cheap analytic stand-in for the extrusion simulation: the deposit follows the nozzle
like a damped spring (a second-order lag), which overshoots corners as whipping ink does.

The landing point x(t) of the ink leaving the nozzle at n(t) obeys

    x'' = omega^2 (n - x) - 2 zeta omega x',     omega = 1 / tau,

from x(0) = n(0), x'(0) = n'(0) (RK4, step tau / 40).  On a straight line at speed v it
trails the nozzle by 2 zeta v tau; with zeta < 1 it overshoots a corner and rings.  A row of
round(D / h) particles h apart, across the direction of travel, is laid every h of nozzle
travel (a bead about one nozzle diameter D wide), at height h / 2.

It is not physics: it gives the optimisation machinery (tests, throughput measurements) a
deposit with a known, smooth dependence on the toolpath.  ``cost_s`` adds a fixed sleep, so
a measurement can give every evaluation a known cost.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

__all__ = ["LagDeposit", "lag_deposit"]


@dataclass
class LagDeposit:
    """Same fields as :class:`sphfem.diw.extrusion.DepositResult`."""

    positions: np.ndarray
    h: float
    nozzle_diameter: float
    info: dict = field(default_factory=dict)
    vtu: str | None = None


def lag_deposit(path, nozzle_diameter: float, h: float, tau: float, zeta: float = 0.4,
                cost_s: float = 0.0) -> LagDeposit:
    """Deposit of the lag model for ``path`` (``position(t)``, ``velocity(t)``,
    ``duration``) with relaxation time ``tau`` [s] and damping ratio ``zeta``."""
    t0 = time.perf_counter()
    if cost_s > 0:
        time.sleep(cost_s)
    T = float(path.duration)
    dt = min(tau / 40.0, T / 400.0)
    nstep = int(np.ceil(T / dt))
    dt = T / nstep
    w2, c = 1.0 / tau**2, 2.0 * zeta / tau

    nz = np.asarray(path.position(np.linspace(0.0, T, 2 * nstep + 1)))  # at t = k dt / 2

    def rhs(j, x, v):
        return v, w2 * (nz[j] - x) - c * v

    x = nz[0].astype(float)
    v = np.asarray(path.velocity(0.5 * dt), dtype=float)
    xs, vs = [x], [v]
    for k in range(nstep):
        k1x, k1v = rhs(2 * k, x, v)
        k2x, k2v = rhs(2 * k + 1, x + dt / 2 * k1x, v + dt / 2 * k1v)
        k3x, k3v = rhs(2 * k + 1, x + dt / 2 * k2x, v + dt / 2 * k2v)
        k4x, k4v = rhs(2 * k + 2, x + dt * k3x, v + dt * k3v)
        x = x + dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
        v = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        xs.append(x)
        vs.append(v)
    ts = np.linspace(0.0, T, nstep + 1)
    xs, vs = np.array(xs), np.array(vs)
    # rows every h of nozzle travel
    length = T * np.mean(np.linalg.norm(path.velocity(ts[1:-1]), axis=1))
    tr = np.linspace(0.0, T, max(2, int(round(length / h)) + 1))
    cx = np.column_stack([np.interp(tr, ts, xs[:, 0]), np.interp(tr, ts, xs[:, 1])])
    cv = np.column_stack([np.interp(tr, ts, vs[:, 0]), np.interp(tr, ts, vs[:, 1])])
    speed = np.linalg.norm(cv, axis=1, keepdims=True)
    tang = np.where(speed > 0, cv / np.where(speed > 0, speed, 1.0), [1.0, 0.0])
    normal = np.column_stack([tang[:, 1], -tang[:, 0]])
    n_across = max(1, int(round(nozzle_diameter / h)))
    off = (np.arange(n_across) - 0.5 * (n_across - 1)) * h
    pts = (cx[:, None, :] + off[None, :, None] * normal[:, None, :]).reshape(-1, 2)
    pos = np.column_stack([pts, np.full(len(pts), 0.5 * h)])
    info = {"steps": nstep, "wall_s": time.perf_counter() - t0, "stopped_reason": None,
            "model": "lag", "tau": tau, "zeta": zeta}
    return LagDeposit(pos, h, nozzle_diameter, info)
