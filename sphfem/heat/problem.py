"""A stand-alone heat problem on fixed particles: ghosts + conduction system + stepper.

Used by the validation cases, the tests and :class:`sphfem.heat.module.HeatConduction`:

    prob = build_problem(x, vol, rho, c, k, T0, dx, faces, laplacian="fatehi_manzari")
    out = prob.run(t_end=0.03)              # explicit at the stable step
    out = prob.run(t_end=0.03, implicit=True, theta=0.5, dt=100 * prob.stable_dt)

The real particles come first in every array of the problem, the ghosts after them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from sphfem import kernels
from sphfem.heat.energy import EnergyLedger
from sphfem.heat.ghosts import Face, Ghosts, box_faces, place_ghosts
from sphfem.heat.stepping import ExplicitStepper, ThetaStepper
from sphfem.heat.system import HeatSystem
from sphfem.neighbors import build_neighbor_list
from sphfem.operators import interpolate


def faces_of(boundaries) -> list[Face]:
    """Faces from a list of :class:`Face` and/or ``BoxBoundary`` (lo, hi, faces)."""
    out = []
    for b in boundaries:
        out.extend([b] if isinstance(b, Face) else box_faces(b.lo, b.hi, b.faces))
    return out


@dataclass
class RunResult:
    T: np.ndarray          # temperatures of the real particles at t_end
    steps: int
    dt: float
    wall_s: float
    energy: dict = field(default_factory=dict)


@dataclass
class HeatProblem:
    system: HeatSystem
    ghosts: Ghosts
    n_real: int
    x: np.ndarray
    m: np.ndarray
    c: np.ndarray
    T: np.ndarray          # full set (real + ghosts), ghosts up to date

    @property
    def stable_dt(self) -> float:
        return self.system.stable_dt()

    def energy(self) -> float:
        return self.system.energy(self.T, self.m, self.c)

    def run(self, t_end: float, dt: float | None = None, implicit: bool = False,
            theta: float = 1.0, startup: int = 1) -> RunResult:
        """Advance to ``t_end`` with equal steps no larger than ``dt`` (default: the
        explicit stable step); the problem's ``T`` is updated in place."""
        dt = self.stable_dt if dt is None else dt
        nsteps = max(1, int(np.ceil(t_end / dt * (1 - 1e-12))))
        dt = t_end / nsteps
        t0 = time.perf_counter()
        stepper = (ThetaStepper(self.system, theta, startup) if implicit
                   else ExplicitStepper(self.system))
        ledger = EnergyLedger(self.energy())
        for _ in range(nsteps):
            heat = stepper.step(self.T, dt)
            ledger.record(self.energy(), heat)
        wall = time.perf_counter() - t0
        return RunResult(self.T[: self.n_real].copy(), nsteps, dt, wall, ledger.to_dict())


def free_surface_rows(kernel_args, threshold: float = 0.85, faces=(), n_real=None):
    """Rows that take the plain weights under the corrected Laplacian: particles within the
    support radius R of a ``free`` face, and particles whose number density
    sum_j V_j W_ij (ghosts counted) is below ``threshold`` (free surfaces that no face
    describes).

    The Fatehi-Manzari Laplacian is exact for quadratics, so on a one-sided stencil it
    imposes no boundary condition at all, and the discrete operator then has eigenvalues
    with large positive real part (measured: Re(lambda) ~ +500 on a 12 x 12 patch with one
    free edge, dx = 1/12); explicit and implicit runs both blow up.  The plain (Cleary)
    rows there exchange no heat through the surface (a zero-flux condition) and remove
    those modes.  A density threshold alone needs ~0.95 on perturbed particles, which also
    catches ~8 % of the interior (random clustering) and spoils convergence; hence the
    geometric rule for faces and the low default for the density rule.
    """
    x, R = kernel_args[0], kernel_args[4]
    rows = interpolate(np.ones(x.shape[0]), *kernel_args) < threshold
    for f in faces:
        if f.bc == "free":
            d = f.side * (f.position - x[:, f.axis])
            rows |= d < R
    if n_real is not None:
        rows[n_real:] = False
    return rows


def build_problem(x, vol, rho, c, k, T0, dx: float, boundaries=(), *,
                  laplacian: str = "cleary", kernel: str = "wendland_c2",
                  support_factor: float = 3.0, eta_place: float = 0.85,
                  eta_trim: float = 1.3, dirichlet_ghosts: str = "antisymmetric",
                  insulated_source: str = "mirror", origin=None, held=None,
                  free_surface_plain: float = 0.85, period=None, lo=None) -> HeatProblem:
    """Place ghosts for ``boundaries`` around the real particles ``x`` (n, dim) and build
    the conduction system.  ``rho`` [kg/m^3], ``c`` [J/(kg K)], ``k`` [W/(m K)], ``T0`` [K]
    are per particle or scalars; ``held`` marks real particles whose T stays fixed.
    ``period`` (dim,) makes axes periodic (length > 0; 0 = open) with the periodic cell
    starting at ``lo`` (see :func:`~sphfem.heat.ghosts.place_ghosts`).

    With the corrected Laplacian, particles near a free face or with number density (ghosts
    counted) below ``free_surface_plain`` use the plain rows (:func:`free_surface_rows`)."""
    x = np.ascontiguousarray(np.asarray(x, float))
    if x.ndim != 2:
        raise ValueError("positions must have shape (n, dim)")
    n, dim = x.shape
    bc = [np.broadcast_to(np.asarray(a, float), (n,)).copy() for a in (vol, rho, c, k, T0)]
    vol, rho, c, k, T0 = bc
    R = support_factor * dx
    faces = faces_of(boundaries)
    period = (np.zeros(dim) if period is None
              else np.broadcast_to(np.asarray(period, float), (dim,)).copy())
    gh = place_ghosts(x, vol, dx, R, faces, kernel=kernel, eta_place=eta_place,
                      eta_trim=eta_trim, origin=origin, neumann_source=insulated_source,
                      period=period, lo=lo)
    s = gh.source
    xa = np.ascontiguousarray(np.concatenate([x, gh.x]))
    va = np.concatenate([vol, vol[s]])
    ma = np.concatenate([rho * vol, rho[s] * vol[s]])
    ca = np.concatenate([c, c[s]])
    ka = np.concatenate([k, k[s]])
    Ta = np.concatenate([T0, T0[s]])
    na = xa.shape[0]
    kind = kernels.kernel_code(kernel)
    sigma = kernels.kernel_sigma(kind, dim, R)
    nl = build_neighbor_list(xa, R, xa.min(0) - R, xa.max(0) + R, period)
    active = np.zeros(na, dtype=bool)
    active[:n] = True
    if held is not None:
        active[:n] &= ~np.asarray(held, bool)
    args = (xa, va, nl.offsets, nl.indices, R, sigma, kind, period)
    plain = (free_surface_rows(args, free_surface_plain, faces, n)
             if laplacian != "cleary" else None)
    system = HeatSystem(args, ma * ca / va, ka, active, np.arange(n, na), gh.type, gh.source,
                        gh.t_wall, laplacian=laplacian, dirichlet_mode=dirichlet_ghosts,
                        plain_rows=plain, ghost_ratio=gh.ratio)
    system.apply_ghosts(Ta)
    return HeatProblem(system, gh, n, xa, ma, ca, Ta)
