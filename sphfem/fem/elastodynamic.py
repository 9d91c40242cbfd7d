"""Elastodynamic substrate: the FEM substrates' K with a mass matrix, stepped by HHT-alpha.

The quasi-static substrates (:class:`sphfem.fem.FEMSubstrate`, 3D / plane strain, and
:class:`sphfem.fem.axisymmetric.AxisymmetricFEMSubstrate`, per radian in (r, z)) solve
``K u = f``.  :class:`ElastodynamicSubstrate` wraps either one and integrates

    M a + K u = f(t),        M = int rho u . v dx    (axisymmetric: int rho u . v r dr dz)

with the HHT-alpha method (Hilber, Hughes & Taylor 1977, *Earthquake Eng. Struct. Dyn.*
5, 283; Hughes, *The Finite Element Method*, 2000, sec. 9.3)::

    M a_{n+1} + (1 + a) K u_{n+1} - a K u_n = (1 + a) f_{n+1} - a f_n
    u_{n+1} = u_n + dt v_n + dt^2 [(1/2 - beta) a_n + beta a_{n+1}]
    v_{n+1} = v_n + dt [(1 - gamma) a_n + gamma a_{n+1}]
    beta = (1 - a)^2 / 4,  gamma = 1/2 - a,  -1/3 <= a <= 0

``a = 0`` (the default) is Newmark's average acceleration (trapezoidal) rule: unconditionally
stable, second order, no numerical damping, and the discrete energy
``1/2 v.M v + 1/2 u.K u`` is conserved exactly without load.  ``a < 0`` damps the
unresolved high frequencies (the ringing behind a step load) and stays second order; HHT
was chosen over generalised-alpha because one parameter suffices here and ``a = 0``
reduces it to the plain Newmark scheme.  The mass is consistent by default (exact
quadrature of the r-weighted form too); ``mass="lumped"`` (row sums, P1 only) is the
alternative.  In displacement form the step solves

    [(1 + a) K + M / (beta dt^2)] u_{n+1} = (1 + a) f_{n+1} - a f_n + a K u_n + M u* / (beta dt^2)
    u* = u_n + dt v_n + dt^2 (1/2 - beta) a_n

with homogeneous Dirichlet dofs (the substrate's clamps, rollers, axis and pins).  The
effective matrix is factorised once per step size and refactorised only when ``dt``
changes by more than ``DT_RTOL`` (a few distinct sizes are cached).  Loads are assembled
exactly as the quasi-static substrate does (thermal strain, tractions, point forces, body
force, a ready vector), and results are the substrate's own result type.

:func:`wave_speeds` and :func:`quasi_static_check` decide when the quasi-static substrate
is enough (see their docstrings and docs/validation/substrate_dynamics/README.md).

>>> dyn = ElastodynamicSubstrate(sub, rho=3950.0)
>>> res = dyn.step(1e-9, tractions={"top": p_of_x})    # t = 1 ns
>>> res.von_mises_nodes, dyn.energy()
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from skfem import BilinearForm

from sphfem.fem.substrate import FEMResult

logger = logging.getLogger(__name__)

__all__ = ["ElastodynamicSubstrate", "mass_form", "wave_speeds", "rayleigh_speed",
           "ramp_amplification", "quasi_static_check", "QuasiStaticCheck"]

#: distinct step sizes whose factorisations are kept (the SPH step varies a little)
_CACHE = 4
#: step sizes within this relative difference share a factorisation (and its dt)
DT_RTOL = 1e-9


def mass_form(rho: float, axisymmetric: bool) -> BilinearForm:
    """``int rho u . v dx``; per radian ``int rho u . v r dr dz`` when axisymmetric."""

    @BilinearForm
    def form(u, v, w):
        uv = sum(u[i] * v[i] for i in range(u.shape[0]))
        return rho * uv * (w.x[0] if axisymmetric else 1.0)

    return form


class ElastodynamicSubstrate:
    """HHT-alpha / Newmark time stepping of a quasi-static FEM substrate's system.

    Parameters
    ----------
    substrate : a :class:`sphfem.fem.FEMSubstrate` or an
        :class:`sphfem.fem.axisymmetric.AxisymmetricFEMSubstrate` (its K, Dirichlet dofs,
        loads and result type are used; its own factorisation is not).
    rho : density [kg/m^3].
    hht_alpha : the HHT parameter a in [-1/3, 0]; 0 = Newmark average acceleration.
    mass : "consistent" or "lumped" (row-sum, P1 elements only).
    t0 : the time of the initial state (at rest, zero load unless :meth:`reset` says).
    """

    def __init__(self, substrate, rho: float, hht_alpha: float = 0.0,
                 mass: str = "consistent", t0: float = 0.0):
        from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, AxisymmetricResult

        if not rho > 0:
            raise ValueError(f"rho must be > 0, got {rho}")
        if not -1.0 / 3.0 <= hht_alpha <= 0.0:
            raise ValueError(f"hht_alpha must lie in [-1/3, 0], got {hht_alpha}")
        if mass not in ("consistent", "lumped"):
            raise ValueError(f"mass must be 'consistent' or 'lumped', got {mass!r}")
        if mass == "lumped" and substrate.element != "P1":
            raise ValueError("mass='lumped' (row sums) needs P1 elements; row-sum lumping of "
                             "P2 gives zero or negative vertex masses")
        self.sub = substrate
        self.rho = float(rho)
        self.axisymmetric = isinstance(substrate, AxisymmetricFEMSubstrate)
        self._result_cls = AxisymmetricResult if self.axisymmetric else FEMResult
        self.hht_alpha = a = float(hht_alpha)
        self.beta, self.gamma = (1.0 - a) ** 2 / 4.0, 0.5 - a
        self.mass_kind = mass
        t1 = time.perf_counter()
        M = mass_form(self.rho, self.axisymmetric).assemble(substrate.basis).tocsr()
        if mass == "lumped":
            M = sp.diags(np.asarray(M.sum(axis=1)).ravel()).tocsr()
        self.M = M
        I = substrate.I
        self._K_II = substrate.K[I][:, I].tocsc()
        self._M_II = M[I][:, I].tocsc()
        self.timings = {"assemble_M": time.perf_counter() - t1, "factorize": 0.0,
                        "assemble_load": 0.0, "solve": 0.0}
        self._lu: dict[float, object] = {}
        self.n_factorizations = 0
        self.n_steps = 0
        self.reset(t0=t0)

    # ------------------------------------------------------------------ state
    def reset(self, u0=None, v0=None, f0=None, t0: float = 0.0) -> None:
        """Initial state: displacement ``u0``, velocity ``v0`` (full dof vectors, default 0)
        under the load vector ``f0`` (default 0); a_0 solves M a_0 = f0 - K u0."""
        N = self.sub.basis.N
        self.u = np.zeros(N) if u0 is None else np.array(u0, float)
        self.v = np.zeros(N) if v0 is None else np.array(v0, float)
        self.f = np.zeros(N) if f0 is None else np.array(f0, float)
        D = self.sub.D
        self.u[D] = 0.0
        self.v[D] = 0.0
        self.a = np.zeros(N)
        I = self.sub.I
        r = self.f - self.sub.K @ self.u
        if np.any(r[I]):
            self.a[I] = splu(self._M_II).solve(r[I])
        self.t = float(t0)
        self.dT = None

    def energy(self) -> dict:
        """Kinetic ``1/2 v.M v`` and strain ``1/2 u.K u`` energy [J] (axisymmetric: per
        radian; times 2 pi for the body) and their sum."""
        kin = 0.5 * float(self.v @ (self.M @ self.v))
        pot = 0.5 * float(self.u @ (self.sub.K @ self.u))
        return {"kinetic": kin, "strain": pot, "total": kin + pot}

    # ------------------------------------------------------------------ loads
    def load_vector(self, **loads):
        """(f, dT) of the loads (keywords of :meth:`sphfem.fem.FEMSubstrate.solve`),
        assembled by the substrate (:meth:`sphfem.fem.FEMSubstrate.load_vector`)."""
        return self.sub.load_vector(**loads)

    def _solver(self, dt: float):
        """(factorisation, step size) for ``dt``: a cached size within ``DT_RTOL`` of dt is
        reused (coupling times t_n - t_{n-1} differ by round-off from one interval to the
        next), otherwise K_eff is factorised for dt."""
        for key, lu in self._lu.items():
            if abs(dt - key) <= DT_RTOL * key:
                return lu, key
        t0 = time.perf_counter()
        A = (1.0 + self.hht_alpha) * self._K_II + self._M_II / (self.beta * dt * dt)
        lu = splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
        if len(self._lu) >= _CACHE:
            self._lu.pop(next(iter(self._lu)))
        self._lu[float(dt)] = lu
        self.n_factorizations += 1
        self.timings["factorize"] += time.perf_counter() - t0
        logger.debug("elastodynamic: factorised K + M/(beta dt^2) for dt = %.4g s", dt)
        return lu, float(dt)

    # ------------------------------------------------------------------ step
    def step(self, dt: float, **loads):
        """Advance by ``dt`` [s] to t + dt under the loads at t + dt (keywords of
        :meth:`load_vector`); returns the substrate's result type for the new state."""
        if not dt > 0:
            raise ValueError(f"elastodynamic step: dt must be > 0, got {dt}")
        t0 = time.perf_counter()
        f, dT = self.load_vector(**loads)
        t1 = time.perf_counter()
        res = self.advance(dt, f, dT)
        self.timings["assemble_load"] += t1 - t0
        return res

    def advance(self, dt: float, f: np.ndarray, dT=None):
        """One HHT-alpha step with a ready load vector ``f`` at t + dt (``dT`` only for the
        stress recovery: the thermal strain is already in f)."""
        t1 = time.perf_counter()
        a, beta, gamma = self.hht_alpha, self.beta, self.gamma
        I = self.sub.I
        K = self.sub.K
        lu, dt_req = self._solver(dt)
        dt, dt_req = dt_req, dt  # the factorised size (within DT_RTOL); t advances by dt_req
        c = 1.0 / (beta * dt * dt)
        u_star = self.u + dt * self.v + dt * dt * (0.5 - beta) * self.a
        v_star = self.v + dt * (1.0 - gamma) * self.a
        rhs = (1.0 + a) * f - a * self.f + c * (self.M @ u_star)
        if a:
            rhs += a * (K @ self.u)
        u = self.sub.basis.zeros()
        u[I] = lu.solve(rhs[I])
        acc = c * (u - u_star)
        acc[self.sub.D] = 0.0
        self.v = v_star + gamma * dt * acc
        self.u, self.a, self.f = u, acc, np.asarray(f, float).copy()
        self.t += dt_req
        self.dT = dT
        self.n_steps += 1
        self.timings["solve"] += time.perf_counter() - t1
        return self._result_cls(self.sub, u, self.f, dT,
                                {"t": self.t, "dt": dt, "solve_s": time.perf_counter() - t1})

    def diagnostics(self) -> dict:
        return {"scheme": "newmark-average-acceleration" if self.hht_alpha == 0 else "hht",
                "hht_alpha": self.hht_alpha, "beta": self.beta, "gamma": self.gamma,
                "mass": self.mass_kind, "rho": self.rho, "steps": self.n_steps,
                "factorizations": self.n_factorizations, "timings_s": dict(self.timings),
                **{f"energy_{k}": v for k, v in self.energy().items()}}


