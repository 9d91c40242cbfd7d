"""Akinci et al. (2013) surface tension and wall adhesion (``surface_tension = "akinci"``).

Cohesion + curvature of Akinci, Akinci & Teschner (2013, ACM TOG 32(6) 182) between fluid
particles, and their adhesion to wall particles:

    a_i = sum_j K_ij [ gamma m_j C(d) r/d  +  gamma_k (n_i - n_j) ]        (fluid j)
        + sum_b gamma_a rho0 V_b C(d) r/d                                   (wall b)

    K_ij = 2 rho0 / (rho_i + rho_j),   n_i = R sum_j V_j grad_i W_ij   (fluid + wall j),
    C(d) = (32/pi) R^-dim { (1-q)^3 q^3            if 1/2 < q <= 1
                            2 (1-q)^3 q^3 - 1/64   if 0 < q <= 1/2 }.

Notation as in :mod:`sphfem.fluid.passes` (``r = x_j - x_i``, ``d = |r|``, ``q = d / R``).

Cohesion: calibrated to sigma (:func:`akinci_constant`) by the mechanical tension of a flat
interface between uniform half-spaces, sigma = gamma rho0^2 R^2 AKINCI_C[dim]
(Kirkwood-Buff integral of the pair force).  It also carries an internal (virial) pressure
in the bulk, :func:`internal_pressure` = -(pi/2) gamma rho0^2 R int c q^2 dq (2D), of order
sigma / R: the EOS pressure balances it, so a weakly compressible run needs
rho0 c0^2 >> sigma / R (not just >> sigma / R_drop), see :func:`akinci_c0_pressure`.

Curvature term.  Two changes from the paper, each the cause of the former blow-up (the
2D droplet stopped on the speed guard at step 2):

* sign: n_i here points into the liquid (grad of the kernel sum, as SPlisHSPlasH's
  gradW(x_i - x_j) also gives); with that normal the paper's -gamma (n_i - n_j) pushes the
  outer layer outward (on a disc of 10 layers: +2.5e5 m/s^2, twenty times the cohesion's
  inward pull) and is area-increasing on a convex surface.  The area-minimising term for
  the inward normal is +gamma_k (n_i - n_j) (the paper's term with the outward normal).
* scale: the paper's gamma (n_i - n_j) is not an acceleration for the gamma of the cohesion
  (its weight relative to the cohesion depends on the unit system: in SI with water it is
  ~1/rho0 of it).  Here gamma_k = beta sigma / (rho0 R^2) [m/s^2], beta =
  ``akinci_curvature`` (default 0.1).  The term is a pair sum of normal differences: on a
  flat interface it is normal to the surface, so it adds no tension (the calibration stays
  the cohesion's); it rearranges the density of the surface layers (an internal pressure of
  order beta sigma / R, below the cohesion's) and its area-minimising part on a curved
  surface is O(kappa R) of the Laplace pressure.  It smooths particle-scale surface
  roughness (the paper's reason for it).

Adhesion (the paper's adhesion kernel replaced by the cohesion kernel C, so that wall and
fluid interact like fluid and fluid): by the Young-Dupre relation, the work of adhesion
sigma (1 + cos theta) equals gamma_a / gamma times the work of cohesion 2 sigma of the same
pair potential, hence gamma_a = gamma (1 + cos theta) / 2 for the prescribed equilibrium
contact angle theta = ``akinci_contact_angle`` (degrees; unset: no adhesion, theta = 180).
The wall's repulsion is the wall model's pressure (Adami et al. 2012).

Time step: the capillary limit of :meth:`FluidSolver.dt_limits` with the sigma the
constant represents.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem.fluid.surface import color_gradient
from sphfem.fluid.surface_tension import SurfaceTensionMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param
from sphfem.smallmat import pair_sep

#: default curvature weight beta: gamma_k = beta sigma / (rho0 R^2)
CURVATURE_DEFAULT = 0.1


def _akinci_c(q):
    q = np.asarray(q, float)
    a = (1.0 - q) ** 3 * q**3
    return 32.0 / math.pi * np.where(q > 0.5, a, 2.0 * a - 1.0 / 64.0)


def _akinci_integral(power: int) -> float:
    q = np.linspace(0.0, 1.0, 20001)
    f = _akinci_c(q) * q**power
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


#: sigma = gamma rho0^2 R^(dim+2) R^-dim AKINCI_C[dim]  (cohesion term, half-space)
AKINCI_C = {2: _akinci_integral(3) / 3.0, 3: math.pi / 8.0 * _akinci_integral(4)}
#: bulk virial pressure p = -AKINCI_P[dim] gamma rho0^2 R of the cohesion
#: (p = -(rho0^2 / (2 dim)) int gamma C(r) r dV)
AKINCI_P = {2: 0.5 * math.pi * _akinci_integral(2), 3: 2.0 * math.pi / 3.0 * _akinci_integral(3)}


def akinci_constant(sigma: float, rho0: float, R: float, dim: int) -> float:
    """gamma [m^(dim+1)/(kg s^2)] of the Akinci cohesion for ``sigma`` [N/m]."""
    return sigma / (rho0 * rho0 * R**2 * AKINCI_C[dim])


def internal_pressure(sigma: float, R: float, dim: int) -> float:
    """Virial pressure [Pa] of the cohesion in the bulk (negative: tension) for the gamma
    of ``sigma``: -sigma AKINCI_P / (AKINCI_C R), independent of rho0."""
    return -sigma * AKINCI_P[dim] / (AKINCI_C[dim] * R)


def akinci_c0_pressure(sigma: float, R: float, dim: int, R_drop: float) -> float:
    """The largest pressure [Pa] the model puts on the EOS in a drop of radius ``R_drop``:
    the Laplace pressure plus the cohesion's internal pressure (what rho0 c0^2 must
    exceed ~100-fold for a 1 % density variation)."""
    return (dim - 1) * sigma / R_drop - internal_pressure(sigma, R, dim)


def adhesion_ratio(theta_deg: float | None) -> float:
    """gamma_a / gamma = (1 + cos theta) / 2 (Young-Dupre; None: no adhesion)."""
    if theta_deg is None:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.radians(theta_deg)))


def contact_angle_of_ratio(ratio: float) -> float:
    """Inverse of :func:`adhesion_ratio`: theta [deg] for gamma_a / gamma."""
    return math.degrees(math.acos(min(1.0, max(-1.0, 2.0 * ratio - 1.0))))


@njit(cache=True, inline="always")
def _akinci_shape(q):
    a = (1.0 - q) * (1.0 - q) * (1.0 - q) * q * q * q
    if q > 0.5:
        return 32.0 / math.pi * a
    return 32.0 / math.pi * (2.0 * a - 1.0 / 64.0)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def akinci_accel(x, m, V, rho, kind, offsets, indices, R, gamma, gamma_k, gamma_a, rho0,
                 period, nrm, acc):
    """acc[i] += Akinci cohesion + curvature (fluid j) + adhesion (wall j) on fluid rows;
    ``nrm`` = R grad C (into the liquid), ``gamma_k`` [m/s^2], ``gamma_a`` as ``gamma``."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    Rd = R ** dim
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        ri = rho[i]
        ni0 = nrm[i, 0]
        ni1 = nrm[i, 1] if dim > 1 else 0.0
        ni2 = nrm[i, 2] if dim > 2 else 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            fluid = kind[j] == FLUID
            if not fluid and (kind[j] != WALL or gamma_a == 0.0):
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            if fluid:
                K = 2.0 * rho0 / (ri + rho[j])
                # cohesion: -gamma m_j C (x_i - x_j)/d = +gamma m_j C r/d
                fc = K * gamma * m[j] * _akinci_shape(d / R) / (Rd * d)
                fk = K * gamma_k  # area-minimising for the inward normal (module doc)
                a0 += fc * r0 + fk * (ni0 - nrm[j, 0])
                if dim > 1:
                    a1 += fc * r1 + fk * (ni1 - nrm[j, 1])
                if dim > 2:
                    a2 += fc * r2 + fk * (ni2 - nrm[j, 2])
            else:  # adhesion to the wall particle (rest mass rho0 V_b)
                fa = gamma_a * rho0 * V[j] * _akinci_shape(d / R) / (Rd * d)
                a0 += fa * r0
                if dim > 1:
                    a1 += fa * r1
                if dim > 2:
                    a2 += fa * r2
        acc[i, 0] += a0
        if dim > 1:
            acc[i, 1] += a1
        if dim > 2:
            acc[i, 2] += a2


