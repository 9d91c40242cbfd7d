"""Colour gradient, free-surface detection and particle shifting (issue 4, part 2).

Notation as in :mod:`sphfem.fluid.passes`: ``r = x_j - x_i``, ``d = |r|``, ``q = d / R``,
``grad_i W_ij = F r`` with ``F = -W'(d)/d >= 0``.  Every pass is a gather over fluid rows
of the fluid's filtered neighbour view (fluid rows hold fluid and wall neighbours).
The surface-tension methods are in their own modules, chosen through the registry
:mod:`sphfem.fluid.surface_tension`.

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

from sphfem import kernels
from sphfem.fluid.passes import grad_factor
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import invert3, pair_sep


@njit(cache=True, inline="always", fastmath=FASTMATH)
def color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kernel_code, period, periodic,
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
        r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
        d2 = r0 * r0 + r1 * r1 + r2 * r2
        if d2 >= R2 or d2 == 0.0:
            continue
        t = V[j] * grad_factor(np.sqrt(d2), R, fac2, kernel_code)
        g0 += t * r0
        g1 += t * r1
        g2 += t * r2
    return g0, g1, g2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def color_gradient(x, V, kind, offsets, indices, R, sigma, kernel_code, period, only_fluid, gc):
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
            g0, g1, g2 = color_gradient_row(i, x, V, kind, offsets, indices, R, fac2, kernel_code,
                                            period, periodic, only_fluid)
        gc[i, 0] = g0
        if dim > 1:
            gc[i, 1] = g1
        if dim > 2:
            gc[i, 2] = g2


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def free_surface(x, V, kind, offsets, indices, R, sigma, kernel_code, period, cond_max, gc, nrm,
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
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            s = V[j] * grad_factor(np.sqrt(d2), R, fac2, kernel_code)
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
        if invert3(M, dim, Bi, cond_max):
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
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
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
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            if r0 * r0 + r1 * r1 + r2 * r2 < R2:
                near[i] = True
                break


@njit(cache=True, parallel=True)
def shift_displacement(x, v, kind, gc, nrm, near, coef, dt, max_shift, project_surface,
                       v_floor, speed, dr):
    """The particle shift dr = -coef max(|v|, ``v_floor``) dt grad C into ``dr`` (projected
    on the tangent plane where ``near`` when ``project_surface``, 0 there otherwise; 0 on
    non-fluid rows), capped at ``max_shift``; :func:`apply_shift` moves the particles.
    ``v_floor`` = the largest fluid speed gives every particle the shift of the fastest
    one (Sun et al. 2017's Ma-scaled shift), so slow regions (stagnation points) are
    regularised too.  A non-empty ``speed`` (one entry per particle) replaces |v_i|: the
    Galilean-invariant strain speed of :func:`strain_speed`."""
    n, dim = x.shape
    own = speed.shape[0] == 0
    for i in prange(n):
        for k in range(dim):
            dr[i, k] = 0.0
        if kind[i] != FLUID:
            continue
        if near[i] and not project_surface:
            continue
        if own:
            sp = 0.0
            for k in range(dim):
                sp += v[i, k] * v[i, k]
            sp = np.sqrt(sp)
        else:
            sp = speed[i]
        D = coef * max(sp, v_floor) * dt
        for k in range(dim):
            dr[i, k] = -D * gc[i, k]
        if near[i]:
            pn = 0.0
            for k in range(dim):
                pn += dr[i, k] * nrm[i, k]
            for k in range(dim):
                dr[i, k] -= pn * nrm[i, k]
        L = 0.0
        for k in range(dim):
            L += dr[i, k] * dr[i, k]
        L = np.sqrt(L)
        if L > max_shift:
            for k in range(dim):
                dr[i, k] *= max_shift / L


@njit(cache=True, parallel=True)
def apply_shift(x, rho, grad_rho, dr, max_shift, out):
    """x_i += dr_i (|dr_i| capped at ``max_shift``), rho_i += grad rho_i . dr_i (the density
    interpolated to the new place), ``out[i]`` = |dr_i|; rows of ``x``."""
    n, dim = x.shape
    for i in prange(n):
        L = 0.0
        for k in range(dim):
            L += dr[i, k] * dr[i, k]
        L = np.sqrt(L)
        f = max_shift / L if L > max_shift else 1.0
        drho = 0.0
        for k in range(dim):
            x[i, k] += f * dr[i, k]
            drho += grad_rho[i, k] * f * dr[i, k]
        rho[i] += drho
        out[i] = f * L


@njit(cache=True, parallel=True)
def remove_local_mean(dr, x, liquid, offsets, indices, Rp, kcode, period, n, out):
    """out_i = dr_i - <dr>_i for the ``liquid`` rows i < ``n`` (those the shift left alone,
    dr_i = 0, included: they move against their neighbourhood's drift), <dr>_i = sum_j w_ij
    dr_j / sum_j w_ij the kernel-weighted mean over the ``liquid`` neighbours j != i within
    the pair support (R_i + R_j) / 2 (w = the kernel's shape f(d / R_ij); i itself is left
    out, so a particle-scale disorder keeps its whole shift; no neighbour: dr_i kept).
    Rows of ``dr``, ``x``, ``liquid`` and ``Rp`` run over the listed set, mirrors included;
    ``period``: 0 on open axes.  The shift then only rearranges the particles among their
    neighbours: a displacement shared by a whole neighbourhood, such as the drift of a thin
    film's particles towards its end along grad C, is taken out (``[fluid] shifting_drift =
    "removed"``)."""
    dim = x.shape[1]
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        for k in range(dim):
            out[i, k] = dr[i, k]
        if not liquid[i]:
            continue
        s = np.zeros(3)
        sw = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if j == i or not liquid[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            R = 0.5 * (Rp[i] + Rp[j])
            if d >= R:
                continue
            w = kernels.kernel_f(d / R, kcode)
            for k in range(dim):
                s[k] += w * dr[j, k]
            sw += w
        if sw > 0.0:
            for k in range(dim):
                out[i, k] = dr[i, k] - s[k] / sw


#: the ``speed`` of :func:`shift_displacement` that selects each particle's own |v_i|
OWN_SPEED = np.empty(0)


@njit(cache=True)
def strain_speed(h, L, out):
    """out_i = h_i |S_i|, |S| = sqrt(S_ab S_ab) the norm of the strain rate S = (L + L^T) / 2
    of the velocity gradient L_i (rows of ``L``: L00, L01, L10, L11 in 2D).  The speed of
    the shifting law that depends on the motion relative to the neighbours only (no
    rotation, no translation), so a film carried at speed is shifted no more than one at
    rest, and the shift velocity A h |S| h grad C vanishes as h^2 in the bulk and as h at
    a surface with refinement."""
    for i in range(out.shape[0]):
        s01 = 0.5 * (L[i, 1] + L[i, 2])
        out[i] = h[i] * math.sqrt(L[i, 0] ** 2 + L[i, 3] ** 2 + 2.0 * s01 * s01)


def shift_floor_speed(v, kind, mode: str) -> float:
    """The ``v_floor`` of :func:`shift_displacement` for the scene key ``[fluid] shifting_speed``:
    0 for "local" (each particle's own |v|) and "strain" (:func:`strain_speed`), the
    largest fluid speed for "max"."""
    if mode in ("local", "strain"):
        return 0.0
    if mode != "max":
        raise ValueError(f"[fluid] shifting_speed must be 'local', 'max' or 'strain', got "
                         f"{mode!r}")
    f = np.asarray(kind) == FLUID
    if not f.any():
        return 0.0
    return float(np.sqrt((np.asarray(v)[f] ** 2).sum(axis=1).max()))
