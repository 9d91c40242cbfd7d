"""Static contact angle through the interface normals at the wall (Breinlinger et al. 2013).

Breinlinger, Polfer, Hashibon & Kraft (2013, J. Comput. Phys. 243, 14) impose the
equilibrium contact angle theta (measured through the liquid) as a boundary condition of
the interface normal: where the free surface meets a wall, the unit normal out of the
liquid is

    n_out = n_w cos theta + t_w sin theta,

n_w the wall normal (out of the wall) and t_w the unit vector in the wall's tangent plane
that points from the liquid across the contact line (theta = 180 deg: n_out = -n_w, a
drop touching the wall at a point; 90 deg: n_out = t_w).  A curvature computed from these
normals is then that of an interface meeting the wall at theta, and the capillary force
drives the contact line towards it.  Here, for every fluid particle i with wall
neighbours (normals pointing *into* the liquid, as the surface-tension passes use them):

    g_w,i = sum_wall V_b grad_i W_ib            (points into the wall: n_w = -g_w / |g_w|)
    t_w   = -(g_i - (g_i . n_w) n_w) / |...|     (the tangential part of the inward normal
                                                  points into the liquid along the wall)
    nu_i  = -(n_w cos theta + t_w sin theta)     (Young's inward normal)
    g_i  <- |g_i| normalise((1 - beta_i) g_i / |g_i| + beta_i nu_i),
    beta_i = smoothstep((|g_w,i| R - a0) / (a1 - a0))

beta fades the condition in with the wall's colour gradient (|g_w| R = 1.26 / 0.68 / 0.23
at 0.5 / 1 / 1.5 dx above a flat 3-layer wall, R = 3 dx: the first layer gets beta = 1, the
second 0), so it acts on the layer along the wall and does not switch abruptly as particles
move.  The magnitude |g_i| is kept.  A particle whose inward normal is along n_w (no
tangential part, e.g. under the middle of a drop when the walls count as liquid) keeps its
normal.  The wall normal comes from the wall particles alone, so any wall shape works.

The interface is also continued into the wall (:func:`young_wall_normals`): each wall
particle next to the surface takes Young's normal, with n_w and t_w averaged over its fluid
neighbours, and the weight of its surface neighbours, so that the curvature of the fluid
particles near the contact line sees the prescribed angle over the whole support, not only
through the first layer.  :func:`young_curvature_normals` does both for a curvature pass
and leaves the surface model's own normals (the force direction) unchanged.

Measured (2D sessile drop, CSF, free-slip wall, :mod:`sphfem.validation.sessile_drop`):
the contact line moves towards theta, but the final angle depends on where it starts
(contact-line hysteresis: 120 deg from a 90 deg start 105.7 deg, from 150 deg 118.5 deg at
R0/dx = 10, Ohnesorge 1); the gap shrinks with resolution (120 deg from 90: 105.7 / 109.3 /
114.1 deg at R0/dx = 10 / 15 / 20), as a pinning force of the order of the pressure over
the contact region (~p R) would.  Some runs lose the first layer at the contact line (it
runs ahead along a free-slip wall, then the drop retracts behind it).

Used by the CSF (``csf_contact_angle``, :mod:`sphfem.fluid.surface_tension_csf`); the
functions take arrays only, so an axisymmetric pass can call them on its own normals.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import grad_factor
from sphfem.kernels import FASTMATH, kernel_f
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import pair_sep

#: the condition fades in with |grad C_wall| R from WALL_LO to WALL_HI (smoothstep)
WALL_LO, WALL_HI = 0.3, 0.9


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def young_normals(x, V, kind, offsets, indices, R, sigma, kernel_code, period, cos_t, sin_t,
                  a0, a1, g, beta, gwall):
    """Rotate the inward normals ``g`` (any magnitude, kept) of fluid rows near walls
    towards Young's direction for the contact angle with cosine/sine ``cos_t``/``sin_t``
    (module doc); ``beta`` receives the blend weight of every row (0 away from walls and on
    other rows), ``gwall`` (n, 3) every row's wall colour gradient g_w,i (0 on other rows),
    which :func:`young_wall_normals` reuses."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        beta[i] = 0.0
        gwall[i, 0] = 0.0
        gwall[i, 1] = 0.0
        gwall[i, 2] = 0.0
        if kind[i] != FLUID:
            continue
        w0 = 0.0
        w1 = 0.0
        w2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != WALL:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            t = V[j] * grad_factor(np.sqrt(d2), R, fac2, kernel_code)
            w0 += t * r0
            w1 += t * r1
            w2 += t * r2
        gwall[i, 0] = w0
        gwall[i, 1] = w1
        gwall[i, 2] = w2
        wn = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        a = (wn * R - a0) / (a1 - a0)
        if a <= 0.0:
            continue
        b = 1.0 if a >= 1.0 else a * a * (3.0 - 2.0 * a)
        nw0 = -w0 / wn
        nw1 = -w1 / wn
        nw2 = -w2 / wn
        g0 = g[i, 0]
        g1 = g[i, 1] if dim > 1 else 0.0
        g2 = g[i, 2] if dim > 2 else 0.0
        gn = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
        if gn == 0.0:
            continue
        gw = g0 * nw0 + g1 * nw1 + g2 * nw2
        t0 = g0 - gw * nw0
        t1 = g1 - gw * nw1
        t2 = g2 - gw * nw2
        tn = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if tn <= 1e-6 * gn:  # normal along the wall normal: no contact-line direction
            continue
        beta[i] = b
        # Young's inward normal -(n_w cos + t_w sin), t_w = -t / |t|
        m0 = (1.0 - b) * g0 / gn + b * (-nw0 * cos_t + t0 / tn * sin_t)
        m1 = (1.0 - b) * g1 / gn + b * (-nw1 * cos_t + t1 / tn * sin_t)
        m2 = (1.0 - b) * g2 / gn + b * (-nw2 * cos_t + t2 / tn * sin_t)
        mn = np.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if mn == 0.0:
            continue
        g[i, 0] = gn * m0 / mn
        if dim > 1:
            g[i, 1] = gn * m1 / mn
        if dim > 2:
            g[i, 2] = gn * m2 / mn


