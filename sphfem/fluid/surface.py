"""Surface tension, free-surface detection and particle shifting (issue 4, part 2).

Notation as in :mod:`sphfem.fluid.passes`: ``r = x_j - x_i``, ``d = |r|``, ``q = d / R``,
``grad_i W_ij = F r`` with ``F = -W'(d)/d >= 0``.  Every pass is a gather over fluid rows
of the fluid's filtered neighbour view (fluid rows hold fluid and wall neighbours).

Surface tension, two models (both act between fluid particles only; no wall adhesion):

* ``iif`` -- the inter-particle interaction force of Tartakovsky & Meakin (2005) with the
  mass weighting of Park (2019) eq. 2.78.  The pair force on i from j is

      F_ij = s w_ij cos(3 pi d / (2 R)) e_ji,    d <= R,   e_ji = (x_i - x_j)/d,

  repulsive for d < R/3, attractive for R/3 < d < R.  The thesis prints the weight
  2 m_i/(m_i + m_j), which makes F_ij != -F_ji for unequal masses (it is the pair
  *accelerations* that are then opposite); we use the symmetric weight
  w_ij = 2 m_i m_j / ((m_i + m_j) m_bar) (m_bar: mean fluid particle mass), which equals
  the thesis' weight for equal masses and conserves linear and angular momentum exactly.
  ``s`` [N] is the calibration constant of the model (the "1e6 N" of the thesis' droplet
  case), *not* the surface tension sigma [N/m].  Calibration (:func:`iif_constant`): for
  a pair force f(d) (repulsive > 0) between particles of number density n = rho0/m_bar,
  cutting a uniform fluid along a plane costs the energy per area 2 sigma =
  -n^2 int_{z>0} z phi(|r|) d^d r (phi the pair potential, f = -phi').  Integrating by
  parts,

      sigma_3D = -(pi/8) n^2 int_0^R f(d) d^4 dd,   sigma_2D = -(1/3) n^2 int_0^R f(d) d^3 dd,

  so sigma = s n^2 R^(d+2) c_d with c_3D = -(pi/8) int_0^1 cos(3 pi q/2) q^4 dq and
  c_2D = -(1/3) int_0^1 cos(3 pi q/2) q^3 dq (:data:`IIF_C`).  This is the half-space
  (Kirkwood-Buff, uniform pair distribution) estimate; it is checked against the Laplace
  pressure jump of static droplets in the tests and against Rayleigh's oscillation period
  in ``sphfem validate droplet-oscillation``.

* ``akinci`` -- cohesion + curvature of Akinci, Akinci & Teschner (2013):

      a_i = sum_j K_ij [ -gamma m_j C(d) (x_i - x_j)/d - gamma (m_bar/R^dim) (n_i - n_j) ],
      K_ij = 2 rho0 / (rho_i + rho_j),   n_i = R sum_j V_j grad_i W_ij,
      C(d) = (32/pi) R^-dim { (1-q)^3 q^3            if 1/2 < q <= 1
                              2 (1-q)^3 q^3 - 1/64   if 0 < q <= 1/2 }.

  The paper's curvature force gamma m_i (n_i - n_j) is not dimensionally consistent with
  its cohesion force gamma m_i m_j C; the factor m_bar / R^dim (mean particle mass per
  support volume, the scale of m_j C) makes both terms accelerations for one gamma
  [m^(dim+1)/(kg s^2)].  Calibration (:func:`akinci_constant`): gamma from sigma
  by the half-space integral of the cohesion term alone (with K = 1); the curvature term,
  which vanishes on a flat interface at rest in the continuum limit but adds a
  curvature-dependent force, is not in the calibration -- the droplet validation reports
  the resulting error.

  Not recommended: in the 2D droplet of ``sphfem validate droplet-oscillation`` (full run)
  it stops on the speed guard within the first few steps; the cause (the normalisation of
  the cohesion kernel or the scaling of the curvature term above) has not been isolated.
  ``iif`` is stable but responds elasto-plastically (period off by ~40 % in 3D).  Use
  ``csf`` (:mod:`sphfem.fluid.surface_tension_csf`), which passes the droplet and Laplace
  checks.

Free surface (Marrone et al. 2010): lambda_i, the smallest eigenvalue of the moment matrix
M_i = sum_j V_j r (x) grad_i W_ij (= I in the bulk), over fluid and wall neighbours;
lambda <= 0.2: free surface; 0.2 < lambda <= 0.75: free surface unless a neighbour lies
in the scan region (the cone of half-angle 45 degrees about the outward normal within
sqrt(2) h of x_i, or the ball of radius h around x_T = x_i + h n beyond it; h = R/2);
lambda > 0.75: interior.  The outward normal is n = -B grad C / |B grad C|, B = M^-1
(-grad C / |grad C| where M is singular), grad C_i = sum_j V_j grad_i W_ij.

Shifting (Skillen et al. 2013 / Xu & Yu 2018; Park 2019 sec. 2.1.6 with A = 5/3):

    dr_i = -A h |v_i| dt grad C_i,

projected on the tangent plane, dr <- (I - n n) dr, for free-surface particles and for
particles with a free-surface neighbour ("near surface", Sun et al. 2017), and capped at
0.1 h.  The density follows the shift with the renormalised gradient, rho += grad rho . dr
(velocities are not corrected).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import _F, FASTMATH, _invert, _sep
from sphfem.particles import FLUID, WALL


def _iif_integral(power: int) -> float:
    q = np.linspace(0.0, 1.0, 20001)
    f = np.cos(1.5 * math.pi * q) * q**power
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


#: sigma = s n^2 R^(dim+2) IIF_C[dim] (half-space integral of the IIF pair force)
IIF_C = {2: -_iif_integral(3) / 3.0, 3: -math.pi / 8.0 * _iif_integral(4)}


def iif_constant(sigma: float, rho0: float, m_bar: float, R: float, dim: int) -> float:
    """Calibration constant s [N] of the IIF model for the surface tension ``sigma`` [N/m]."""
    n = rho0 / m_bar
    return sigma / (n * n * R ** (dim + 2) * IIF_C[dim])


def iif_sigma(s: float, rho0: float, m_bar: float, R: float, dim: int) -> float:
    """Inverse of :func:`iif_constant`: the surface tension [N/m] of constant ``s`` [N]."""
    n = rho0 / m_bar
    return s * n * n * R ** (dim + 2) * IIF_C[dim]


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


def akinci_constant(sigma: float, rho0: float, R: float, dim: int) -> float:
    """gamma [m^(dim+1)/(kg s^2)] of the Akinci model for ``sigma`` [N/m] (cohesion only)."""
    return sigma / (rho0 * rho0 * R**2 * AKINCI_C[dim])


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def iif_accel(x, m, kind, offsets, indices, R, s, m_bar, period, acc):
    """acc[i] += sum_j F_ij / m_i of the IIF model (fluid-fluid pairs within R)."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    c = 1.5 * math.pi / R
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        mi = m[i]
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            mj = m[j]
            w = 2.0 * mj / ((mi + mj) * m_bar)  # (2 m_i m_j/((m_i+m_j) m_bar)) / m_i
            f = -s * w * np.cos(c * d) / d  # along r = x_j - x_i: minus e_ji
            a0 += f * r0
            a1 += f * r1
            a2 += f * r2
        acc[i, 0] += a0
        if dim > 1:
            acc[i, 1] += a1
        if dim > 2:
            acc[i, 2] += a2


