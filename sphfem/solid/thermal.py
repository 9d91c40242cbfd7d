"""Heat conduction in a TL-SPH solid through :mod:`sphfem.heat` (ghosts for thermal BCs).

The conduction problem is solved on the *reference* positions (total-Lagrangian: the
particles' reference neighbourhoods do not change; the conductances are those of the
undeformed body, valid for the small strains of thermo-elastic solids) with
:func:`sphfem.heat.problem.build_problem`: ghost particles of algorithm 2.5 carry the
``dirichlet`` (prescribed temperature) and ``insulated`` faces, ``free`` faces exchange no
heat.  Particles left out of the heat problem (``active=False``, e.g. the clamp layer
below a supported face) copy the temperature of the nearest heat particle.

The heat equation is advanced first in each step and the new temperatures written to
``body.theta`` (one-way coupling: no thermo-elastic dissipation term).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from sphfem.heat.problem import build_problem
from sphfem.heat.stepping import ExplicitStepper, ThetaStepper


class SolidHeat:
    """Conduction on the particles of ``body`` with specific heat ``c`` [J/(kg K)] and
    conductivity ``k`` [W/(m K)] (scalars or per particle), faces ``boundaries``
    (:class:`sphfem.heat.ghosts.Face` or boxes, see :func:`build_problem`), initial
    temperature ``T_init`` (default ``body.theta``).  ``implicit`` uses the theta method
    (``theta`` 0.5: Crank-Nicolson with a Rannacher start-up) at the mechanical step;
    otherwise explicit Heun with sub-steps at the thermal limit."""

    def __init__(self, body, c, k, boundaries=(), active=None, T_init=None, *,
                 laplacian: str = "cleary", implicit: bool = False, theta: float = 0.5,
                 origin=None):
        n = body.n
        self.body = body
        act = np.ones(n, bool) if active is None else np.asarray(active, bool)
        self.active_index = np.flatnonzero(act)
        c = np.broadcast_to(np.asarray(c, float), (n,))
        k = np.broadcast_to(np.asarray(k, float), (n,))
        T0 = np.broadcast_to(np.asarray(body.theta if T_init is None else T_init, float),
                             (n,))
        X = body.ref.X
        a = self.active_index
        self.problem = build_problem(X[a], body.ref.vol[a], body.rho[a], c[a], k[a], T0[a],
                                     body.dx, boundaries, laplacian=laplacian,
                                     kernel="wendland_c2",
                                     support_factor=body.ref.R / body.dx, origin=origin)
        self.follow = np.flatnonzero(~act)
        if self.follow.size:
            _, src = cKDTree(X[a]).query(X[self.follow])
            self.follow_source = src
        self.implicit = implicit
        self.theta_method = theta
        self.stepper = (ThetaStepper(self.problem.system, theta, 1) if implicit
                        else ExplicitStepper(self.problem.system))
        self.stable_dt = self.problem.stable_dt
        self.substeps = 0
        self._write()

    def _write(self) -> None:
        T = self.problem.T[: self.problem.n_real]
        self.body.theta[self.active_index] = T
        if self.follow.size:
            self.body.theta[self.follow] = T[self.follow_source]

    def step(self, dt: float) -> None:
        """Advance the temperatures by ``dt`` and write them to ``body.theta``."""
        if self.implicit:
            self.stepper.step(self.problem.T, dt)
            self.substeps += 1
        else:
            m = max(1, int(np.ceil(dt / self.stable_dt * (1 - 1e-12))))
            for _ in range(m):
                self.stepper.step(self.problem.T, dt / m)
            self.substeps += m
        self._write()

    @property
    def ghosts(self) -> int:
        return self.problem.ghosts.n