def apply_young_normals(solver, g: np.ndarray, theta_deg: float,
                        beta: np.ndarray | None = None) -> np.ndarray:
    """:func:`young_normals` on the solver's particles and list for the angle
    ``theta_deg``; returns ``beta``."""
    p, nl = solver.p, solver.nbrs
    if beta is None or beta.shape[0] != p.n:
        beta = np.zeros(p.n)
    th = math.radians(theta_deg)
    young_normals(p.x, solver._scratch.V, p.kind, nl.offsets, nl.indices, solver.R,
                  solver.sigma, solver.kernel_code, solver.period, math.cos(th), math.sin(th),
                  WALL_LO, WALL_HI, g, beta, np.zeros((p.n, 3)))
    return beta


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def young_wall_normals(x, V, kind, offsets, indices, R, sigma, kernel_code, period, cos_t,
                       sin_t, g, omega, gwall, g_out, omega_out):
    """Young's inward normals on the wall rows next to a free surface (the interface
    continued into the wall at theta): for wall row b, from its fluid neighbours f,

        n_w = normalise(sum_f W_bf n_w,f)   (n_w,f = -grad_f C_wall / |...|, out of the wall)
        t   = -tangential part of sum_f omega_f W_bf g_f / |g_f|, normalised
        g_out[b] = -(n_w cos theta + t sin theta),
        omega_out[b] = sum_f omega_f V_f W_bf / sum_f V_f W_bf;

    fluid rows copy ``g`` and ``omega``; other rows get 0.  ``gwall``: the fluid rows'
    wall colour gradients grad_f C_wall of :func:`young_normals`."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for b in prange(n):
        for k in range(dim):
            g_out[b, k] = g[b, k] if kind[b] == FLUID else 0.0
        omega_out[b] = omega[b] if kind[b] == FLUID else 0.0
        if kind[b] != WALL:
            continue
        s = 0.0
        so = 0.0
        w0 = 0.0
        w1 = 0.0
        w2 = 0.0
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        for jj in range(offsets[b], offsets[b + 1]):
            f = indices[jj]
            if kind[f] != FLUID:
                continue
            r0, r1, r2 = pair_sep(x, b, f, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2:
                continue
            w = V[f] * sigma * kernel_f(np.sqrt(d2) / R, kernel_code)
            s += w
            # the fluid particle's wall normal: -grad_f C_wall (out of the wall)
            c0 = -gwall[f, 0]
            c1 = -gwall[f, 1]
            c2 = -gwall[f, 2]
            cn = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            if cn > 0.0:
                w0 += w * c0 / cn
                w1 += w * c1 / cn
                w2 += w * c2 / cn
            if omega[f] > 0.0:
                gf0 = g[f, 0]
                gf1 = g[f, 1] if dim > 1 else 0.0
                gf2 = g[f, 2] if dim > 2 else 0.0
                gn = np.sqrt(gf0 * gf0 + gf1 * gf1 + gf2 * gf2)
                if gn > 0.0:
                    so += omega[f] * w
                    m0 += omega[f] * w * gf0 / gn
                    m1 += omega[f] * w * gf1 / gn
                    m2 += omega[f] * w * gf2 / gn
        wn = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        if s <= 0.0 or so <= 0.0 or wn <= 0.0:
            continue
        nw0 = w0 / wn
        nw1 = w1 / wn
        nw2 = w2 / wn
        mw = m0 * nw0 + m1 * nw1 + m2 * nw2
        t0 = m0 - mw * nw0
        t1 = m1 - mw * nw1
        t2 = m2 - mw * nw2
        tn = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if tn <= 1e-6 * so:
            continue
        g_out[b, 0] = -nw0 * cos_t + t0 / tn * sin_t
        if dim > 1:
            g_out[b, 1] = -nw1 * cos_t + t1 / tn * sin_t
        if dim > 2:
            g_out[b, 2] = -nw2 * cos_t + t2 / tn * sin_t
        omega_out[b] = so / s


class YoungNormals:
    """Work arrays of :func:`young_curvature_normals`: the normals ``g`` and weights
    ``omega`` the curvature is computed from (fluid rows: the surface model's, turned to
    Young's direction along walls; wall rows next to the surface: Young's normal and the
    weight of their surface neighbours), the fluid rows' blend weights ``beta``."""

    def __init__(self, n: int, dim: int):
        self.n = n
        self.g0 = np.zeros((n, dim))
        self.g = np.zeros((n, dim))
        self.omega = np.zeros(n)
        self.beta = np.zeros(n)
        self.gwall = np.zeros((n, 3))


