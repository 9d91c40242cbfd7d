"""Akinci et al. (2013) surface tension and wall adhesion (``surface_tension = "akinci"``).

Cohesion + curvature of Akinci, Akinci & Teschner (2013, ACM TOG 32(6) 182) between fluid
particles, and their adhesion to wall particles:

    a_i = sum_j K_ij [ gamma m_j C(d) r/d  -  gamma_k (n_i - n_j) ]        (fluid j)
        + sum_b gamma_a rho0 V_b C(d) r/d                                   (wall b)

    K_ij = 2 rho0 / (rho_i + rho_j),   n_i = R sum_j V_j grad_i W_ij   (fluid j),
    C(d) = (32/pi) R^-dim { (1-q)^3 q^3            if 1/2 < q <= 1
                            2 (1-q)^3 q^3 - 1/64   if 0 < q <= 1/2 }.

Notation as in :mod:`sphfem.fluid.passes` (``r = x_j - x_i``, ``d = |r|``, ``q = d / R``;
n_i points into the liquid, as SPlisHSPlasH's gradW(x_i - x_j) gives; the signs are the
paper's).

Calibration.  The paper's curvature force gamma m_i (n_i - n_j) is not dimensionally
consistent with its cohesion gamma m_i m_j C (their ratio depends on the unit system), so
the two get separate constants, each fixed by the mechanical tension of a flat interface,
sigma = int (P_N - P_T) dz with the pair virial (Kirkwood-Buff), evaluated as lattice sums
at the run's R / dx (:func:`lattice_tensions`; the continuum half-space integral AKINCI_C is
their limit, ~10 % below the sum at R = 3 dx).  The curvature forces are normal to a flat
interface; they count through the EOS pressure that balances them (the surface layer is
stretched: positive tension).  ``akinci_curvature`` = phi is the share of sigma carried by
the curvature term: gamma for (1 - phi) sigma, gamma_k [m/s^2] for phi sigma
(:func:`akinci_constants`).

Why the former version blew up (2D droplet: speed guard at step 2): gamma_k was gamma
m_bar / R^dim, i.e. the curvature term carried ~70 sigma of tension (20 times the cohesion's
pull on the outer layer, outward), and c0 was chosen for the Laplace pressure sigma / R_drop
while the cohesion's bulk virial pressure (:func:`internal_pressure`) is ~7 sigma / R.

Why phi defaults to 1 (no cohesion): the cohesion is a pair potential; a particle lattice
held by it is an elastic solid with a shear modulus of the order of its internal pressure
~sigma / R, far above the capillary stress sigma / R_drop.  Measured on the 2D droplet of
``sphfem validate droplet-oscillation`` (R_drop = 10 dx, started from rest in the model's
equilibrium): the l = 2 period is 0.39-0.45 of Rayleigh's with phi = 0-0.25 and the drop
keeps a plastic deformation; with phi = 0.9 it is 0.94, with phi = 1 0.95.  The curvature
term depends on the particles only through the colour gradient, which vanishes in the bulk,
so it adds no bulk stiffness.

Adhesion (the paper's adhesion kernel replaced by the cohesion kernel C, so that wall and
liquid interact through the same pair potential): the work of adhesion of that potential is
2 gamma_a rho0^2 R^2 S_c (twice its lattice tension), and Young-Dupre sets it to
sigma (1 + cos theta), theta = ``akinci_contact_angle`` (degrees; unset: no adhesion).
Both tension terms see the wall as vacuum (normals and cohesion over fluid neighbours), so
the solid-liquid tension without adhesion is sigma and the relation holds for any phi.
The wall's repulsion is the wall model's pressure (Adami et al. 2012).

Time step: the capillary limit of :meth:`FluidSolver.dt_limits` with the sigma the
constants represent; weakly compressible runs need rho0 c0^2 >> the largest pressure,
:func:`akinci_c0_pressure` (Laplace plus the cohesion's internal pressure).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numba import njit, prange

from sphfem.fluid.surface import color_gradient
from sphfem.fluid.surface_tension import SurfaceTensionMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param
from sphfem.smallmat import pair_sep

#: default share of sigma carried by the curvature term (``akinci_curvature``; see the
#: module doc: the cohesion makes the particle lattice elastic)
CURVATURE_DEFAULT = 1.0


def _akinci_c(q):
    q = np.asarray(q, float)
    a = (1.0 - q) ** 3 * q**3
    return 32.0 / math.pi * np.where(q > 0.5, a, 2.0 * a - 1.0 / 64.0)


def _akinci_integral(power: int) -> float:
    q = np.linspace(0.0, 1.0, 20001)
    f = _akinci_c(q) * q**power
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


#: continuum half-space tension of the cohesion: sigma = gamma rho0^2 R^2 AKINCI_C[dim]
AKINCI_C = {2: _akinci_integral(3) / 3.0, 3: math.pi / 8.0 * _akinci_integral(4)}
#: bulk virial pressure p = -AKINCI_P[dim] gamma rho0^2 R of the cohesion
#: (p = -(rho0^2 / (2 dim)) int gamma C(r) r dV)
AKINCI_P = {2: 0.5 * math.pi * _akinci_integral(2), 3: 2.0 * math.pi / 3.0 * _akinci_integral(3)}


def _wendland_dwdq(q, dim):
    """dW/dq * R^dim of the Wendland C2 kernel (the fluid's default kernel)."""
    c = 7.0 / math.pi if dim == 2 else 21.0 / (2.0 * math.pi)
    return c * (-20.0 * q * (1.0 - q) ** 3)


@lru_cache(maxsize=32)
def lattice_tensions(dim: int, R_over_dx: float) -> tuple[float, float]:
    """(S_c, S_k): tension of a flat interface per unit gamma rho0^2 R^2 (cohesion) and per
    unit gamma_k rho0 R^2 (curvature term), from the pair sums over a square / cubic lattice
    of spacing dx (a slab 4 R thick, unbounded sideways, normals from the Wendland C2 kernel).

    Mechanical tension of the slab's two faces: 2 sigma = int (P_N - P_T) dz with the pair
    virial P_ab V = sum_{i<j} (x_i - x_j)_a F_ij,b; in equilibrium the EOS pressure cancels
    the normal stress, so the curvature term (forces along the normal) counts through its
    normal stress alone.  Per lattice column (area dx^(dim-1)):

        2 sigma_c = 1/2 sum_l sum_o gamma m^2 C(|o|) (o_x^2 - o_n^2) / |o|
        2 sigma_k = 1/2 sum_l sum_o m gamma_k o_n (n_l - n_(l+o))_n   (paper's sign)

    over the layers l and the offsets o (|o| < R) that stay inside the slab.
    """
    a = int(math.ceil(R_over_dx))
    rng = np.arange(-a, a + 1)
    grids = np.meshgrid(*([rng] * dim), indexing="ij")
    o = np.stack([g.ravel() for g in grids], 1).astype(float)  # in units of dx
    d = np.sqrt((o**2).sum(1))
    keep = (d > 0) & (d < R_over_dx)
    o, d = o[keep], d[keep]
    q = d / R_over_dx
    L = int(math.ceil(4 * R_over_dx))
    # units: dx = 1, R = R_over_dx, rho0 = 1 (m = 1, V = 1)
    R = R_over_dx
    C = _akinci_c(q) / R**dim
    F = -_wendland_dwdq(q, dim) / R**dim / R / d  # grad_i W_ij = F r, r = x_j - x_i
    on = o[:, -1]  # the normal axis (last): layers along it
    nrm = np.zeros(L)
    for lay in range(L):
        ok = (lay + on >= 0) & (lay + on < L)
        nrm[lay] = R * np.sum(F[ok] * on[ok])
    sc = 0.0
    sk = 0.0
    for lay in range(L):
        ok = (lay + on >= 0) & (lay + on < L)
        sc += np.sum(C[ok] * (o[ok, 0] ** 2 - on[ok] ** 2) / d[ok])
        j = (lay + on[ok]).astype(int)
        sk += np.sum(on[ok] * (nrm[lay] - nrm[j]))
    # per face (/2), pairs counted twice (/2); in units rho0^2 R^2 gamma and rho0 R^2 gamma_k
    return 0.25 * sc / R**2, 0.25 * sk / R**2


def akinci_constants(sigma: float, rho0: float, R: float, dx: float, dim: int,
                     share: float = CURVATURE_DEFAULT) -> tuple[float, float]:
    """(gamma, gamma_k) such that the cohesion carries (1 - share) sigma and the curvature
    term share sigma on a lattice of spacing ``dx`` (:func:`lattice_tensions`)."""
    S_c, S_k = lattice_tensions(dim, round(R / dx, 6))
    return ((1.0 - share) * sigma / (rho0 * rho0 * R * R * S_c),
            share * sigma / (rho0 * R * R * S_k))


def akinci_constant(sigma: float, rho0: float, R: float, dim: int) -> float:
    """gamma [m^(dim+1)/(kg s^2)] of the cohesion alone for ``sigma`` [N/m] from the
    continuum half-space integral (the lattice sum of :func:`lattice_tensions` is ~10 %
    above it at R = 3 dx)."""
    return sigma / (rho0 * rho0 * R**2 * AKINCI_C[dim])


def internal_pressure(gamma: float, rho0: float, R: float, dim: int) -> float:
    """Virial pressure [Pa] of the cohesion ``gamma`` in the bulk (negative: tension),
    -AKINCI_P gamma rho0^2 R, of order sigma / R."""
    return -AKINCI_P[dim] * gamma * rho0 * rho0 * R


def akinci_c0_pressure(sigma: float, rho0: float, R: float, dx: float, dim: int,
                       R_drop: float, share: float = CURVATURE_DEFAULT) -> float:
    """The largest pressure [Pa] the model puts on the EOS in a drop of radius ``R_drop``:
    the Laplace pressure plus the cohesion's internal pressure (what rho0 c0^2 must exceed
    ~100-fold for a 1 % density variation)."""
    gamma = akinci_constants(sigma, rho0, R, dx, dim, share)[0]
    return (dim - 1) * sigma / R_drop - internal_pressure(gamma, rho0, R, dim)


def adhesion_ratio(theta_deg: float | None) -> float:
    """(1 + cos theta) / 2: the work of adhesion over the work of cohesion 2 sigma
    (Young-Dupre; None: no adhesion)."""
    if theta_deg is None:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.radians(theta_deg)))