@njit(cache=True, inline="always", fastmath=FASTMATH)
def color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kkind, period, periodic,
                       only_fluid):
    """grad C_i = sum_j V_j grad_i W_ij over the fluid (``only_fluid``) or fluid and wall
    neighbours of row ``i``, as three components (the unused ones 0)."""
    dim = x.shape[1]
    R2 = R * R
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    for jj in range(offsets[i], offsets[i + 1]):
        j = indices[jj]
        if kind[j] != FLUID and (only_fluid or kind[j] != WALL):
            continue
        r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        if d2 >= R2 or d2 == 0.0:
            continue
        t = V[j] * _F(np.sqrt(d2), R, fac2, kkind)
        g0 += t * r0
        g1 += t * r1
        g2 += t * r2
    return g0, g1, g2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def color_gradient(x, V, kind, offsets, indices, R, sigma, kkind, period, only_fluid, gc):
    """grad C_i = sum_j V_j grad_i W_ij over fluid rows (``only_fluid``: fluid neighbours
    only, else fluid and wall neighbours); other rows are zeroed."""
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
            g0, g1, g2 = color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kkind,
                                            period, periodic, only_fluid)
        gc[i, 0] = g0
        if dim > 1:
            gc[i, 1] = g1
        if dim > 2:
            gc[i, 2] = g2


