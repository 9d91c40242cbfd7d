"""Continuum surface force (CSF) for the axisymmetric fluid of :mod:`sphfem.fluid.axisymmetric`.

The planar CSF of :mod:`sphfem.fluid.surface_tension_csf` (Brackbill, Kothe & Zemach 1992;
SPH form after Morris 2000) run in the meridian (r, z) half-plane, with planar areas
A_i = M_i / (2 pi r_i rho_i) as particle volumes and the axis mirrors (-r, z) of the fluid
as neighbours, plus the hoop part of the curvature.  With n the unit normal pointing into
the liquid, the mean curvature of an axisymmetric surface is (e.g. Batchelor 1967, app. 2,
divergence in cylindrical coordinates)

    kappa = -div n = -(d_r n_r + d_z n_z) - n_r / r = kappa_m + kappa_h,              (1)

kappa_m the curvature of the meridian curve (the planar -div n of the (r, z) plane) and
kappa_h = -n_r / r the curvature of the parallel circle (hoop).  A sphere of radius R0 has
kappa_m = kappa_h = 1 / R0, a cylinder along z kappa_m = 0 and kappa_h = 1 / R0.

Passes (each a numba kernel; the planar ones are those of the planar CSF):

1. colour gradient g_i = sum_j A_j grad_i W_ij and normal weight omega_i
   (:func:`~sphfem.fluid.surface_tension_csf.csf_normals`), over fluid, wall and mirror
   neighbours; then copied to the mirrors with the parity of a vector (g_r odd across the
   axis, g_z odd across a wall plane; :func:`mirror_normals`);
2. meridian curvature kappa_m (:func:`~sphfem.fluid.surface_tension_csf.csf_curvature`,
   dim = 2: the tangential-moment-corrected -div n of the plane);
3. hoop curvature (:func:`hoop_curvature`), added to kappa.  Near the axis -n_r / r is a
   ratio of two vanishing quantities: n_r is odd in r and carries the kernel-smoothing and
   lattice error of the colour gradient, which the division by r_i ~ dx/2 amplifies.  The
   even continuation gives the limit (L'Hopital) -n_r / r -> -d_r n_r, and on the axis a
   smooth surface is normal to it, so there -d_r n_r = kappa_m (the two principal curvatures
   are equal at an umbilic pole).  Hence

       kappa_h,i = s_i (-n_r,i / r_i) + (1 - s_i) kappa_m,i,
       s_i = smoothstep((r_i - a R) / (b R - a R)),

   with the support radius R, (a, b) = :data:`AXIS_BAND`: the pointwise ratio away from the
   axis, the meridian curvature at the axis.  kappa_h - kappa_m is even and vanishes at
   r = 0, so the blend errs by O(r^2) there, i.e. O(R^2) (zero on a sphere);
   Curvature at the axis (``axis_curvature``, opt-in): next to the axis the colour
   gradient itself is distorted: a ring at r and its mirror are 2 r apart and the areas
   M / (2 pi r rho) vary as 1 / r, so jitter of a flowing lattice tilts the normals there
   (n_r = -0.3 to -0.6 on a flat film) and the curvature of a flat surface reads 2-3e6 1/m
   at D/dx 90 (examples/axisymmetric/csf_axis_noise.py).  With the option kappa_i in the
   band is blended (the same smoothstep) into the mean kappa of the valid rows at the
   band's outer edge, r in [b R, b R + R], within |dz| < R (kappa is even and smooth in r,
   so this errs by O(R^2) like the hoop blend): on the jittered flat film the top rings'
   spurious a_r within 2 dx of the axis fall from 3-5e6 to 0.5-1e5 m/s^2, the level of
   the rest of the surface; on the sphere nothing changes (test).  The interior rings of
   the band keep a spurious valid normal (|g| R up to 0.55 with a full support, the
   fluid's lambda_min 0.82-0.98, against 0.40-0.77 on the true surface there):
   ``axis_lambda_gate`` (experimental, attribute, None = off) removes the normals of the
   band's rings with lambda_min at or above it; with 0.8 and ``axis_curvature`` the film's
   spurious accelerations next to the axis fall to <= 1.1e5 m/s^2 everywhere (interior
   -5e3 within one spacing, from -2.6e6);
   Curvature smoothing (``curvature_smoothing`` = c > 1; 1 = off): the valid rows'
   curvature replaced by its Wendland mean over the valid rows (and mirrors) within c R
   (:func:`smooth_curvature`), a low-pass along the surface.  The curvature's response to
   particle disorder grows as 1 / dx (a ripple of amplitude ~0.1 dx over a wavelength of
   a few R): on the sphere's arcs jittered by 0.1 dx the outer arc's rms error is 0.14 /
   0.35 / 0.66 of 2 / R0 at R0/dx = 10 / 20 / 40, and 0.06 / 0.10 / 0.19 with c = 2 (the
   unjittered sphere unchanged, test).  In the axisymmetric impact that noise is not
   harmless: ring waves of it converge on the axis (docs/validation/droplet_impact/
   README.md, session 13);
4. band curvature (Shepard extension) and force a_i = 2 sigma kbar_i g_i / rho_i
   (:func:`~sphfem.fluid.surface_tension_csf.csf_force`), with kappa copied to the mirrors.

Why the planar force needs nothing else: the axisymmetric pressure acceleration is
-sum_j mt_j (p_i / rho_i^2 + p_j / rho_j^2) grad_i W_ij with planar masses mt = rho A, so a
uniform pressure P acts on every particle with -2 P g_i / rho_i, as in the planar case; the
static balance per particle is again P = sigma kbar (Laplace's jump 2 sigma / R0 on a
sphere).  The pressure gradient has no hoop term; the hoop part lives in the curvature.

Support: one scalar radius R for all CSF sums (the planar passes take a scalar).  The
fluid's hook passes its widest fluid support, which is R itself unless ``adaptive_h``; with
adaptive h and the median support instead, a D/dx = 16 impact (10 m/s, sigma = 0.072 N/m)
blew up at the axis at 1.46 t_c, with the widest it ran to 3 t_c.

Thin films (``film=True``, scene key ``[fluid] film_tension``; default off).  A film thinner
than the support R has a truncated colour field: its two faces' colour gradients cancel
(a free film one row thick has g = 0 and no force at all), and on a wall the step of its
end is a convex and a concave corner closer than R whose curvatures the kernel cancels.
The pull on the end of a film k rows thick, against the exact line force (2 sigma free,
sigma (1 - cos theta) = sigma on the CSF's 90-degree wall; the Frenet integral of kappa n
over the end whatever its shape), is 0.12 / 0.76 / 1.10 / 1.03 / 0.98 sigma on a wall for
k = 1 / 2 / 3 / 4 / 6 with a square end, 0.12 / 0.36 / 0.74 / 0.67 / 0.67 with a rounded
one, and 0 / 1.25-1.35 x 2 sigma free (``examples/axisymmetric/film_edge_force.py``).
The film model writes the surface tension of such a film as what it is across any cut, a
line tension gamma along the film (Taylor 1959, Culick 1960), i.e. the in-plane stress of
a membrane, S = tau t t, and its force as the symmetric SPH divergence

    a_i = phi_i / rho_i sum_j A_j (S_i + S_j) . grad_i W_ij    (fluid neighbours)      (F1)

in place of the CSF: a_i = (1 - phi_i) a_CSF,i + (F1) + (F3).  (F1) is antisymmetric, so the
force on the part of a film beyond a cut is the flux of S through the cut, whatever the
shape of the end; for a uniform film on a lattice that flux is sum_rows s tau_i M_tt,i
(s the spacing, M_tt = sum_j A_j F_ij (t . r_ij)^2 the tangential moment, 1 in the bulk),
so with

    tau_i = gamma_i / Q_i,   Q = sum_j A_j w1(t . r_ij) M_tt,j  (self included, w1 the
    kernel's shape normalised in 1D: the band sum of M_tt across the film)            (F2)

it is gamma exactly (up to the 1D quadrature of w1: 0.994 gamma at R = 3 dx).  The rows'
quantities, from fluid neighbours only (walls and wall-plane images are not film):

- t: the larger eigenvector of the Shepard mean of the moment matrices M_j = sum_k A_k
  F_jk r_jk r_jk (an end row alone has no film direction);
- the width E_i: the least over its film normal and FILM_DIRECTIONS directions of the
  extent of the fluid within R, plus sqrt(A_i) (k s for a film of k <= R/s + 1 rows);
  phi_i = 1 - smoothstep of the largest E over the row and its neighbours from R +
  FILM_BAND[0] s to R + FILM_BAND[1] s: 1 in films up to R/s + 1 rows (4 at R = 3 dx), 0
  from one row more, and 0 on the face of thick fluid (its third row sees 5 rows);
- gamma_i = sigma (2 - c_i), c_i the wall contact: smoothstep(FILM_CONTACT - d_w / s) of
  the nearest wall row at d_w, spread as the largest over the neighbours' neighbours (the
  whole film's thickness);
- Q in (F2) is the largest Q over the row and its neighbours, so that tau stays the film's
  up to its end (Q of an end row is truncated), and at least FILM_Q_MIN of a one-row
  film's (:func:`row_moment`): a fragment of two rings closer than a spacing would
  otherwise get tau ~ 1 / |r|^2 and pull them together as 1 / |r| (a D/dx = 32 impact
  threw a ring out at 2e4 m/s at 3.6 t_c without the floor).

Axisymmetric: the film's stress is isotropic in its plane, S + tau e_theta e_theta, whose
divergence in cylindrical coordinates is the planar one plus

    (tau M_tt / r) (t_r t - e_r)                                                       (F3)

(tau M_tt: the stress itself, whose integral across the film is gamma; (F1) needs the
1 / M_tt of (F2) for its truncated kernel sums, a pointwise term does not.  (F3) is 0 for a
film normal to the axis, -gamma / r0 per unit area for a cylindrical sheet of radius r0:
the hoop pull of its two faces), faded to 0 at the axis over AXIS_BAND as the hoop
curvature.  Measured with the model (``film_edge_force.py --film``; tests/
test_film_edge_force.py): 0.994 of the exact line force for 1-4 rows, square or rounded end,
free or on a wall; 5 and 6 rows are the CSF's (phi = 0: 0.99 / 0.70 on a wall, 1.31 / 1.14
free for 5 rows, square / rounded).  Thick fluid has phi = 0
exactly, so the static droplet, its oscillation and every other flow without films are
the CSF's to the bit (test).  Not modelled: a film's own bending (its two faces' curvature
force 2 sigma kappa on a curved sheet comes from (F1) with the sheet's curvature, as for a
membrane), contact angles other than 90 degrees.

Known defect, the junction of a film with thick fluid: phi = 0 within about 2 R of the thick
fluid, where the CSF acts, and the CSF there delivers only part of the film's pull on the
thick side.  A free block 12 x 12 rows with a film k rows thick attached (planar, static):
the film's outer half gets -1.99 sigma (exact -2), the block +0.08 / +0.73 / +1.27 sigma for
k = 1 / 2 / 3 (exact +2), so the body has a net force of -1.7 / -1.4 / -0.6 sigma along the
film (the CSF alone: 0 / -2.2 / -1.4 sigma, its film end pulled with 0 / 1.34 / 1.35 x
2 sigma).  Spreading the pair weight and the CSF's switch-off one and two neighbour hops
further moved that to +0.1 / +0.8 / +1.1 sigma (not kept).  Dynamic check, the Taylor-
Culick retraction of a free sheet (planar, 80 rows long, alpha = 0.02): 0.19 / 0.78 / 0.92
of sqrt(2 sigma / (rho h)) for 1 / 2 / 3 rows (CSF alone: none / -0.12 / 0.87); a single row
cannot gather a rim (its rings stay in line and the pull compresses the whole row, which
moves as one).

Droplet impact (water, D = 0.1 mm, 10 m/s, layer friction, to 4 t_c;
``examples/droplet_impact/level_run.py 10 N 4 OUT fluid.film_tension=True``), D_max / D at
D/dx 32 / 45 / 64: 2.76 / 2.96, 3.06 / 3.00, 3.51, 3.08 with the model (twins: output every
0.02 / 0.05 t_c), 5.57 / 4.70 / 4.48, 4.11 without (correlations 3.09-3.54; D/dx 128
without: 3.88).  The model takes the spread to the band's bottom from below and makes the
sequence monotone, but its maximum comes at 1.2-1.8 t_c (2.9 in one twin) where the
resolved run has 2.55, and the round-off twins still differ by up to 16 % at D/dx 64: a
one- or two-row lamella with its correct pull retracts and ruptures (holes open where the
film is one ring thick), and when the first hole opens is round-off.  So it is not the
default.

Time step (capillary waves, Brackbill et al. 1992): dt <= 0.25 sqrt(rho h^3 / (2 pi sigma))
(:func:`capillary_dt`; not among the fluid's own limits: callers take the minimum).

Checks (tests/test_axisymmetric_surface_tension.py): prescribed sphere (arcs of
:func:`half_disc_arcs`): kappa = 2 / rho1 within 1 % per particle (rho1 = R0 - dx/2, the
outer arc), the planar part alone 1 / rho1; cylinder: kappa_m = 0, kappa_h = 1 / r to 1e-3;
slab: 0.  The staircase of :func:`~sphfem.axisymmetric.half_disc_lattice` gives meridian
curvatures of +-3 / R0 per particle at R0/dx = 20 (the planar CSF's response to a lattice
staircase), so the prescribed-field checks use arcs; a droplet started on the lattice relaxes
(Laplace pressure within 2.3 % at R0/dx = 20).  Droplet at rest: inner pressure 2 sigma /
rho1 within 0.1 %, i.e. 2 sigma / R0 with the first-order layer offset (5.2 / 2.5 / 1.2 %
at R0/dx = 10 / 20 / 40); spurious currents < 5e-4 sigma / mu.  Rayleigh's l = 2 period
within 0.6 % at R0/dx = 10 and 20; the remaining error is the weak compressibility of the
run (c0 = 3.8 m/s: doubling c0 takes it from 0.59 % to 0.16 % at R0/dx = 20), not the
spatial discretisation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.axisymmetric import MIRROR_FLUID, MIRROR_WALL
from sphfem.fluid.passes import grad_factor
from sphfem.fluid.surface_tension_csf import (
    DELTA_FACTOR,
    NORMAL_HI,
    NORMAL_LO,
    SHEPARD_MIN,
    TANGENT_MIN,
    csf_curvature,
    csf_force,
    csf_normals,
    csf_state,
)
from sphfem.kernels import kernel_f
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import pair_sep

#: the hoop curvature blends from kappa_m (r < a R) to -n_r / r (r > b R), R the support
AXIS_BAND = (0.5, 1.5)
#: film model: a row is in a thin film where the largest normal extent E of the fluid seen
#: by it and its neighbours is below R + FILM_BAND[0] s, not at all above R + FILM_BAND[1] s
#: (s the row's spacing sqrt(A); smoothstep between)
FILM_BAND = (1.25, 1.75)
#: film model: rows with a wall row closer than (2 - a) s, a in [0, 1], touch the wall with
#: weight smoothstep(a) (the first fluid row on a wall lattice lies one spacing from it)
FILM_CONTACT = 2.0
#: film model: the width of the fluid around a row is its least extent over its own normal
#: and this many equally spaced directions
FILM_DIRECTIONS = 8
#: film model: floor of Q in (F2), as a fraction of a one-row film's
FILM_Q_MIN = 0.5


@njit(cache=True)
def mirror_normals(n, src, mtype, g, omega):
    """Copy the colour gradient and normal weight of the sources onto the mirror rows
    n + q (in order: a source may be an earlier mirror).  ``mtype`` 0: image across the axis
    (g_r negated); 1: image across a wall plane z = const (g_z negated)."""
    for q in range(src.shape[0]):
        s = src[q]
        k = n + q
        omega[k] = omega[s]
        if mtype[q] == 0:
            g[k, 0] = -g[s, 0]
            g[k, 1] = g[s, 1]
        else:
            g[k, 0] = g[s, 0]
            g[k, 1] = -g[s, 1]


@njit(cache=True)
def mirror_scalar(n, src, a):
    """a[n + q] = a[src[q]] (an even scalar, in order)."""
    for q in range(src.shape[0]):
        a[n + q] = a[src[q]]


@njit(cache=True, inline="always")
def _smoothstep(a):
    if a <= 0.0:
        return 0.0
    if a >= 1.0:
        return 1.0
    return a * a * (3.0 - 2.0 * a)


@njit(cache=True, parallel=True)
def film_moments(x, A, fl, wl, n, offsets, indices, R, fac2, kernel_code, period, M, dwall):
    """Fluid-only moment matrix M_i = sum_j A_j F_ij r_ij r_ij (j != i fluid-like, ``fl``;
    the identity in the bulk), stored (M_rr, M_rz, M_zz), and the distance ``dwall`` to the
    nearest wall-like row (``wl``; inf without one) of the real fluid rows i < n."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        M[i, 0] = 0.0
        M[i, 1] = 0.0
        M[i, 2] = 0.0
        dwall[i] = np.inf
        if not fl[i]:
            continue
        a = 0.0
        b = 0.0
        c = 0.0
        dw = np.inf
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not (fl[j] or wl[j]):
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            if wl[j]:
                dw = min(dw, math.sqrt(d2))
                continue
            t = A[j] * grad_factor(math.sqrt(d2), R, fac2, kernel_code)
            a += t * r0 * r0
            b += t * r0 * r1
            c += t * r1 * r1
        M[i, 0] = a
        M[i, 1] = b
        M[i, 2] = c
        dwall[i] = dw


