"""``SolidBody``: the state of a total-Lagrangian SPH thermo-elastic body and its forces.

>>> body = SolidBody(X, vol, rho=7800.0, lam=lam, mu=mu, alpha=1.2e-5, dx=dx)
>>> body.clamp(X[:, 1] < 0.0)                     # every component held
>>> body.roller(np.abs(X[:, 0]) > 0.99, "x")      # x held, y free (symmetry plane)
>>> body.set_traction(top, (0.0, -1e6), area=dx)  # applied traction on surface particles
>>> body.theta[:] = 350.0                         # temperature (or a SolidHeat updates it)
>>> a = body.accelerations()                      # F, S, P, forces of the current state

Per-particle material arrays (``lam``, ``mu``, ``alpha``, ``rho``) allow several materials.
The force pipeline is :func:`~sphfem.solid.kinematics.deformation_gradient` ->
:func:`~sphfem.solid.constitutive.pk1_stress` -> :func:`~sphfem.solid.forces.stress_forces`
(+ :func:`~sphfem.solid.forces.hourglass_forces`) + applied forces ``f_ext``.

Constraints act on velocity components: a held component keeps the prescribed velocity
``v_presc`` (0 for clamps and rollers) and gets no acceleration, so the reaction is whatever
the constraint absorbs (:meth:`reaction`).
"""

from __future__ import annotations

import numpy as np

from sphfem.solid.constitutive import cauchy_stress, pk1_stress, strain_energy, von_mises
from sphfem.solid.forces import (
    hourglass_energy,
    hourglass_forces,
    pair_forces_2d,
    stress_forces,
)
from sphfem.solid.kinematics import deformation_gradient
from sphfem.solid.reference import build_reference

_AXES = {"x": 0, "y": 1, "z": 2}


def _components(spec, dim):
    if isinstance(spec, str):
        comps = [_AXES[c] for c in spec.lower()]
    else:
        comps = [int(c) for c in np.atleast_1d(spec)]
    if not comps or any(c >= dim or c < 0 for c in comps):
        raise ValueError(f"components {spec!r} invalid for dimension {dim}")
    return comps