# ----------------------------------------------------------------------------- criterion
def rayleigh_speed(nu: float, c_s: float) -> float:
    """Rayleigh wave speed [m/s]: the root x = (c_R / c_S)^2 in (0, 1) of
    x^3 - 8 x^2 + 8 (3 - 2 k) x - 16 (1 - k) = 0, k = (c_S / c_P)^2 = (1 - 2 nu) / (2 - 2 nu)
    (Achenbach, *Wave Propagation in Elastic Solids*, 1973, eq. 5.69)."""
    from scipy.optimize import brentq

    k = (1.0 - 2.0 * nu) / (2.0 - 2.0 * nu)

    def g(x):
        return x ** 3 - 8 * x ** 2 + 8 * (3 - 2 * k) * x - 16 * (1 - k)

    return c_s * float(np.sqrt(brentq(g, 1e-6, 1.0 - 1e-12)))


def wave_speeds(E: float, nu: float, rho: float) -> dict:
    """P (dilatational), S (shear), Rayleigh and bar (sqrt(E/rho)) speeds [m/s]:
    c_P^2 = (lam + 2 mu)/rho = E (1 - nu) / ((1 + nu)(1 - 2 nu) rho), c_S^2 = mu / rho."""
    mu = E / (2.0 * (1.0 + nu))
    m = E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    c_p, c_s = float(np.sqrt(m / rho)), float(np.sqrt(mu / rho))
    return {"P": c_p, "S": c_s, "R": rayleigh_speed(nu, c_s), "bar": float(np.sqrt(E / rho))}