@njit(cache=True, inline="always")
def _akinci_shape(q):
    a = (1.0 - q) * (1.0 - q) * (1.0 - q) * q * q * q
    if q > 0.5:
        return 32.0 / math.pi * a
    return 32.0 / math.pi * (2.0 * a - 1.0 / 64.0)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def akinci_accel(x, m, rho, kind, offsets, indices, R, gamma, rho0, m_bar, period, nrm, acc):
    """acc[i] += Akinci cohesion + curvature (``nrm`` = R grad C over fluid neighbours)."""
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
            if kind[j] != FLUID:
                continue
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            K = 2.0 * rho0 / (ri + rho[j])
            # cohesion: -gamma m_j C (x_i - x_j)/d = +gamma m_j C r/d
            fc = K * gamma * m[j] * _akinci_shape(d / R) / (Rd * d)
            fk = -K * gamma * m_bar / Rd
            a0 += fc * r0 + fk * (ni0 - nrm[j, 0])
            if dim > 1:
                a1 += fc * r1 + fk * (ni1 - nrm[j, 1])
            if dim > 2:
                a2 += fc * r2 + fk * (ni2 - nrm[j, 2])
        acc[i, 0] += a0
        if dim > 1:
            acc[i, 1] += a1
        if dim > 2:
            acc[i, 2] += a2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def free_surface(x, V, kind, offsets, indices, R, sigma, kkind, period, cond_max, gc, nrm,
                 lam, flag):
    """Marrone et al. (2010) detection: ``lam`` (smallest eigenvalue of M), outward unit
    normal ``nrm``, colour gradient ``gc`` (fluid and wall neighbours) and ``flag``
    (0 interior, 1 free surface) of every fluid particle; other rows are zeroed."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    h = 0.5 * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    cos45 = math.sqrt(0.5)
    for i in prange(n):
        for k in range(dim):
            gc[i, k] = 0.0
            nrm[i, k] = 0.0
        lam[i] = 1.0
        flag[i] = 0
        if kind[i] != FLUID:
            continue
        M = np.zeros((3, 3))
        g = np.zeros(3)
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            s = V[j] * _F(np.sqrt(d2), R, fac2, kkind)
            rr = (r0, r1, r2)
            for p in range(dim):
                g[p] += s * rr[p]
                for q in range(dim):
                    M[p, q] += s * rr[p] * rr[q]
        for k in range(dim):
            gc[i, k] = g[k]
        # smallest eigenvalue of the symmetric dim x dim M
        if dim == 1:
            lmin = M[0, 0]
        elif dim == 2:
            tr = M[0, 0] + M[1, 1]
            df = M[0, 0] - M[1, 1]
            lmin = 0.5 * tr - 0.5 * np.sqrt(df * df + 4.0 * M[0, 1] * M[0, 1])
        else:
            lmin = np.linalg.eigvalsh(M)[0]
        lam[i] = lmin
        Bi = np.empty((3, 3))
        nv = np.zeros(3)
        if _invert(M, dim, Bi, cond_max):
            for p in range(dim):
                for q in range(dim):
                    nv[p] -= Bi[p, q] * g[q]
        else:
            for p in range(dim):
                nv[p] = -g[p]
        nn = 0.0
        for p in range(dim):
            nn += nv[p] * nv[p]
        nn = np.sqrt(nn)
        if nn > 0.0:
            for p in range(dim):
                nv[p] /= nn
                nrm[i, p] = nv[p]
        if lmin <= 0.2:
            flag[i] = 1
            continue
        if lmin > 0.75 or nn == 0.0:
            continue
        # scan region: is any neighbour inside the umbrella above x_i?
        covered = False
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            proj = r0 * nv[0] + r1 * nv[1] + r2 * nv[2]
            if d >= math.sqrt(2.0) * h:
                t0 = r0 - h * nv[0]
                t1 = r1 - h * nv[1]
                t2 = r2 - h * nv[2]
                if t0 * t0 + t1 * t1 + t2 * t2 < h * h:
                    covered = True
                    break
            elif proj > cos45 * d:
                covered = True
                break
        if not covered:
            flag[i] = 1


@njit(cache=True, parallel=True)
def near_surface(kind, offsets, indices, flag, x, R, period, near):
    """near[i] = True for fluid particles that are free-surface particles or have one
    within R."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        near[i] = flag[i] == 1
        if kind[i] != FLUID or near[i]:
            continue
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if flag[j] != 1:
                continue
            r0, r1, r2 = _sep(x, i, j, dim, period, periodic)
            if r0 * r0 + r1 * r1 + r2 * r2 < R2:
                near[i] = True
                break


@njit(cache=True, parallel=True)
def shift(x, v, rho, kind, gc, nrm, near, grad_rho, coef, dt, max_shift, project_surface,
          out):
    """Apply dr = -coef |v| dt grad C (projected on the tangent plane where ``near``
    when ``project_surface``, skipped there otherwise), capped at ``max_shift``; the
    density follows with grad rho . dr.  ``out[i]`` receives |dr|."""
    n, dim = x.shape
    for i in prange(n):
        out[i] = 0.0
        if kind[i] != FLUID:
            continue
        if near[i] and not project_surface:
            continue
        sp = 0.0
        for k in range(dim):
            sp += v[i, k] * v[i, k]
        D = coef * np.sqrt(sp) * dt
        dr = np.zeros(3)
        for k in range(dim):
            dr[k] = -D * gc[i, k]
        if near[i]:
            pn = 0.0
            for k in range(dim):
                pn += dr[k] * nrm[i, k]
            for k in range(dim):
                dr[k] -= pn * nrm[i, k]
        L = 0.0
        for k in range(dim):
            L += dr[k] * dr[k]
        L = np.sqrt(L)
        if L > max_shift:
            for k in range(dim):
                dr[k] *= max_shift / L
            L = max_shift
        drho = 0.0
        for k in range(dim):
            x[i, k] += dr[k]
            drho += grad_rho[i, k] * dr[k]
        rho[i] += drho
        out[i] = L
