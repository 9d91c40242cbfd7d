"""Continuum surface force (CSF) for single-phase free-surface SPH (``surface_tension = "csf"``).

Brackbill, Kothe & Zemach (1992): the surface tension is the volume force

    f = sigma kappa n_in delta_s,       kappa = -div(n_in),

with n_in the unit normal pointing into the liquid and delta_s a surface delta function
(int delta_s dn = 1 across the interface).  SPH forms after Morris (2000); single-phase
(free-surface) variant as follows.  Notation as in :mod:`sphfem.fluid.passes`: r = x_j - x_i,
grad_i W_ij = F r, F = -W'(d)/d >= 0; sums over the fluid's neighbour view, wall particles
count as liquid (so a wetted wall is no free surface; no contact-angle model).

1. Colour gradient (:func:`csf_normals`):  g_i = grad C_i = sum_j V_j grad_i W_ij, the
   gradient of the kernel sum C_i = sum_j V_j W_ij.  g points into the liquid; in the bulk
   g ~ 0, on the outer layer of a droplet |g| R ~ 1.3, on the second layer ~ 0.25.  The
   normal n_i = g_i / |g_i| is trusted with the weight omega_i = smoothstep((|g_i| R - 0.3)
   / 0.6) (0 below |g| R = 0.3, 1 above 0.9; a smooth switch instead of Morris' sharp
   threshold, so that particles entering or leaving the surface layer do not make the
   force jump); "valid" normals are those with omega > 0.

2. Curvature (:func:`csf_curvature`), over the neighbours with valid normals (Morris 2000),
   weighted by omega_j:

       kappa_i = (dim - 1) sum_j' w_j (n_i - n_j) . F r  /  max(T_i, 0.25 (dim - 1)),
       T_i = sum_j' w_j F (|r|^2 - (r . n_i)^2),     w_j = omega_j V_j.

   The numerator is -div(n) of the plain SPH divergence.  The truncated, one-sided support
   of a surface particle is corrected by dividing by the *tangential* moment T_i of the same
   sum instead of its full-support value (dim - 1): the divergence of a unit normal field
   has only tangential terms (n . grad n = 0), so for n_j - n_i ~ -K r_t (K the curvature
   tensor) the ratio is exactly the mean of the principal curvatures whatever part of the
   support is present (with a tangentially isotropic neighbourhood); times (dim - 1) it is
   kappa = k1 + k2 (1/R_d of a disc, 2/R_d of a sphere).  Morris' own correction, dividing
   by sum_j' V_j W_ij, has the same aim; on the static disc / sphere of the curvature
   test its mean is 1.8 % / 1.1 % off the exact value, ours 0.1 % / 0.7 %.
   The floor of T (the outer layer alone gives T ~ 0.5 (dim - 1)) damps
   the curvature of isolated particles instead of letting it blow up.

3. Band curvature and force (:func:`csf_force`): the curvature is extended to every particle
   within R of valid normals by a Shepard mean, kbar_i = sum_j' w_j W_ij kappa_j /
   max(sum_j' w_j W_ij, 0.2) (self included; the floor fades the force in with depth), and

       f_i = 2 sigma kbar_i g_i,     a_i = f_i / rho_i.

   delta_s = |g|: across a flat free surface the kernel sum falls from 1 in the bulk to
   1/2 at the surface, so int |g| dn over the liquid side is 1/2, not 1 -- the other half
   of the jump of a two-phase colour function lies in the (absent) gas.  The factor 2
   puts the whole jump on the liquid.  It is also what the symmetric pressure gradient
   needs: a uniform pressure P acts on every particle with -2 P g_i / rho_i (the missing
   outer neighbours count as p = 0), so with a uniform kbar the static balance of each
   particle is P = sigma kbar, Laplace's jump.  The extension matters: the second layer
   carries ~ 15 % of int |g| dn but has no trustworthy normal of its own.

Momentum: the CSF force is a field force, not a sum of antisymmetric pair forces, so
linear and angular momentum are conserved only to the discretisation error (on a closed
surface int kappa n dA = 0 in the continuum; a symmetric droplet gets zero net force by
symmetry); the droplet validation reports the centre-of-mass drift and the momentum.

Time step (Brackbill et al. 1992, capillary wave limit): dt <= 0.25 sqrt(rho h^3/(2 pi
sigma)) = 0.25 h / c_cap, reported as ``capillary`` by :meth:`FluidSolver.dt_limits`, with

    c_cap = sqrt(2 pi sigma / (rho h))                   (:func:`capillary_wave_speed`)

the phase speed sqrt(sigma k / rho) of a capillary wave of wavelength h.

Stability: weakly compressible SPH needs c0 >= c_cap (the acoustic step at least as short
as the capillary one).  The particle-scale capillary waves the CSF carries travel at up to
~c_cap; with c0 below it they are faster than sound and couple with the (delta-diffused)
density: surface ripples grow.  Measured on the 2D droplet (R = 1 mm, sigma = 0.072 N/m,
alpha = 0.02, delta = 0.1, l = 2 mode): c0 from the Laplace rule alone is 2.68 m/s; at
R/dx = 40 (c_cap = 3.47 m/s) the rms surface ripple (``surface_ripple`` of
:mod:`sphfem.validation.fluid`) stays < 0.01 dx to 1.2 periods, then grows by ~2.2x per
0.09 period and stops the run at 1.6 periods; the same with half the time step; with
c0 = c_cap it stays < 0.011 dx to 2 periods (period 1.018 T_Rayleigh).  delta = 0 or 0.05,
or particle shifting ("all"), also keep it below 0.015 dx (to 3, 1.8, 1.6 periods), which
points at the density coupling; at R/dx <= 20 the Laplace rule's c0 already exceeds c_cap.
:func:`_calibrate` logs a warning when a scene's c0 is below c_cap.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numba import njit, prange

from sphfem.fluid.contact_angle_breinlinger2013 import young_curvature_normals
from sphfem.fluid.passes import grad_factor
from sphfem.fluid.surface import color_gradient_row
from sphfem.fluid.surface_tension import SurfaceTensionMethod, register
from sphfem.kernels import FASTMATH, kernel_f
from sphfem.particles import FLUID
from sphfem.schema import Param
from sphfem.smallmat import pair_sep

logger = logging.getLogger(__name__)

#: normal weight omega = smoothstep of |grad C| R from NORMAL_LO to NORMAL_HI (|grad C| R
#: ~ 1.3 on the outer layer of a droplet, ~ 0.25 on the second, < 0.1 in the bulk)
NORMAL_LO, NORMAL_HI = 0.3, 0.9
#: floor of the tangential moment, as a fraction of its full-support value dim - 1 (the
#: outer layer alone gives ~ 0.5): isolated particles get a damped, not a huge, curvature
TANGENT_MIN = 0.25
#: floor of the Shepard denominator of the band curvature (~ 0.5 on the outer layer,
#: ~ 0.25 on the second): the force fades in smoothly with depth
SHEPARD_MIN = 0.2
#: delta_s = DELTA_FACTOR |grad C| on the liquid side of a free surface (see module doc)
DELTA_FACTOR = 2.0


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def csf_normals(x, V, kind, offsets, indices, R, sigma, kernel_code, period, a0, a1, g, omega):
    """Colour gradient ``g`` (fluid and wall neighbours) and the normal weight ``omega``
    (smoothstep of |g| R from ``a0`` to ``a1``) of every fluid particle; other rows are
    zeroed."""
    n, dim = x.shape
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        if kind[i] == FLUID:
            g0, g1, g2 = color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kernel_code,
                                            period, periodic, False)
        g[i, 0] = g0
        if dim > 1:
            g[i, 1] = g1
        if dim > 2:
            g[i, 2] = g2
        w = 0.0
        if kind[i] == FLUID:
            a = (np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) * R - a0) / (a1 - a0)
            if a >= 1.0:
                w = 1.0
            elif a > 0.0:
                w = a * a * (3.0 - 2.0 * a)
        omega[i] = w


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def csf_curvature(x, V, kind, offsets, indices, R, sigma, kernel_code, period, den_min, g, omega,
                  kappa):
    """Curvature ``kappa`` of the particles with valid normals (0 elsewhere), from the
    neighbours with valid normals (see the module docstring)."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        kappa[i] = 0.0
        if omega[i] == 0.0:
            continue
        gi0 = g[i, 0]
        gi1 = g[i, 1] if dim > 1 else 0.0
        gi2 = g[i, 2] if dim > 2 else 0.0
        gn = np.sqrt(gi0 * gi0 + gi1 * gi1 + gi2 * gi2)
        ni0 = gi0 / gn
        ni1 = gi1 / gn
        ni2 = gi2 / gn
        num = 0.0
        den = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if omega[j] == 0.0:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            t = omega[j] * V[j] * grad_factor(np.sqrt(d2), R, fac2, kernel_code)
            gj0 = g[j, 0]
            gj1 = g[j, 1] if dim > 1 else 0.0
            gj2 = g[j, 2] if dim > 2 else 0.0
            gnj = np.sqrt(gj0 * gj0 + gj1 * gj1 + gj2 * gj2)
            num += t * ((ni0 - gj0 / gnj) * r0 + (ni1 - gj1 / gnj) * r1
                        + (ni2 - gj2 / gnj) * r2)
            rn = r0 * ni0 + r1 * ni1 + r2 * ni2
            den += t * (d2 - rn * rn)
        kappa[i] = (dim - 1) * num / max(den, den_min * (dim - 1))


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def csf_force(x, V, rho, kind, offsets, indices, R, sigma, kernel_code, period, st_sigma,
              delta_factor, shepard_min, g, omega, kappa, kbar, acc):
    """Curvature extended to the surface band, ``kbar`` (Shepard mean of ``kappa`` over
    the valid neighbours within R, self included; 0 without any), and
    acc[i] += delta_factor st_sigma kbar_i g_i / rho_i on fluid particles."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    w0 = sigma * kernel_f(0.0, kernel_code)
    for i in prange(n):
        kbar[i] = 0.0
        if kind[i] != FLUID:
            continue
        num = 0.0
        den = 0.0
        if omega[i] > 0.0:
            num = omega[i] * V[i] * w0 * kappa[i]
            den = omega[i] * V[i] * w0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if omega[j] == 0.0:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            w = omega[j] * V[j] * sigma * kernel_f(np.sqrt(d2) / R, kernel_code)
            num += w * kappa[j]
            den += w
        if den <= 0.0:
            continue
        kap = num / max(den, shepard_min)
        kbar[i] = kap
        s = delta_factor * st_sigma * kap / rho[i]
        acc[i, 0] += s * g[i, 0]
        if dim > 1:
            acc[i, 1] += s * g[i, 1]
        if dim > 2:
            acc[i, 2] += s * g[i, 2]


class CSFState:
    """Work arrays of the CSF passes (recomputed at every evaluation, never persistent):
    colour gradient ``g``, normal validity ``valid``, curvature ``kappa`` (valid normals)
    and the band curvature ``kbar`` that the force uses."""

    def __init__(self, n: int, dim: int):
        self.n = n
        self.g = np.zeros((n, dim))
        self.omega = np.zeros(n)
        self.kappa = np.zeros(n)
        self.kbar = np.zeros(n)
        self.young = None  # Young's normals of the contact angle (csf_contact_angle)

    def accumulate(self, x, V, rho, kind, offsets, indices, R, sigma, kernel_code, period,
                   st_sigma, acc, adjust_normals=None):
        """The three passes: normals, curvature, force (acc += CSF acceleration).
        ``adjust_normals(g, omega) -> (g_k, omega_k)``, if given, gives the normals and
        weights the curvature is computed from (the contact angle:
        :func:`sphfem.fluid.contact_angle_breinlinger2013.young_curvature_normals`); the
        force keeps the colour gradient ``g`` as its direction and surface delta."""
        csf_normals(x, V, kind, offsets, indices, R, sigma, kernel_code, period, NORMAL_LO,
                    NORMAL_HI, self.g, self.omega)
        gk, ok = (self.g, self.omega) if adjust_normals is None else adjust_normals(self.g,
                                                                                   self.omega)
        csf_curvature(x, V, kind, offsets, indices, R, sigma, kernel_code, period, TANGENT_MIN,
                      gk, ok, self.kappa)
        csf_force(x, V, rho, kind, offsets, indices, R, sigma, kernel_code, period, st_sigma,
                  DELTA_FACTOR, SHEPARD_MIN, self.g, self.omega, self.kappa, self.kbar, acc)

    @property
    def valid(self) -> np.ndarray:
        """Particles with a (partly) valid normal, omega > 0."""
        return self.omega > 0.0


def csf_state(state: CSFState | None, n: int, dim: int) -> CSFState:
    """``state`` if it fits ``n`` particles, else a new one."""
    return state if state is not None and state.n == n else CSFState(n, dim)


def capillary_wave_speed(sigma: float, rho: float, h: float) -> float:
    """Phase speed [m/s] of a capillary wave of wavelength ``h``, sqrt(2 pi sigma / (rho h)):
    the least c0 for which the particle-scale capillary waves are subsonic (module doc)."""
    return math.sqrt(2.0 * math.pi * sigma / (rho * h))


def _calibrate(pa, m_bar: float, R: float, dim: int):
    """CSF uses the material's sigma directly (no calibration constant); warns when c0 is
    below the capillary wave speed at h = R/2 (surface ripples grow, module doc)."""
    if pa.sigma > 0:
        c_cap = capillary_wave_speed(pa.sigma, pa.rho0, 0.5 * R)
        if pa.c0 < c_cap:
            logger.warning("surface_tension = 'csf': c0 = %.3g m/s is below the capillary wave "
                           "speed sqrt(2 pi sigma/(rho0 h)) = %.3g m/s at h = R/2; "
                           "particle-scale surface ripples can grow: raise c0 to >= %.3g m/s",
                           pa.c0, c_cap, c_cap)
    return None, pa.sigma


def _accelerate(solver, state):
    p, s, nl = solver.p, solver._scratch, solver.nbrs
    state = csf_state(state, p.n, solver.dim)
    theta = solver.params.st_params.get("csf_contact_angle",
                                        getattr(solver.params, "csf_contact_angle", None))
    adjust = None
    if theta is not None:  # Young's normals at the walls (Breinlinger et al. 2013)
        def adjust(g, omega):
            state.young = young_curvature_normals(solver, g, omega, float(theta), state.young)
            return state.young.g, state.young.omega
    state.accumulate(p.x, s.V, p.rho, p.kind, nl.offsets, nl.indices, solver.R, solver.sigma,
                     solver.kernel_code, solver.period, solver.st_sigma, p.acc, adjust)
    return state


METHOD = register(SurfaceTensionMethod(
    name="csf",
    doc="recommended; continuum surface force sigma kappa n delta_s of Brackbill et al. "
        "(1992) in a single-phase free-surface SPH form (colour gradient of the kernel sum, "
        "curvature from the valid normals with a tangential-moment correction, see "
        "sphfem.fluid.surface_tension_csf), the material's sigma used directly, checked "
        "against the Laplace pressure and Rayleigh's droplet period; needs c0 >= "
        "sqrt(2 pi sigma/(rho0 h)) (else particle-scale surface ripples grow)",
    params=(
        Param("csf_contact_angle", float, None, ge=0.0, le=180.0,
              when=("surface_tension", ("csf",)),
              doc="equilibrium contact angle on walls [deg] (through the liquid): the "
                  "curvature sees Young's normals n_w cos theta + t_w sin theta on the fluid "
                  "layer along a wall and on the wall particles next to the surface "
                  "(Breinlinger et al. 2013, sphfem.fluid.contact_angle_breinlinger2013; "
                  "pair with [fluid] wall_slip: a no-slip wall pins the contact line); "
                  "unset: walls count as liquid and the contact line has no condition"),
    ),
    constant_key=None,
    calibrate=_calibrate,
    accelerate=_accelerate,
))