class SolidBody:
    """TL-SPH body.  ``X`` (n, dim) reference positions [m], ``vol`` V0 [m^dim], ``rho``
    [kg/m^3], Lame ``lam``, ``mu`` [Pa], ``alpha`` [1/K] (scalars or per particle),
    ``dx`` the particle spacing (support R = ``support_factor`` dx), ``theta0`` the
    stress-free temperature [K] (scalar or per particle), ``hourglass`` the Ganzenmueller
    coefficient (0: off)."""

    def __init__(self, X, vol, rho, lam, mu, alpha=0.0, dx=None, *, theta0: float = 0.0,
                 support_factor: float = 3.0, kernel: str = "wendland_c2", period=None,
                 hourglass: float = 10.0, damping: float = 0.0):
        X = np.ascontiguousarray(np.asarray(X, float))
        n = X.shape[0]
        if dx is None:
            raise ValueError("give the particle spacing dx")

        def per(a):
            return np.ascontiguousarray(np.broadcast_to(np.asarray(a, float), (n,))).copy()

        self.dx = float(dx)
        self.ref = build_reference(X, per(vol), support_factor * self.dx, kernel, period)
        self.dim = X.shape[1]
        self.period = self.ref.period
        self.rho, self.lam, self.mu, self.alpha = per(rho), per(lam), per(mu), per(alpha)
        if np.any(self.rho <= 0) or np.any(self.mu <= 0) or np.any(self.lam + self.mu <= 0):
            raise ValueError("TL-SPH material needs rho > 0, mu > 0 and lam + mu > 0")
        self.m = self.rho * self.ref.vol
        self.young = self.mu * (3 * self.lam + 2 * self.mu) / (self.lam + self.mu)
        self.theta0 = float(theta0) if np.ndim(theta0) == 0 else per(theta0)
        self.hourglass = float(hourglass)
        self.damping = float(damping)
        self.x = X.copy()
        self.v = np.zeros_like(X)
        self.theta = np.broadcast_to(np.asarray(self.theta0, float), (n,)).copy()
        self.f_ext = np.zeros_like(X)
        self.fixed = np.zeros((n, self.dim), dtype=bool)
        self.v_presc = np.zeros_like(X)
        self.F = np.zeros((n, self.dim, self.dim))
        self.S = np.zeros((n, 3, 3))
        self.P = np.zeros((n, self.dim, self.dim))
        self.f_int = np.zeros_like(X)
        self.force_evaluations = 0
        self._mirror = None  # (ghost, partner, u_sign, X_sign), see mirror()

    # -- geometry --------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.x.shape[0]

    @property
    def X(self) -> np.ndarray:
        return self.ref.X

    @property
    def u(self) -> np.ndarray:
        """Displacement x - X."""
        return self.x - self.ref.X

    # -- boundary conditions ---------------------------------------------------------------
    def clamp(self, mask) -> None:
        """Hold every displacement component of the particles in ``mask``."""
        self.fixed[np.asarray(mask, bool)] = True

    def roller(self, mask, components) -> None:
        """Hold the listed components ("x", "yz", [0, 2]) of the particles in ``mask``
        (symmetry planes, sliding supports)."""
        mask = np.asarray(mask, bool)
        for c in _components(components, self.dim):
            self.fixed[mask, c] = True

    def mirror(self, ghost, partner, u_sign, X_sign) -> None:
        """Make particles ``ghost`` (k,) mirror images of ``partner`` (k,) across symmetry
        planes (rollers): with S = diag(``u_sign``) and Q = diag(``X_sign``) (k, dim) of
        +-1, every force evaluation sets

            x_g = X_g + S (x_p - X_p),   F_g = I + S (F_p - I) Q,   theta_g = theta_p,

        and B0_g = Q B0_p Q once, so a real particle near the plane sees the full support
        of the mirrored body (its stress divergence is that of the symmetric continuation,
        exact for every state symmetric about the plane, e.g. a uniform one).  Ghosts hold
        every component (the integrators never move them) and their own forces are unused;
        body-wide sums (:meth:`strain_energy`, :meth:`reaction`) include them, so callers
        that report those restrict them to the real particles.
        """
        g = np.asarray(ghost, np.int64)
        p = np.asarray(partner, np.int64)
        su = np.asarray(u_sign, float).reshape(g.size, self.dim)
        sx = np.asarray(X_sign, float).reshape(g.size, self.dim)
        if np.isin(p, g).any():
            raise ValueError("mirror: a partner particle is itself a ghost")
        self.fixed[g] = True
        B = self.ref.B
        B[g] = sx[:, :, None] * B[p] * sx[:, None, :]
        self._mirror = (g, p, su, sx)

    def _mirror_positions(self, x) -> None:
        g, p, su, _ = self._mirror
        X = self.ref.X
        x[g] = X[g] + su * (x[p] - X[p])
        self.theta[g] = self.theta[p]

    def _mirror_gradients(self) -> None:
        g, p, su, sx = self._mirror
        eye = np.eye(self.dim)
        self.F[g] = eye + su[:, :, None] * (self.F[p] - eye) * sx[:, None, :]

    def prescribe_velocity(self, mask, velocity) -> None:
        """Move the particles in ``mask`` at ``velocity`` (dim,) (all components held)."""
        mask = np.asarray(mask, bool)
        self.fixed[mask] = True
        self.v_presc[mask] = np.asarray(velocity, float)
        self.v[mask] = self.v_presc[mask]

    def set_traction(self, mask, traction, area) -> None:
        """Applied traction t [Pa] on surface particles: f_ext = t * area per particle
        (area [m^(dim-1)] per particle: dx in 2D (per unit depth), dx^2 in 3D).
        ``traction`` is (dim,) or (n_mask, dim); replaces earlier loads on those particles."""
        mask = np.asarray(mask, bool)
        t = np.asarray(traction, float)
        a = np.asarray(area, float)
        self.f_ext[mask] = t * (a[:, None] if a.ndim else a)

    # -- forces ----------------------------------------------------------------------------
    def internal_forces(self, x=None) -> np.ndarray:
        """F, S, P and the internal forces (stress divergence + hourglass) at positions
        ``x`` (default: the current ones); returns ``f_int`` (n, dim)."""
        x = self.x if x is None else x
        r = self.ref
        if self._mirror is not None:
            self._mirror_positions(x)
        deformation_gradient(x, r.vol, r.offsets, r.indices, r.gw, r.B, r.period, self.F)
        if self._mirror is not None:
            self._mirror_gradients()
        pk1_stress(self.F, self.theta - self.theta0, self.alpha, self.lam, self.mu, self.S,
                   self.P)
        if self.dim == 2:
            pair_forces_2d(x, r.vol, r.offsets, r.indices, r.vgw, r.dX, r.hgw, r.B, self.P,
                           self.F, self.young, self.hourglass, r.period, self.f_int)
            self.force_evaluations += 1
            return self.f_int
        stress_forces(r.vol, r.offsets, r.indices, r.gw, r.B, self.P, self.f_int)
        if self.hourglass > 0.0:
            hourglass_forces(x, r.X, r.vol, r.offsets, r.indices, r.w, self.F, self.young,
                             self.hourglass, r.period, self.f_int)
        self.force_evaluations += 1
        return self.f_int

    def accelerations(self, x=None, v=None) -> np.ndarray:
        """a = (f_int + f_ext) / m - damping v, zero on held components."""
        f = self.internal_forces(x) + self.f_ext
        a = f / self.m[:, None]
        if self.damping > 0.0:
            a -= self.damping * (self.v if v is None else v)
        a[self.fixed] = 0.0
        return a

    def reaction(self) -> np.ndarray:
        """Force the constraints exert on the body, per particle (zero on free components):
        minus the unbalanced internal + applied force on held components."""
        f = -(self.f_int + self.f_ext)
        f[~self.fixed] = 0.0
        return f

    def residual_force(self) -> np.ndarray:
        """Out-of-balance force f_int + f_ext on the free components (held ones: 0)."""
        f = self.f_int + self.f_ext
        f[self.fixed] = 0.0
        return f

    # -- time step -------------------------------------------------------------------------
    def wave_speed(self) -> float:
        """Largest P-wave speed sqrt((lam + 2 mu) / rho) [m/s]."""
        return float(np.sqrt((self.lam + 2 * self.mu) / self.rho).max())

    def omega_max(self, iterations: int = 40, seed: int = 0) -> float:
        """Largest angular frequency of the linearised system M^-1 K at the current state,
        by power iteration with finite-difference stiffness products (K v ~ -(f(x + e v) -
        f(x)) / e).  Held components are excluded."""
        rng = np.random.default_rng(seed)
        free = ~self.fixed
        x0 = self.x.copy()
        f0 = self.internal_forces(x0).copy()
        z = rng.standard_normal(x0.shape) * free
        lam_est = 0.0
        for _ in range(iterations):
            nz = np.linalg.norm(z)
            if nz == 0:
                return 0.0
            z /= nz
            eps = 1e-7 * self.dx
            f1 = self.internal_forces(x0 + eps * z)
            y = -(f1 - f0) / eps / self.m[:, None] * free
            lam_est = float(np.sum(z * y))
            z = y
        self.internal_forces(x0)
        return float(np.sqrt(max(lam_est, 0.0)) * 1.02)

    def stable_dt(self, cfl: float = 0.9, estimate: bool = True) -> float:
        """Explicit (velocity Verlet) limit: ``cfl`` * 2 / omega_max (power iteration), or
        with ``estimate=False`` the sound-speed rule ``cfl`` * 0.5 dx / c."""
        if estimate:
            w = self.omega_max()
            if w > 0:
                return cfl * 2.0 / w
        return cfl * 0.5 * self.dx / self.wave_speed()

    # -- output ----------------------------------------------------------------------------
    def cauchy(self) -> np.ndarray:
        """Cauchy stress (n, 3, 3) of the last force evaluation (2D: plane strain)."""
        return cauchy_stress(self.F, self.S)

    def von_mises(self) -> np.ndarray:
        return von_mises(self.cauchy())

    def momentum(self) -> np.ndarray:
        return (self.m[:, None] * self.v).sum(axis=0)

    def kinetic_energy(self) -> float:
        return 0.5 * float(np.sum(self.m[:, None] * self.v**2))

    def hourglass_energy(self) -> float:
        """Energy stored by the hourglass control at the last force evaluation (pseudo-
        potential, :func:`~sphfem.solid.forces.hourglass_energy`) [J; 2D: J/m]."""
        if self.hourglass == 0.0:
            return 0.0
        r = self.ref
        return hourglass_energy(self.x, r.offsets, r.indices, r.dX, r.hgw, self.F,
                                self.young, self.hourglass, r.period)

    def strain_energy(self) -> float:
        """Free energy sum_i V0_i v^3 W_e(E_e) of the last force evaluation [J; 2D: J/m]
        (:func:`~sphfem.solid.constitutive.strain_energy`)."""
        return strain_energy(self.F, self.theta - self.theta0, self.alpha, self.lam,
                             self.mu, self.ref.vol)

    def diagnostics(self) -> dict:
        return {"particles": self.n, "dim": self.dim, "support_radius_m": self.ref.R,
                "B0_fallbacks": self.ref.fallbacks, "hourglass_coefficient": self.hourglass,
                "force_evaluations": self.force_evaluations,
                "held_components": int(self.fixed.sum())}