def contact_angle_of_ratio(ratio: float) -> float:
    """Inverse of :func:`adhesion_ratio`: theta [deg]."""
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
    ``nrm`` = R grad C over fluid neighbours (into the liquid), ``gamma_k`` [m/s^2],
    ``gamma_a`` in the units of ``gamma``."""
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
                fk = -K * gamma_k  # the paper's sign: adds tension (module doc)
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


def _share(pa) -> float:
    v = pa.st_params.get("akinci_curvature", getattr(pa, "akinci_curvature", None))
    return CURVATURE_DEFAULT if v is None else float(v)


def _calibrate(pa, m_bar: float, R: float, dim: int):
    """((gamma, gamma_k, gamma_a), the sigma they represent) on the lattice of the mean
    particle spacing dx = (m_bar / rho0)^(1/dim): from the material's sigma, or from
    ``akinci_gamma`` (gamma_k then keeps the share ``akinci_curvature``); gamma_a from the
    contact angle (Young-Dupre, module doc)."""
    dx = (m_bar / pa.rho0) ** (1.0 / dim)
    share = _share(pa)
    S_c, S_k = lattice_tensions(dim, round(R / dx, 6))
    gamma = pa.st_params.get("akinci_gamma", getattr(pa, "akinci_gamma", None))
    if gamma is None:
        gamma, gamma_k = akinci_constants(pa.sigma, pa.rho0, R, dx, dim, share)
        sig = pa.sigma
    else:
        if share >= 1.0:
            raise ValueError("akinci_gamma needs akinci_curvature < 1 (gamma is the cohesion's)")
        sig = gamma * pa.rho0**2 * R**2 * S_c / (1.0 - share)
        gamma_k = share * sig / (pa.rho0 * R * R * S_k)
    # work of adhesion sigma (1 + cos theta) = 2 x the tension of the adhesion pair potential
    gamma_a = sig * adhesion_ratio(_param(pa, "akinci_contact_angle", None)) / (
        pa.rho0**2 * R**2 * S_c)
    return (float(gamma), float(gamma_k), float(gamma_a)), float(sig)


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
                   solver.period, True, state.nrm)
    state.nrm *= R
    gamma, gamma_k, gamma_a = solver.st_constant
    akinci_accel(p.x, p.m, s.V, p.rho, p.kind, nl.offsets, nl.indices, R, gamma, gamma_k,
                 gamma_a, pa.rho0, solver.period, state.nrm, p.acc)
    return state


_WHEN = ("surface_tension", ("akinci",))

METHOD = register(SurfaceTensionMethod(
    name="akinci",
    doc="cohesion + curvature of Akinci et al. (2013) with adhesion to walls; both terms "
        "calibrated to sigma by lattice sums of the flat-interface tension, akinci_curvature "
        "the curvature term's share (default 1: the cohesion makes the particle lattice "
        "elastic), adhesion from the contact angle by Young-Dupre (see "
        "sphfem.fluid.surface_tension_akinci2013)",
    params=(
        Param("akinci_gamma", float, None, positive=True, when=_WHEN,
              doc="Akinci coefficient gamma [m^(dim+1)/(kg s^2)]; unset: computed from the "
                  "material's sigma [N/m]"),
        Param("akinci_curvature", float, CURVATURE_DEFAULT, ge=0.0, le=1.0, when=_WHEN,
              doc="share of sigma carried by the curvature term (0: cohesion only); "
                  "both terms calibrated by lattice sums"),
        Param("akinci_contact_angle", float, None, ge=0.0, le=180.0, when=_WHEN,
              doc="equilibrium contact angle on walls [deg]: wall adhesion gamma_a = gamma "
                  "(1 + cos theta) / 2 (Young-Dupre); unset: no adhesion (180 deg)"),
    ),
    constant_key="akinci_gamma",
    calibrate=_calibrate,
    accelerate=_accelerate,
))