def young_curvature_normals(solver, g: np.ndarray, omega: np.ndarray, theta_deg: float,
                            state: YoungNormals | None = None) -> YoungNormals:
    """Normals and weights for a curvature pass with the contact angle ``theta_deg``
    (module doc): ``g`` (inward colour gradients) and ``omega`` (normal weights, 0 on
    wall rows) of the surface model are left unchanged; fluid rows along walls get Young's
    direction (:func:`young_normals`), wall rows next to the surface Young's normal with
    the weight of their surface neighbours (:func:`young_wall_normals`)."""
    p, nl = solver.p, solver.nbrs
    if state is None or state.n != p.n:
        state = YoungNormals(p.n, solver.dim)
    th = math.radians(theta_deg)
    c, s = math.cos(th), math.sin(th)
    state.g0[:] = g
    young_normals(p.x, solver._scratch.V, p.kind, nl.offsets, nl.indices, solver.R,
                  solver.sigma, solver.kernel_code, solver.period, c, s, WALL_LO, WALL_HI,
                  state.g0, state.beta, state.gwall)
    young_wall_normals(p.x, solver._scratch.V, p.kind, nl.offsets, nl.indices, solver.R,
                       solver.sigma, solver.kernel_code, solver.period, c, s, state.g0, omega,
                       state.gwall, state.g, state.omega)
    return state
