"""Wall friction of a viscous layer thinner than the particle spacing (``[fluid] wall_friction
= "layer"``).

An SPH no-slip wall (Adami et al. 2012 ghost velocity, Morris et al. 1997 viscous term) gives
a fluid sliding at U over the wall the traction of a layer about half a spacing thick: for a
uniform plug on a lattice of spacing dx the summed wall term is exactly

    tau_sph = S mu U / dx,                                                         (1)

S a lattice constant of the kernel and support (:func:`plug_traction_constant`: 1.68 for
Wendland C2 with R = 3 dx).  The real layer is thinner while the flow is young or strained
(a droplet's lamella: ~1 um at 10 m/s against dx = 1.5-6 um), so the wall term alone
under-brakes the fluid, and an artificial viscosity acting on wall pairs (alpha h c0, ~ h)
brakes it by an amount set by the resolution instead.

Model: each fluid particle within a kernel support of the wall carries the shear thickness
delta of its wall layer (tau_w = mu U / delta), evolved by the integral balance of an unsteady
layer stretched by the flow along the wall,

    d(delta^2)/dt = pi nu - 2 a delta^2,       a = div_s u_t = div u - n . (grad u) n,   (2)

a the surface divergence of the tangential velocity (axisymmetric: div u includes u_r / r),
n the wall normal.  It is exact for Stokes' first problem (a = 0: delta = sqrt(pi nu t),
tau = mu U / sqrt(pi nu t); Schlichting & Gersten 2017, sec. 5.3.1); for the steady
axisymmetric stagnation flow (a = 2 a_H) it gives delta = 0.886 sqrt(nu / a_H) against
Homann's (1936) 0.762 sqrt(nu / a_H) (the traction 14 % low); for a lamella expanding as
u_r = r / t (a = 2 / t; Roisman 2009) delta = 0.793 sqrt(nu t) against the similarity
layer's 0.966 sqrt(nu t) (22 % high).  The wall term of particle i is multiplied by

    f_i = max(1, dx / (S delta_i)),                                                  (3)

so a plug feels tau = mu U / delta (1) while the layer is unresolved, and the plain no-slip
wall term once delta > dx / S (f -> 1 as dx -> 0: the model switches itself off under
refinement).  The wall pairs then carry no artificial viscosity.  A particle entering the
band takes the kernel average of delta^2 over its band neighbours (the layer is continuous);
leaving it, it forgets its layer.  Over a step delta^2 is floored at its time average from
zero, pi nu dt / 4, and f is capped by the viscous step limit (f <= visc_cfl h^2 / (nu dt)).

Contact line.  Eq. (2) describes the layer under a film sliding along the wall; at the end
of a wall row (an advancing contact line) the liquid rolls onto the wall rather than
sliding over it, and the rings there are the youngest of the band: with eq. (3) they are
braked hardest.  In the 10 m/s droplet impact (docs/validation/droplet_impact, sessions 16
and 18) this stalls the lamella's tip and the fluid behind it rides up into a vertical
sheet (from 1.25 t_c at D/dx 181, 1.5-1.75 t_c at 128), which the plain wall term
(``"viscous"``) does not do.  So the factor is lifted towards 1 on the rows at the end of
their wall row (:func:`contact_line_weight`: the one-sidedness of the ring's neighbours in
its own layer along the wall, 1 at a row's end, 0 one ring behind it on a lattice): f_i <-
1 + (f_i - 1)(1 - w_i).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sphfem import kernels
from sphfem.particles import FLUID
from sphfem.smallmat import pair_sep


def plug_traction_constant(kernel: str, support_factor: float, eps_visc: float = 0.0) -> float:
    """S of eq. (1): the summed Morris wall term on a uniform plug over a flat no-slip wall of
    three or more layers, tau = S mu U / dx, for a square lattice of spacing dx (planar kernel
    sums; ghost velocity -U; the regulariser eps_visc h^2 included)."""
    kc = kernels.kernel_code(kernel)
    R = float(support_factor)
    if not R > 0:
        raise ValueError(f"support_factor must be positive, got {support_factor}")
    s2 = kernels.kernel_sigma(kc, 2, R) * R * R
    n = int(math.ceil(R)) + 1
    h = 0.5 * R
    tot = 0.0
    for iy in range(n):
        yi = iy + 0.5
        for jy in range(n):
            yj = -(jy + 0.5)
            for jx in range(-n - 1, n + 2):
                d2 = jx * jx + (yj - yi) ** 2
                d = math.sqrt(d2)
                if d >= R:
                    continue
                F = -s2 / R**3 * kernels.kernel_dfdq(d / R, kc) / d
                tot += F * d2 / (d2 + eps_visc * h * h)
    return 4.0 * tot


@njit(cache=True)
def _pair_weight(x, Rp, i, j, kcode):
    """Kernel shape f(d / R_ij) of the pair (0 beyond the pair support R_ij = (R_i + R_j) /
    2)."""
    r0 = x[j, 0] - x[i, 0]
    r1 = x[j, 1] - x[i, 1]
    R = 0.5 * (Rp[i] + Rp[j])
    d = math.sqrt(r0 * r0 + r1 * r1)
    return kernels.kernel_f(d / R, kcode) if d < R else 0.0


@njit(cache=True)
def band_normals(x, kind, offsets, indices, Rp, nrm, kcode, n_real, out_nrm, out_band):
    """For the real FLUID rows: ``out_band[i]`` = 1 when a wall row (kind WALL, or an axis
    mirror of one, kind > 1 with a nonzero normal) lies within the pair support, and
    ``out_nrm[i]`` the kernel-weighted unit mean of those walls' normals ``nrm`` (rows over
    the augmented set)."""
    for i in range(n_real):
        out_band[i] = 0
        out_nrm[i, 0] = 0.0
        out_nrm[i, 1] = 0.0
        if kind[i] != FLUID:
            continue
        s0 = 0.0
        s1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] == FLUID or (nrm[j, 0] == 0.0 and nrm[j, 1] == 0.0):
                continue
            w = _pair_weight(x, Rp, i, j, kcode)
            s0 += w * nrm[j, 0]
            s1 += w * nrm[j, 1]
        nn = math.sqrt(s0 * s0 + s1 * s1)
        if nn > 0.0:
            out_band[i] = 1
            out_nrm[i, 0] = s0 / nn
            out_nrm[i, 1] = s1 / nn


@njit(cache=True)
def surface_divergence(gradv, hoop_rate, nrm, band, out):
    """a_i of eq. (2) for the band rows: tr L + u_r / r - n . L n, L_ab = d v_a / d x_b stored
    as ``gradv[i] = (L00, L01, L10, L11)``, ``hoop_rate[i]`` = u_r / r (0 in planar flow)."""
    for i in range(out.shape[0]):
        out[i] = 0.0
        if band[i] == 0:
            continue
        L00, L01, L10, L11 = gradv[i, 0], gradv[i, 1], gradv[i, 2], gradv[i, 3]
        n0, n1 = nrm[i, 0], nrm[i, 1]
        out[i] = (L00 + L11 + hoop_rate[i]
                  - (n0 * n0 * L00 + n0 * n1 * (L01 + L10) + n1 * n1 * L11))


#: the contact-line weight rises from 0 to 1 as the wall row's one-sidedness s goes over
#: this range (module docstring, "Contact line"): 1 at a row's end (s = 1), ~0.09 one ring
#: behind it on a lattice (Wendland C2, R = 3 dx)
CONTACT_LINE_S = (0.35, 0.7)


@njit(cache=True)
def contact_line_weight(x, liquid, offsets, indices, band, nrm, n_real, Rp, kcode, tol,
                        period, out):
    """``out[i]`` in [0, 1] for the band rows i < n_real: how much row i is the end of its
    wall row (the contact line).  Over the liquid neighbours j (``liquid`` over the augmented
    rows, axis mirrors included) within ``tol`` of i's layer, |(x_j - x_i) . n_i| < tol, with
    d_t = (x_j - x_i) . t_i along the wall (t_i the band normal ``nrm[i]`` turned by 90
    degrees) and kernel weights w: s = |sum w d_t| / sum w |d_t| (1 without such a
    neighbour), and ``out[i]`` = smoothstep of s over :data:`CONTACT_LINE_S`; 0 off the
    band.  ``period``: the (x, y) periods (0: open), minimum image across them."""
    lo, hi = CONTACT_LINE_S
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in range(n_real):
        out[i] = 0.0
        if band[i] == 0:
            continue
        n0, n1 = nrm[i, 0], nrm[i, 1]
        m = 0.0
        a = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if j == i or not liquid[j]:
                continue
            d0, d1, _ = pair_sep(x, i, j, 2, period, periodic)
            if abs(d0 * n0 + d1 * n1) >= tol:
                continue
            R = 0.5 * (Rp[i] + Rp[j])
            d = math.sqrt(d0 * d0 + d1 * d1)
            if d >= R:
                continue
            w = kernels.kernel_f(d / R, kcode)
            dt_ = -d0 * n1 + d1 * n0
            m += w * dt_
            a += w * abs(dt_)
        s = abs(m) / a if a > 0.0 else 1.0
        u = min(max((s - lo) / (hi - lo), 0.0), 1.0)
        out[i] = u * u * (3.0 - 2.0 * u)


@njit(cache=True)
def advance_layer(delta2, band, a, nu, dt, d2max, x, offsets, indices, Rp, kcode):
    """One step of eq. (2) for the real rows (``delta2 < 0``: no layer).  Rows leaving the
    band forget their layer; rows entering it take the kernel average of their band
    neighbours' delta^2 (0 without one); band rows advance exactly for constant a over dt,
    delta^2 <- delta^2 e^(-2 a dt) + pi nu (1 - e^(-2 a dt)) / (2 a), capped at ``d2max``."""
    n = delta2.shape[0]
    new = np.empty(n)
    for i in range(n):
        new[i] = delta2[i]
        if band[i] == 0:
            new[i] = -1.0
            continue
        if delta2[i] < 0.0:  # entering: the neighbours' layer
            sw = 0.0
            sd = 0.0
            for jj in range(offsets[i], offsets[i + 1]):
                j = indices[jj]
                if j >= n or j == i or band[j] == 0 or delta2[j] < 0.0:
                    continue
                w = _pair_weight(x, Rp, i, j, kcode)
                sw += w
                sd += w * delta2[j]
            new[i] = sd / sw if sw > 0.0 else 0.0
            continue
        g = 2.0 * a[i] * dt
        if abs(g) < 1e-8:
            d2 = delta2[i] + math.pi * nu * dt * (1.0 - 0.5 * g)
        else:
            e = math.exp(-g)
            d2 = delta2[i] * e + math.pi * nu * dt * (1.0 - e) / g
        new[i] = min(max(d2, 0.0), d2max)
    for i in range(n):
        delta2[i] = new[i]


def friction_factor(delta2, dx: float, S: float, nu: float, dt: float, h: float,
                    visc_cfl: float) -> np.ndarray:
    """f of eq. (3) per row (1 outside the band), delta^2 floored at pi nu dt / 4 and f capped
    by the viscous step limit visc_cfl h^2 / (nu f) >= dt."""
    d2 = np.maximum(delta2, 0.25 * math.pi * nu * dt)
    f = np.maximum(1.0, dx / (S * np.sqrt(d2)))
    f = np.minimum(f, max(1.0, visc_cfl * h * h / (nu * dt)))
    return np.where(delta2 < 0.0, 1.0, f)