@njit(cache=True, parallel=True)
def film_smooth(x, A, fl, n, offsets, indices, R, sigma, kernel_code, period, M, Mbar):
    """Shepard mean ``Mbar`` of the moment matrices ``M`` over the fluid-like neighbours
    and the row itself, of the real fluid rows (its larger eigenvector is the film's
    tangent, which a row at the film's end does not have on its own)."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    w0 = sigma * kernel_f(0.0, kernel_code)
    for i in prange(n):
        Mbar[i, 0] = 0.0
        Mbar[i, 1] = 0.0
        Mbar[i, 2] = 0.0
        if not fl[i]:
            continue
        den = A[i] * w0
        a = den * M[i, 0]
        b = den * M[i, 1]
        c = den * M[i, 2]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            w = A[j] * sigma * kernel_f(math.sqrt(d2) / R, kernel_code)
            den += w
            a += w * M[j, 0]
            b += w * M[j, 1]
            c += w * M[j, 2]
        Mbar[i, 0] = a / den
        Mbar[i, 1] = b / den
        Mbar[i, 2] = c / den


@njit(cache=True, parallel=True)
def film_extent(x, A, fl, n, offsets, indices, R, sigma1, kernel_code, period, tang, ndir, M,
                ext, Q):
    """Width ``ext`` of the fluid within R of each real fluid row: the least over its film
    normal (normal to ``tang``) and ``ndir`` equally spaced directions of max - min of the
    projections of r_ij on them (fluid-like neighbours and the row itself), plus its
    spacing sqrt(A_i); and the film's tangential moment per unit length Q_i = sum_j A_j
    w1(t_i . r_ij) t_i . M_j . t_i (self included; w1 the kernel's shape normalised in 1D
    by ``sigma1``): sum_rows s M_tt of the film's cross-section when it lies within R."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    nd = ndir + 1
    for i in prange(n):
        ext[i] = 0.0
        Q[i] = 0.0
        if not fl[i]:
            continue
        t0 = tang[i, 0]
        t1 = tang[i, 1]
        d0 = np.empty(nd)
        d1 = np.empty(nd)
        lo = np.zeros(nd)
        hi = np.zeros(nd)
        d0[0] = -t1
        d1[0] = t0
        for k in range(ndir):
            a = math.pi * k / ndir
            d0[k + 1] = math.cos(a)
            d1[k + 1] = math.sin(a)
        q = A[i] * sigma1 * kernel_f(0.0, kernel_code) * (
            t0 * t0 * M[i, 0] + 2.0 * t0 * t1 * M[i, 1] + t1 * t1 * M[i, 2])
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            for k in range(nd):
                p = d0[k] * r0 + d1[k] * r1
                lo[k] = min(lo[k], p)
                hi[k] = max(hi[k], p)
            mtt = t0 * t0 * M[j, 0] + 2.0 * t0 * t1 * M[j, 1] + t1 * t1 * M[j, 2]
            q += A[j] * sigma1 * kernel_f(abs(t0 * r0 + t1 * r1) / R, kernel_code) * mtt
        w = hi[0] - lo[0]
        for k in range(1, nd):
            w = min(w, hi[k] - lo[k])
        ext[i] = w + math.sqrt(A[i])
        Q[i] = q