def _calibrate(pa, m_bar: float, R: float, dim: int):
    """(gamma, the sigma it represents): ``akinci_gamma`` if set, else from sigma."""
    gamma = pa.st_params.get("akinci_gamma", getattr(pa, "akinci_gamma", None))
    if gamma is None:
        gamma = akinci_constant(pa.sigma, pa.rho0, R, dim)
    return gamma, gamma * pa.rho0**2 * R**2 * AKINCI_C[dim]


def _param(pa, key, default):
    v = pa.st_params.get(key, getattr(pa, key, None))
    return default if v is None else v


class AkinciState:
    """Work array of the pass: the normals n = R grad C (fluid rows)."""

    def __init__(self, n: int, dim: int):
        self.n = n
        self.nrm = np.zeros((n, dim))


def _accelerate(solver, state):
    p, s, nl, R, pa = solver.p, solver._scratch, solver.nbrs, solver.R, solver.params
    if state is None or state.n != p.n:
        state = AkinciState(p.n, solver.dim)
    color_gradient(p.x, s.V, p.kind, nl.offsets, nl.indices, R, solver.sigma, solver.kernel_code,
                   solver.period, False, state.nrm)
    state.nrm *= R
    gamma = solver.st_constant
    gamma_k = _param(pa, "akinci_curvature", CURVATURE_DEFAULT) * solver.st_sigma / (
        pa.rho0 * R * R)
    gamma_a = gamma * adhesion_ratio(_param(pa, "akinci_contact_angle", None))
    akinci_accel(p.x, p.m, s.V, p.rho, p.kind, nl.offsets, nl.indices, R, gamma, gamma_k,
                 gamma_a, pa.rho0, solver.period, state.nrm, p.acc)
    return state