def ramp_amplification(t_rise: float, period: float) -> float:
    """Peak dynamic / static response of an undamped oscillator of ``period`` to a load
    ramped linearly over ``t_rise`` and held: 1 + |sin(pi x)| / (pi x), x = t_rise / period
    (Clough & Penzien, *Dynamics of Structures*, 1993, sec. 4-5); 2 for a step."""
    x = t_rise / period
    if x <= 0:
        return 2.0
    return 1.0 + abs(np.sin(np.pi * x)) / (np.pi * x)


@dataclass
class QuasiStaticCheck:
    """Result of :func:`quasi_static_check` (times in s, speeds in m/s)."""

    speeds: dict
    transit: dict  #: h/c_P, h/c_S, lateral half-width / c_R
    period: float  #: slowest thickness mode of the layer held at its base: 4 h / c_S
    load_times: dict  #: the loading's time scales as given
    amplification: dict  #: envelope min(2, 1 + T_1 / (pi t)) of the ramp amplification
    tolerance: float
    applies: dict  #: per load time scale: amplification - 1 <= tolerance

    def table(self) -> str:
        rows = [f"c_P {self.speeds['P']:.0f}, c_S {self.speeds['S']:.0f}, c_R "
                f"{self.speeds['R']:.0f} m/s; thickness mode 4h/c_S = {self.period * 1e9:.1f} ns"]
        for k, t in self.load_times.items():
            rows.append(f"{k}: {t * 1e9:.3g} ns, amplification {self.amplification[k]:.3f} "
                        f"-> {'quasi-static' if self.applies[k] else 'dynamic'}")
        return "\n".join(rows)