@njit(cache=True, parallel=True)
def film_spread(x, A, fl, n, offsets, indices, R, period, ext, contact, Q, band_lo, band_hi,
                phi, touch, Qmax):
    """Film weight ``phi`` (1 - smoothstep of the largest ``ext`` over the row and its
    fluid-like neighbours, from R + band_lo s to R + band_hi s), wall contact ``touch``
    and ``Qmax`` (the largest ``contact`` and ``Q`` over the same rows) of the real fluid
    rows."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        phi[i] = 0.0
        touch[i] = 0.0
        Qmax[i] = 0.0
        if not fl[i]:
            continue
        e = ext[i]
        c = contact[i]
        qm = Q[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            e = max(e, ext[j])
            c = max(c, contact[j])
            qm = max(qm, Q[j])
        s = math.sqrt(A[i])
        phi[i] = 1.0 - _smoothstep((e - R - band_lo * s) / ((band_hi - band_lo) * s))
        touch[i] = c
        Qmax[i] = qm


@njit(cache=True, parallel=True)
def film_max(x, fl, n, offsets, indices, R, period, a, out):
    """out_i = the largest ``a`` over the real fluid row i and its fluid-like neighbours."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        out[i] = 0.0
        if not fl[i]:
            continue
        v = a[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            v = max(v, a[j])
        out[i] = v


@njit(cache=True, parallel=True)
def film_force(x, A, rho, fl, n, offsets, indices, R, fac2, kernel_code, period, S, phi, acc):
    """acc[i] = phi_i / rho_i sum_j A_j (S_i + S_j) . grad_i W_ij over the fluid-like
    neighbours (the planar divergence of the film stress S = (S_rr, S_rz, S_zz) in the
    symmetric pair form) of the real fluid rows with phi_i > 0; 0 elsewhere."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        acc[i, 0] = 0.0
        acc[i, 1] = 0.0
        if not fl[i] or phi[i] == 0.0:
            continue
        f0 = 0.0
        f1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j]:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            t = A[j] * grad_factor(math.sqrt(d2), R, fac2, kernel_code)
            srr = S[i, 0] + S[j, 0]
            srz = S[i, 1] + S[j, 1]
            szz = S[i, 2] + S[j, 2]
            f0 += t * (srr * r0 + srz * r1)
            f1 += t * (srz * r0 + szz * r1)
        acc[i, 0] = phi[i] * f0 / rho[i]
        acc[i, 1] = phi[i] * f1 / rho[i]


@njit(cache=True)
def mirror_tensor(n, src, mtype, S):
    """Copy the symmetric tensor rows (S_rr, S_rz, S_zz) of the sources onto the mirrors
    n + q, in order; S_rz is odd across the axis and across a wall plane."""
    for q in range(src.shape[0]):
        s = src[q]
        k = n + q
        S[k, 0] = S[s, 0]
        S[k, 1] = -S[s, 1]
        S[k, 2] = S[s, 2]


@njit(cache=True)
def mirror_flags(n, src, mtype, fl, wl):
    """Fluid-like (``fl``) and wall-like (``wl``) mirrors, in order: an axis image (type 0)
    and an image across the surface stress' plane (type 2, :mod:`sphfem.fluid.
    axisymmetric_surface_stress`) keep their source's, a wall-plane image of the fluid
    (type 1) stands for the wall."""
    for q in range(src.shape[0]):
        s = src[q]
        k = n + q
        if mtype[q] != 1:
            fl[k] = fl[s]
            wl[k] = wl[s]
        else:
            fl[k] = False
            wl[k] = True


@njit(cache=True, parallel=True)
def hoop_curvature(r, g, omega, kappa_m, r_in, r_out, kappa_h):
    """Hoop curvature ``kappa_h`` of the rows with a valid normal (omega > 0; 0 elsewhere):
    -n_r / r with n = g / |g| for r >= ``r_out``, the meridian curvature ``kappa_m`` (the
    axis limit) for r <= ``r_in``, smoothstep blend between (module docstring, pass 3)."""
    for i in prange(r.shape[0]):
        kappa_h[i] = 0.0
        if omega[i] == 0.0:
            continue
        a = (r[i] - r_in) / (r_out - r_in)
        s = 1.0
        if a <= 0.0:
            s = 0.0
        elif a < 1.0:
            s = a * a * (3.0 - 2.0 * a)
        k = 0.0
        if s > 0.0:
            gn = math.sqrt(g[i, 0] * g[i, 0] + g[i, 1] * g[i, 1])
            k = -g[i, 0] / (gn * r[i])
        kappa_h[i] = s * k + (1.0 - s) * kappa_m[i]


@njit(cache=True)
def _row_moment(s, R, fac2, kernel_code, out):
    for i in range(s.shape[0]):
        q = 0.0
        if s[i] > 0.0:
            m = 1
            while m * s[i] < R:
                d = m * s[i]
                q += 2.0 * s[i] * s[i] * grad_factor(d, R, fac2, kernel_code) * d * d
                m += 1
        out[i] = s[i] * q


def row_moment(s, R, kernel_code) -> np.ndarray:
    """Q of a film one row thick with spacing ``s`` (array): s sum_{m != 0} s^2 F(|m| s)
    (m s)^2 (the band sum of (F2) with its 1D quadrature taken as exact)."""
    s = np.ascontiguousarray(s, dtype=np.float64)
    out = np.empty_like(s)
    _row_moment(s, float(R), kernels.kernel_sigma(kernel_code, 2, R) / (R * R),
                int(kernel_code), out)
    return out


def film_hoop(x, rho, tau, tang, M) -> np.ndarray:
    """(tau M_tt / (r rho)) (t_r t - e_r): the acceleration of the in-plane hoop stress of a
    tension tau t t (eq. F3; rows of real fluid, r = |x_r| > 0)."""
    r = np.maximum(np.abs(x[:, 0]), 1e-300)
    t0, t1 = tang[:, 0], tang[:, 1]
    mtt = t0 * t0 * M[:, 0] + 2.0 * t0 * t1 * M[:, 1] + t1 * t1 * M[:, 2]
    k = tau * mtt / (r * rho)
    return np.column_stack([k * (t0 * t0 - 1.0), k * t0 * t1])


def colour_kinds(kind) -> np.ndarray:
    """Kinds as the planar CSF passes read them: fluid mirrors count as FLUID, wall mirrors
    as WALL (their rows have no neighbours in the axisymmetric list; they are filled by
    :func:`mirror_normals` / :func:`mirror_scalar`)."""
    k = np.asarray(kind, np.int8).copy()
    k[k == MIRROR_FLUID] = FLUID
    k[k == MIRROR_WALL] = WALL
    return k


def half_disc_arcs(radius: float, dx: float, center_z: float = 0.0):
    """Meridian half-disc of a sphere of ``radius`` filled with concentric half-circle arcs
    (a smooth surface rather than the staircase of
    :func:`~sphfem.axisymmetric.half_disc_lattice`; the meridian section of the 3D
    :func:`~sphfem.fluid.setup.droplet_packing`): arc k at rho_k = (k + 1/2) dx' (dx' =
    radius / round(radius / dx), the outer arc at radius - dx'/2) with N_k = round(pi rho_k /
    dx') points at the polar angles (j + 1/2) pi / N_k, none on the axis.

    Returns ``(x, area)``: positions (r, z) and meridian areas pi rho_k dx' / N_k (the
    half-annulus of arc k shared evenly; they sum to pi radius^2 / 2): the half r > 0 of
    :func:`sphfem.geometry.shell_points` with :func:`sphfem.geometry.shell_areas`."""
    from sphfem.geometry import Shape, shell_areas, shell_points

    ball = Shape.sphere((0.0, float(center_z)), float(radius))
    x = shell_points(ball, dx, 2)
    x = x[x[:, 0] > 0.0]  # each circle's half r > 0, in its order
    return x, shell_areas(x, ball, dx)


def capillary_dt(rho, h, sigma) -> float:
    """Capillary-wave limit dt <= 0.25 sqrt(rho h^3 / (2 pi sigma)) [s] (Brackbill et al.
    1992, eq. 61); inf without surface tension."""
    if sigma <= 0.0:
        return math.inf
    return 0.25 * math.sqrt(rho * h**3 / (2.0 * math.pi * sigma))


def axis_curvature_extension(x, kappa, omega, kind, n, r_in, r_out, R, Lz=0.0):
    """``axis_curvature``: the curvature of the real fluid rows with a valid normal inside
    the axis band taken from the band's outer edge.  kappa is even and smooth in r, so
    kappa(r) = kappa(r_e) + O(r_e^2); next to the axis the pointwise value carries the
    colour gradient's distortion there (rings and their mirrors 2 r apart;
    examples/axisymmetric/csf_axis_noise.py).  kappa_i <- s_i kappa_i + (1 - s_i) kappa_e,i,
    s_i the smoothstep of (r_i - ``r_in``) / (``r_out`` - ``r_in``), kappa_e,i the mean of
    kappa_j weighted by omega_j f(|z_j - z_i| / R) (f the Wendland C2 shape) over the valid
    rows j with ``r_out`` <= r_j < ``r_out`` + R and |z_j - z_i| < R (unchanged where there
    is none; ``Lz`` > 0: z periodic with that period).  In place."""
    valid = (np.asarray(kind[:n]) == FLUID) & (omega[:n] > 0.0)
    r = np.abs(x[:n, 0])
    rows = np.flatnonzero(valid & (r < r_out))
    edge = np.flatnonzero(valid & (r >= r_out) & (r < r_out + R))
    if rows.size == 0 or edge.size == 0:
        return
    dz = np.abs(x[edge, 1][None, :] - x[rows, 1][:, None])
    if Lz > 0.0:
        dz = np.minimum(dz % Lz, Lz - dz % Lz)
    dz = dz / R
    q = np.minimum(dz, 1.0)
    w = omega[edge][None, :] * (1.0 - q) ** 4 * (1.0 + 4.0 * q)  # Wendland C2 shape
    den = w.sum(axis=1)
    ok = den > 0.0
    ke = np.where(ok, (w * kappa[edge][None, :]).sum(axis=1) / np.where(ok, den, 1.0), 0.0)
    a = np.clip((r[rows] - r_in) / (r_out - r_in), 0.0, 1.0)
    s = a * a * (3.0 - 2.0 * a)
    kappa[rows] = np.where(ok, s * kappa[rows] + (1.0 - s) * ke, kappa[rows])


@njit(cache=True, parallel=True)
def _smooth_rows(x, w, kappa, nrows, offsets, indices, Rs, Lz, kernel_code, out):
    """out[i] = sum_j w_j f(d_ij / Rs) kappa_j / sum_j w_j f(d_ij / Rs) over j = i and its
    list neighbours (f the Wendland C2 shape; z minimum image when Lz > 0), i < nrows."""
    for i in prange(nrows):
        num = w[i] * kappa[i]
        den = w[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            dr = x[j, 0] - x[i, 0]
            dz = x[j, 1] - x[i, 1]
            if Lz > 0.0:
                dz -= Lz * np.rint(dz / Lz)
            wf = w[j] * kernel_f(math.sqrt(dr * dr + dz * dz) / Rs, kernel_code)
            num += wf * kappa[j]
            den += wf
        out[i] = num / den


def smooth_curvature(x, A, omega, kappa, n, Rs, Lz=0.0):
    """kappa_i <- sum_j w_ij kappa_j / sum_j w_ij for the rows with omega > 0 (real rows
    i < n; j over all valid rows, mirrors included, and i itself), w_ij = omega_j A_j
    f(|x_i - x_j| / Rs), f the Wendland C2 shape (``Lz`` > 0: z periodic, minimum image).
    In place."""
    from sphfem.neighbors import build_neighbor_list

    valid = np.flatnonzero(omega > 0.0)  # ascending: the real rows come first
    rows = int(np.count_nonzero(valid < n))
    if rows == 0:
        return
    pts = np.ascontiguousarray(x[valid], dtype=np.float64)
    lo, hi = pts.min(axis=0) - Rs, pts.max(axis=0) + Rs
    period = np.zeros(2)
    if Lz > 0.0:
        lo[1], hi[1], period[1] = float(lo[1]), float(lo[1]) + Lz, Lz
    nl = build_neighbor_list(pts, Rs, lo, hi, period)
    out = np.empty(rows)
    _smooth_rows(pts, np.ascontiguousarray(omega[valid] * A[valid]),
                 np.ascontiguousarray(kappa[valid]), rows, nl.offsets, nl.indices,
                 float(Rs), float(Lz), kernels.WENDLAND_C2, out)
    kappa[valid[:rows]] = out


class AxisymmetricCSF:
    """CSF surface tension ``sigma`` [N/m] for the augmented (real + mirror) particle set of
    :class:`~sphfem.fluid.axisymmetric.AxisymmetricFluid` (module docstring).

    After :meth:`accumulate`, ``state`` (a :class:`~sphfem.fluid.surface_tension_csf.CSFState`
    over the augmented rows) holds g, omega, kappa (= kappa_m + kappa_h) and kbar, and
    ``kappa_m`` / ``kappa_h`` the two parts.  ``hoop=False``: no hoop part (the planar CSF
    with a symmetry plane at r = 0, for the planar mode of the fluid).
    """

    def __init__(self, sigma: float, kernel_code: int = kernels.WENDLAND_C2,
                 axis_band=AXIS_BAND, hoop: bool = True, film: bool = False,
                 axis_curvature: bool = False, curvature_smoothing: float = 1.0,
                 meridian: str = "csf", wall_colour: float | None = None,
                 rho0: float | None = None):
        if meridian not in ("csf", "pair", "stress"):
            raise ValueError(f'meridian must be "csf", "pair" or "stress", got {meridian!r}')
        if meridian == "pair" and film:
            raise ValueError('the film model replaces the CSF on thin films; it does not go '
                             'with meridian = "pair"')
        if not sigma >= 0.0:
            raise ValueError(f"surface tension sigma must be >= 0, got {sigma}")
        if not curvature_smoothing >= 1.0:
            raise ValueError("curvature_smoothing must be >= 1 (a multiple of the support "
                             f"radius; 1: off), got {curvature_smoothing!r}")
        self.sigma = float(sigma)
        self.kernel_code = int(kernel_code)
        self.axis_band = tuple(float(a) for a in axis_band)
        self.hoop = bool(hoop)
        #: the curvature of the axis band from the band's outer edge (module docstring,
        #: "Curvature at the axis"; opt-in)
        self.axis_curvature = bool(axis_curvature)
        #: rings in the axis band whose moment matrix' smallest eigenvalue (the fluid's
        #: lambda_min, passed to :meth:`accumulate`) reaches this get no normal (None: off;
        #: experimental, module docstring "Curvature at the axis")
        self.axis_lambda_gate = None
        #: the curvature of the valid rows replaced by its mean over the valid rows within
        #: c R (:func:`smooth_curvature`), c this factor (1: off; module docstring,
        #: "Curvature smoothing")
        self.curvature_smoothing = float(curvature_smoothing)
        #: the film model (module docstring, "Thin films"): off by default
        self.film = bool(film)
        #: "csf": sigma (kappa_m + kappa_h) grad C; "pair": the meridian part as the pair
        #: force of :mod:`sphfem.fluid.axisymmetric_pair_tension`, the hoop part the CSF's
        self.meridian = meridian
        from sphfem.fluid.axisymmetric_pair_tension import WALL_COLOUR_90

        #: the walls' colour psi of the pair force (0.5: 90 degrees)
        self.wall_colour = WALL_COLOUR_90 if wall_colour is None else float(wall_colour)
        self._pair = None  # (gamma_k, wall rows, their static normals), set on first use
        #: the rest density of the pair force's K_ij (None: the fluid's median density at
        #: the first evaluation)
        self.rho0 = None if rho0 is None else float(rho0)
        #: the wall plane z of the surface stress' images (meridian "stress"; None: none)
        self.plane = None
        #: meridian "stress": the force function of :mod:`sphfem.fluid.
        #: axisymmetric_surface_stress` (set by its user; that module imports this one)
        self.stress_forces = None
        self.state = None
        self.kappa_m = self.kappa_h = np.zeros(0)
        #: film model, real rows of the last evaluation: weight phi, wall contact, the
        #: film stress (S_rr, S_rz, S_zz) and the film force's acceleration
        self.film_phi = self.film_touch = np.zeros(0)
        self.film_stress = self.film_acc = np.zeros((0, 2))

    def accumulate(self, x, A, rho, kind, offsets, indices, n, src, mtype, R, Lz, acc,
                   lam=None):
        """acc[:n] += CSF acceleration of the real rows.  ``x``, ``A``, ``rho``, ``kind``:
        the augmented set (rows n + q are the mirrors of ``src[q]`` of type ``mtype[q]``,
        fields already filled), its neighbour list ``offsets`` / ``indices`` (radius >= R),
        scalar support ``R``, z period ``Lz`` (0: open)."""
        m = x.shape[0]
        self._R = float(R)
        st = self.state = csf_state(self.state, m, 2)
        if self.meridian == "stress":  # the surface stress (its module) in place of the CSF
            if self.stress_forces is None:
                raise ValueError('meridian = "stress" needs stress_forces = sphfem.fluid.'
                                 'axisymmetric_surface_stress.surface_stress_forces (set '
                                 'by AxisymmetricFluid)')
            acc[:n] += self.stress_forces(self, x, A, rho, kind, n, src, mtype, R, float(Lz),
                                          self.plane)
            return st  # the CSF passes below are not needed
        kc = colour_kinds(kind)
        period = np.array([0.0, float(Lz)])
        ks = kernels.kernel_sigma(self.kernel_code, 2, R)
        kcode = self.kernel_code
        csf_normals(x, A, kc, offsets, indices, R, ks, kcode, period, NORMAL_LO, NORMAL_HI,
                    st.g, st.omega)
        if self.axis_lambda_gate is not None and lam is not None and self.hoop:
            # the axis band's rings with a full support are not surface (module docstring)
            bulk = (np.abs(x[:n, 0]) < self.axis_band[1] * R) & (
                np.asarray(lam, float)[:n] >= self.axis_lambda_gate)
            st.omega[:n][bulk] = 0.0
        mirror_normals(n, src, mtype, st.g, st.omega)
        csf_curvature(x, A, kc, offsets, indices, R, ks, kcode, period, TANGENT_MIN, st.g,
                      st.omega, st.kappa)
        self.kappa_m = st.kappa.copy()
        kh = np.zeros(m)
        a, b = self.axis_band
        if self.hoop:
            hoop_curvature(np.abs(x[:, 0]), st.g, st.omega, self.kappa_m, a * R, b * R, kh)
        self.kappa_h = kh
        if self.meridian == "pair":  # the meridian part is the pair force's (below) away
            # from the axis, the CSF's within PAIR_AXIS_BAND of it
            self._w = self._pair_weight(x)
            st.kappa[:] = kh + (1.0 - self._w) * self.kappa_m
        else:
            st.kappa += kh
        if self.axis_curvature and self.hoop:
            axis_curvature_extension(x, st.kappa, st.omega, kind, n, a * R, b * R, R,
                                     float(Lz))
        mirror_scalar(n, src, st.kappa)
        if self.curvature_smoothing > 1.0:
            smooth_curvature(x, A, st.omega, st.kappa, n, self.curvature_smoothing * R,
                             float(Lz))
            mirror_scalar(n, src, st.kappa)
        work = np.zeros((m, 2))
        if self.meridian == "csf" or self.hoop:
            csf_force(x, A, rho, kc, offsets, indices, R, ks, kcode, period, self.sigma,
                      DELTA_FACTOR, SHEPARD_MIN, st.g, st.omega, st.kappa, st.kbar, work)
        if self.meridian == "pair":
            self.pair_forces(x, A, rho, kind, offsets, indices, n, src, mtype, R, float(Lz),
                             work)
        if not self.film:
            acc[:n] += work[:n]
            return st
        phi, fa = self.film_forces(x, A, rho, kind, offsets, indices, n, src, mtype, R, period)
        acc[:n] += (1.0 - phi)[:, None] * work[:n] + fa
        return st

    def _pair_weight(self, x) -> np.ndarray:
        """Weight of the pair force per augmented row: 1 in planar mode, else smoothstep of
        |r| from PAIR_AXIS_BAND[0] R to PAIR_AXIS_BAND[1] R (the CSF's meridian part takes
        the rest)."""
        from sphfem.fluid.axisymmetric_pair_tension import PAIR_AXIS_BAND

        if not self.hoop:
            return np.ones(x.shape[0])
        R = self._R
        a, b = PAIR_AXIS_BAND
        u = np.clip((np.abs(x[:, 0]) - a * R) / ((b - a) * R), 0.0, 1.0)
        return u * u * (3.0 - 2.0 * u)

    def pair_forces(self, x, A, rho, kind, offsets, indices, n, src, mtype, R, Lz, acc):
        """acc[:n] += the meridian pair force of the real fluid rows
        (:mod:`sphfem.fluid.axisymmetric_pair_tension`); its normals are kept in
        ``pair_normals`` (augmented rows)."""
        from sphfem.fluid import axisymmetric_pair_tension as apt

        m = x.shape[0]
        kind = np.asarray(kind)
        fluid = (kind == FLUID) | (kind == MIRROR_FLUID)
        wall = (kind == WALL) | (kind == MIRROR_WALL)
        col = np.where(fluid, 1.0, np.where(wall, self.wall_colour, 0.0))
        rows = np.flatnonzero(kind[:n] == WALL)
        if self._pair is None or not np.array_equal(self._pair[1], rows):
            fl = np.flatnonzero(kind[:n] == FLUID)
            dx = float(np.sqrt(np.median(A[fl]))) if fl.size else R / 3.0
            if self.rho0 is None:
                self.rho0 = float(np.median(rho[fl])) if fl.size else 1.0
            gk = apt.curvature_constant(self.sigma, self.rho0, R, dx)
            self._pair = (gk, rows, apt.static_wall_normals(x[rows], A[rows], R,
                                                            self.kernel_code, Lz,
                                                            axis=self.hoop))
        gk, rows, static = self._pair
        nrm = np.zeros((m, 2))
        nrm[rows] = self.wall_colour * static
        fac2 = kernels.kernel_sigma(self.kernel_code, 2, R) / (R * R)
        apt.pair_normals(x, A, col, n, offsets, indices, R, fac2, self.kernel_code, Lz, nrm)
        mirror_normals(n, src, mtype, nrm, np.zeros(m))
        self.pair_normals = nrm
        pa = np.zeros((m, 2))
        apt.pair_force(x, A, rho, col, fluid, n, offsets, indices, R,
                       kernels.kernel_sigma(self.kernel_code, 2, R), self.kernel_code, Lz,
                       gk, self.rho0, nrm, pa)
        acc[:n] += self._w[:n, None] * pa[:n]

    def film_forces(self, x, A, rho, kind, offsets, indices, n, src, mtype, R, period):
        """The film model's weight phi and acceleration of the real rows (module docstring,
        "Thin films")."""
        f = self.film_fields(x, A, rho, kind, offsets, indices, n, src, mtype, R, period)
        phi, S, tang, M, tau = f["phi"], f["S"], f["tang"], f["M"], f["tau"]
        m = x.shape[0]
        kcode = self.kernel_code
        fac2 = kernels.kernel_sigma(kcode, 2, R) / (R * R)
        fa = np.zeros((m, 2))
        film_force(x, A, rho, f["fl"], n, offsets, indices, R, fac2, kcode, period, S, phi, fa)
        fa = fa[:n]
        if self.hoop:  # (tau / r)(t_r t - e_r) of the film's in-plane hoop stress, eq. (F3)
            fa += (phi[:n] * self.axis_fade(x[:n, 0], R))[:, None] * film_hoop(
                x[:n], rho[:n], tau[:n], tang[:n], M[:n])
        self.film_acc = fa.copy()
        return phi[:n], fa

    def axis_fade(self, r, R) -> np.ndarray:
        """smoothstep of |r| from axis_band[0] R to axis_band[1] R (0 at the axis)."""
        lo, hi = self.axis_band[0] * R, self.axis_band[1] * R
        u = np.clip((np.abs(r) - lo) / (hi - lo), 0.0, 1.0)
        return u * u * (3.0 - 2.0 * u)

    def film_fields(self, x, A, rho, kind, offsets, indices, n, src, mtype, R, period) -> dict:
        """The film model's fields over the augmented rows (module docstring, "Thin films"):
        fluid-like and wall-like flags ``fl``, ``wl``, fluid-only moment matrices ``M``,
        film tangent ``tang``, weight ``phi``, tension ``tau`` and stress ``S`` = tau t t
        (mirrors filled)."""
        m = x.shape[0]
        kcode = self.kernel_code
        fac2 = kernels.kernel_sigma(kcode, 2, R) / (R * R)
        fl = np.zeros(m, np.bool_)
        wl = np.zeros(m, np.bool_)
        fl[:n] = kind[:n] == FLUID
        wl[:n] = kind[:n] == WALL
        mirror_flags(n, src, mtype, fl, wl)
        M = np.zeros((m, 3))
        dwall = np.full(m, np.inf)
        film_moments(x, A, fl, wl, n, offsets, indices, R, fac2, kcode, period, M, dwall)
        mirror_tensor(n, src, mtype, M)
        Mb = np.zeros((m, 3))
        film_smooth(x, A, fl, n, offsets, indices, R, kernels.kernel_sigma(kcode, 2, R), kcode,
                    period, M, Mb)
        th = 0.5 * np.arctan2(2.0 * Mb[:, 1], Mb[:, 0] - Mb[:, 2])  # larger eigenvector
        tang = np.column_stack([np.cos(th), np.sin(th)])
        ext = np.zeros(m)
        Q = np.zeros(m)
        film_extent(x, A, fl, n, offsets, indices, R, kernels.kernel_sigma(kcode, 1, R), kcode,
                    period, tang, FILM_DIRECTIONS, M, ext, Q)
        sp = np.sqrt(np.maximum(A, 1e-300))
        contact = np.zeros(m)
        u = np.clip(FILM_CONTACT - dwall[:n] / sp[:n], 0.0, 1.0)
        contact[:n] = np.where(fl[:n], u * u * (3.0 - 2.0 * u), 0.0)
        for a in (ext, contact, Q):
            mirror_scalar(n, src, a)
        phi = np.zeros(m)
        touch = np.zeros(m)
        Qm = np.zeros(m)
        film_spread(x, A, fl, n, offsets, indices, R, period, ext, contact, Q, FILM_BAND[0],
                    FILM_BAND[1], phi, touch, Qm)
        mirror_scalar(n, src, touch)  # a second hop: the wall seen across the whole film
        t2 = np.zeros(m)
        film_max(x, fl, n, offsets, indices, R, period, touch, t2)
        touch = t2
        gamma = self.sigma * (2.0 - touch)
        ok = fl.copy()
        ok[n:] = False
        # Q no less than FILM_Q_MIN of a one-row film's (fragments of a few close rings
        # would otherwise get tau ~ 1 / |r|^2 and attract as 1 / |r|)
        Qm = np.maximum(Qm, FILM_Q_MIN * row_moment(sp, R, kcode))
        # a lone ring (no fluid row within R) of area A >= R^2 (near the axis, A = M / (2 pi
        # r rho)) has Q = 0 and a floor of 0: no film stress (a D/dx 61 impact went
        # non-finite from gamma / Q = inf on one at 1.7 t_c)
        tau = np.where(ok & (Qm > 0.0), gamma / np.where(Qm > 0.0, Qm, 1.0), 0.0)
        S = tau[:, None] * np.column_stack([tang[:, 0] ** 2, tang[:, 0] * tang[:, 1],
                                             tang[:, 1] ** 2])
        mirror_tensor(n, src, mtype, S)
        mirror_scalar(n, src, phi)
        self.film_phi = phi[:n].copy()
        self.film_touch = touch[:n].copy()
        self.film_stress = S[:n].copy()
        return dict(fl=fl, wl=wl, M=M, tang=tang, phi=phi, tau=tau, S=S)