_WHEN = ("surface_tension", ("akinci",))

METHOD = register(SurfaceTensionMethod(
    name="akinci",
    doc="cohesion + curvature of Akinci et al. (2013) with adhesion to walls, gamma from sigma "
        "by the cohesion's half-space tension, the curvature term area-minimising and scaled "
        "by akinci_curvature, adhesion from the contact angle by Young-Dupre (see "
        "sphfem.fluid.surface_tension_akinci2013); needs rho0 c0^2 >> sigma / R_kernel "
        "(the cohesion's internal pressure)",
    params=(
        Param("akinci_gamma", float, None, positive=True, when=_WHEN,
              doc="Akinci coefficient gamma [m^(dim+1)/(kg s^2)]; unset: computed from the "
                  "material's sigma [N/m]"),
        Param("akinci_curvature", float, CURVATURE_DEFAULT, ge=0.0, when=_WHEN,
              doc="weight beta of the curvature term, gamma_k = beta sigma / (rho0 R^2) "
                  "[m/s^2] (0: cohesion only)"),
        Param("akinci_contact_angle", float, None, ge=0.0, le=180.0, when=_WHEN,
              doc="equilibrium contact angle on walls [deg]: wall adhesion gamma_a = gamma "
                  "(1 + cos theta) / 2 (Young-Dupre); unset: no adhesion (180 deg)"),
    ),
    constant_key="akinci_gamma",
    calibrate=_calibrate,
    accelerate=_accelerate,
))