def quasi_static_check(E: float, nu: float, rho: float, thickness: float,
                       half_width: float, load_times: dict,
                       tolerance: float = 0.1) -> QuasiStaticCheck:
    """Does a quasi-static substrate hold for loads varying on the ``load_times``?

    A layer of thickness h held at its base (the clamped substrate) has its slowest
    standing mode at the fixed-free thickness resonance of shear waves, T_1 = 4 h / c_S
    (the P-wave one, 4 h / c_P, is faster).  A load that rises over t_r excites it with
    the peak amplification of :func:`ramp_amplification`, at most its envelope
    min(2, 1 + T_1 / (pi t_r)) (2: a step); the quasi-static answer is within ``tolerance``
    when T_1 / (pi t_r) <= tolerance, i.e.
    t_r >= T_1 / (pi tolerance).  The lateral transit half_width / c_R is reported: edge
    reflections return after twice it.  ``load_times`` names the time scales, e.g.
    ``{"water hammer R/c_f": R / c_f, "contact D/v": D / v}``."""
    c = wave_speeds(E, nu, rho)
    T1 = 4.0 * thickness / c["S"]
    amp = {k: 1.0 + (min(1.0, T1 / (np.pi * t)) if t > 0 else 1.0)
           for k, t in load_times.items()}
    return QuasiStaticCheck(
        speeds=c,
        transit={"h/c_P": thickness / c["P"], "h/c_S": thickness / c["S"],
                 "half_width/c_R": half_width / c["R"]},
        period=T1, load_times=dict(load_times), amplification=amp, tolerance=tolerance,
        applies={k: bool(v - 1.0 <= tolerance) for k, v in amp.items()})
