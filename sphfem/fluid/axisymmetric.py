"""Axisymmetric weakly compressible delta-SPH in the (r, z) half-plane.

Particles are rings (:mod:`sphfem.axisymmetric`): constant ring mass M_i, meridian area
A_i = M_i / (2 pi r_i rho_i), planar mass mt_i = rho_i A_i = M_i / (2 pi r_i).  Planar 2D
kernels; F_ij = -W'(d) / d >= 0 so that grad_i W_ij = F_ij (x_j - x_i); u_ij = v_j - v_i.
The axisymmetric equations without swirl (r, z components; Batchelor 1967 app. 2) are

    Drho/Dt = -rho (d_r v_r + d_z v_z) - rho v_r / r                                  (1)
    Dv/Dt   = -grad p / rho + (mu / rho) [lap_2 v + (1/r) d_r v - (v_r / r^2) e_r] + g   (2)

((2) is the Laplacian form of div(2 mu D) / rho for a divergence-free velocity; written as
a stress divergence its radial hoop part is (tau_rr - tau_tt) / r = 2 mu (d_r v_r - v_r / r)
/ r, which for div v = 0 combines with d_r tau_rr + d_z tau_rz into the bracket).  The
planar operators are the SPH sums of :mod:`sphfem.fluid.passes` with planar masses and areas;
the hoop terms are added per particle (the formulation of Petschek & Libersky 1993 with
the reflective axis particles of Garcia-Senz & Relano-Pastor 2012, MNRAS 424, 1585, sec. 2):

    Drho_i/Dt = -rho_i tr(B_i G_i) - rho_i v_r,i / r_i,  G_i = sum_j A_j (v_j - v_i) (x) grad_i W
                + 2 delta h c0 sum_j A_j [(rho_j - rho_i) - (<grad rho>_i + <grad rho>_j)
                  . (x_j - x_i) / 2] F_ij                (fluid pairs; Antuono et al. 2010)
    Dv_i/Dt   = -sum_j mt_j (p_i / rho_i^2 + p_j / rho_j^2) grad_i W_ij            (pressure)
                + sum_j 4 mt_j (mu_i + mu_j) F_ij d_ij^2 u_ij
                  / ((d_ij^2 + eps h^2) (rho_i + rho_j)^2)                  (Morris, lap_2 v)
                + (mu_i / rho_i) [<d_r (v_r / r)>_i e_r + <d_r v_z>_i / r_i e_z]     (hoop)
                + artificial viscosity (alpha h c0, as in passes) + g

The planar divergence is renormalised (B_i below, exact for linear v on any particle
arrangement): the hoop term v_r / r is exact pointwise, and next to it the plain sum
sum_j A_j (v_j - v_i) . grad_i W_ij, whose moment matrix drifts from the identity as the
flow stretches the lattice (rings moving out shrink their area A ~ 1/r), made the two
inconsistent: a drop flattened by v = a (r, -2z) built up spurious pressures of 10-20 rho V^2
and blew up after a stretch of ~2 (tests/test_fluid_axisymmetric.py).  The viscous hoop terms
use (1/r) d_r v_r - v_r / r^2 = d_r (v_r / r): the SPH derivative of the even, smooth
field v_r / r needs no division by r, while <d_r v_r> / r would carry the kernel's
smoothing error of an odd field (3 c R^2 / r for v_r = r^3), which grows as 1/r towards
the axis (first order at the first particle row; measured).  d_r v_z is odd, so its
smoothing error vanishes on the axis and <d_r v_z> / r stays bounded.
<.>: renormalised (B_i = (sum_j A_j F_ij r_ij r_ij)^-1) gradients; where B_i is singular or
worse conditioned than ``cond_max``, or where the smallest eigenvalue of the moment matrix
B_i^-1 (the identity under full support) is below ``renorm_lambda_min`` = 0.2 (a fragment
cut off from the bulk: Marrone et al. 2010, CMAME 199, 3193, classify lambda <= 0.2 as free
surface), the plain sum is used, here and in the continuity's divergence.  B_i amplifies a
fragment's velocity noise by ~1/lambda: in the impact at D/dx = 32 three rim rings with
Shepard sums 0.1-0.17 reached rho = 1.47 rho0 and were thrown out at 40-300 V.  They sum over fluid
neighbours and the walls' ghost velocities.  The delta term is the planar one (a numerical
diffusion; its hoop part (1/r) d_r rho is left out).

Axis: mirror particles (-r, z) of all particles with r < R carry rho, p, mu, A, mt and
(-v_r, v_z) (the ghost velocity of a mirrored wall likewise), so the planar sums near the
axis see an even / odd continuation of the fields.  A particle that crosses the axis in a
step is reflected (r -> -r, v_r -> -v_r).  The hoop terms use r_i itself.  A ring and its
own mirror repel only weakly close to the axis (the kernel gradient vanishes at zero
distance: d W / d q ~ q), while its meridian area A = M / (2 pi r rho) grows as 1 / r: a
ring pushed onto the axis (the apex of the 10 m/s droplet at D/dx 181, r = 0.12 dx at
0.97 t_c) carried an area ~4x the lattice's into its neighbours' divergence, their
density ran away within ten steps (rho 1.6 rho0, p 1.6e7 Pa) and rings were thrown
through the wall.  So a floor ``axis_floor`` (the scene module sets a quarter of the
fluid's spacing, the lattice's first column sitting at half of it) reflects the rings
like the axis does: r < r_f -> 2 r_f - r, an inward v_r reversed; A then stays below
about twice the lattice's.

Hoop term of the continuity (``smooth_hoop``, default): v_r / r is replaced by its Shepard
average over the fluid and its mirrors, <v_r / r>_i = sum_j A_j W_ij (v_r / r)_j / sum_j
A_j W_ij (self included).  The particle's own v_r,i / r_i turns a radial velocity
fluctuation of one ring next to the axis into a density rate amplified by 1 / r_i: in a
droplet impact (D/dx = 16, 10 m/s) the rings of the first column went to -1.5 rho V^2 at
0.4 t_c, were pulled through the wall layers at the axis-wall corner and the run blew up at
~0.9 t_c; with the average the run is stable to 4 t_c.  v_r / r is even and smooth, so the
average is exact for v_r = a r and second order otherwise (v_r = r^3: test).

Optional: ``adaptive_h`` (R_i ~ sqrt(A_i), the pair kernel at (R_i + R_j) / 2, no grad-h
terms), ``wall_normals`` (the continuity's divergence sees the free-slip ghost of the wall,
:meth:`_divergence_velocity`; with the wall's own velocity 0 the normal compression at the
wall is underestimated and rings sink into the wall layers).  Status (issue 16): with all
three the droplet impact follows the 3D run at equal spacing to within 3-13 % in spread
diameter (examples/axisymmetric/droplet_crosscheck.py).  NOT yet robust at fine spacing
(examples/axisymmetric/impact_robustness.py, 10 m/s, c0 = 10 V).  Two causes found at
D/dx = 32: (a) the lamella tip's negative pressure, copied onto the wall by the Adami
extrapolation, pulls contact-line rings into the wall (-1 V^2/dx at 0.25 t_c), and once
inside nothing pushes them out (the wall copies their pressure, the ghost velocities above
and below cancel in the divergence); (b) rim fragments with Shepard sums 0.1-0.17 whose
renormalised divergence amplified velocity noise ~1/lambda (rho 1.47 rho0, thrown out at
40-300 V).  ``renorm_lambda_min`` (on) removes (b) without changing the D/dx = 16
cross-check; ``no_penetration`` (opt-in) removes (a).  With both and fixed h the D/dx = 32
impact runs clean to 4 t_c at 10 and 30 m/s; still failing: adaptive h at D/dx = 32
(tension -10 rho V^2 next to the axis), fixed h at D/dx = 16 (blow-up at 3.2 t_c), and an
isolated rim ring at mu = 3e-4 whose density decays to 0.03 rho0.  Also
validated: hydrostatic column,
Hagen-Poiseuille start-up, prescribed-field kernel tests, a free drop flattened into a sheet;
the planar mode equals the 2D :class:`~sphfem.fluid.wcsph.FluidSolver` to round-off.

Walls: Adami, Hu & Adams (2012) as in :mod:`sphfem.fluid.walls_adami2012`, with the planar
kernel sums of the meridian plane (wall particles have a fixed meridian area ``vol``).
Time stepping: the predictor-corrector position Verlet of :mod:`sphfem.fluid.wcsph`.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.axisymmetric import MIRROR_FLUID, MIRROR_WALL  # noqa: F401  (re-exported)
from sphfem.fluid.axisymmetric_surface_tension import (
    AxisymmetricCSF,
    mirror_normals,
    mirror_scalar,
)
from sphfem.fluid.axisymmetric_wall_slip import MODES as SLIP_MODES
from sphfem.fluid.axisymmetric_wall_slip import slip_ghost_rz
from sphfem.fluid.eos import tait_B, tait_density, tait_pressure
from sphfem.fluid.no_penetration import NoPenetration
from sphfem.fluid.wcsph import FluidParams
from sphfem.neighbors import build_neighbor_list, min_image
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import invert_sym3

#: kind code of the inert rings (debris): beyond every pair filter's masks, so no list
#: holds them (sphfem.neighbors.build_neighbor_list)
INERT = 6


def _keep_masks():
    keep = [0] * (MIRROR_WALL + 1)
    keep[FLUID] = (1 << FLUID) | (1 << WALL) | (1 << MIRROR_FLUID) | (1 << MIRROR_WALL)
    keep[WALL] = (1 << FLUID) | (1 << MIRROR_FLUID)
    return tuple(keep)


KEEP = _keep_masks()


@njit(cache=True, inline="always")
def _isfluid(k):
    return k == FLUID or k == MIRROR_FLUID


@njit(cache=True, parallel=True)
def wall_state(x, v, rho, p, A, kind, offsets, indices, Rp, kcode, Lz, gravity, rho0, B,
               gamma, vg, p_min=-np.inf):
    """Adami wall pressure, density and ghost velocity of the real WALL rows (planar kernel
    in the meridian plane, support (R_i + R_j) / 2; walls at rest, no prescribed
    acceleration); the pressure not below ``p_min`` (0: the wall pushes, never pulls)."""
    for i in prange(x.shape[0]):
        if kind[i] != WALL:
            continue
        sw = 0.0
        sp = 0.0
        sh = 0.0
        sv0 = 0.0
        sv1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not _isfluid(kind[j]):
                continue
            r0 = x[i, 0] - x[j, 0]
            r1 = min_image(x[i, 1] - x[j, 1], Lz)
            d2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[j])
            if d2 >= R * R:
                continue
            w = kernels.kernel_f(math.sqrt(d2) / R, kcode) * A[j] / (R * R)
            sw += w
            sp += p[j] * w
            sh += rho[j] * w * (gravity[0] * r0 + gravity[1] * r1)
            sv0 += v[j, 0] * w
            sv1 += v[j, 1] * w
        if sw > 0.0:
            pw = max((sp + sh) / sw, p_min)
            p[i] = pw
            rho[i] = max(tait_density(pw, rho0, B, gamma), 0.5 * rho0)
            vg[i, 0] = 2.0 * v[i, 0] - sv0 / sw
            vg[i, 1] = 2.0 * v[i, 1] - sv1 / sw
        else:
            p[i] = 0.0
            rho[i] = rho0
            vg[i, 0] = v[i, 0]
            vg[i, 1] = v[i, 1]


@njit(cache=True)
def _clip_surface_walls(x, p, rho, kind, offsets, indices, Rp, Lz, clip, rho0, B, gamma):
    """Wall rows lose tension next to flagged fluid rings (``wall_tension = "bulk"`` or
    ``"contact-line"``): a WALL row with negative pressure and fluid rings j within the pair
    support has p <- p (1 - max_j clip_j) (``clip`` in [0, 1] over the augmented rows) and
    its density the equation of state's for it (clip 1: p = 0, rho = rho0)."""
    for i in range(x.shape[0]):
        if kind[i] != WALL or p[i] >= 0.0:
            continue
        cmax = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if clip[j] <= cmax:
                continue
            r0 = x[i, 0] - x[j, 0]
            r1 = min_image(x[i, 1] - x[j, 1], Lz)
            R = 0.5 * (Rp[i] + Rp[j])
            if r0 * r0 + r1 * r1 < R * R:
                cmax = clip[j]
        if cmax >= 1.0:
            p[i] = 0.0
            rho[i] = rho0
        elif cmax > 0.0:
            p[i] *= 1.0 - cmax
            rho[i] = tait_density(p[i], rho0, B, gamma)


@njit(cache=True, parallel=True)
def mean_area(x, A, kind, offsets, indices, Rp, kcode, Lz, out):
    """Number-weighted mean meridian area of the fluid around each real FLUID row,
    out_i = sum_j A_j W_ij / sum_j W_ij over the fluid and its mirrors, self included
    (pair support (R_i + R_j) / 2).  Both sums lose the same share of the support at a free
    surface, so their ratio, the local spacing squared, does not (unlike A_i / Shepard)."""
    for i in prange(x.shape[0]):
        if kind[i] != FLUID:
            out[i] = A[i]
            continue
        w0 = kernels.kernel_f(0.0, kcode) / (Rp[i] * Rp[i])
        sw = w0
        sa = w0 * A[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not _isfluid(kind[j]):
                continue
            r0 = x[j, 0] - x[i, 0]
            r1 = min_image(x[j, 1] - x[i, 1], Lz)
            d2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[j])
            if d2 >= R * R:
                continue
            w = kernels.kernel_f(math.sqrt(d2) / R, kcode) / (R * R)
            sw += w
            sa += w * A[j]
        out[i] = sa / sw


@njit(cache=True, parallel=True)
def gradients(x, rho, vg, A, kind, offsets, indices, Rp, s2, kcode, Lz, cond_max, lam_min,
              grad_rho, dvdr, shep, Bm, qs, gc, qv, count, pair_j, pair_d, pair_k):
    """Renormalised <grad rho>, <d_r (v_r / r)> and <d_r v_z> (``dvdr[:, 0]``, ``[:, 1]``)
    of the real FLUID rows.

    ``vg``: the velocity seen by the viscous terms (fluid: v, wall: Adami ghost velocity,
    mirrors: the source's with v_r negated).  Rows that are not fluid are zeroed.  Pair
    support (R_i + R_j) / 2, kernel normalisation ``s2`` / R^2.  ``qs``: the Shepard
    average over the fluid (and its mirrors), self included, of v_r / r.  ``gc``: grad C_i =
    sum_j A_j grad_i W_ij over every neighbour (particle shifting).  ``qv``: vg_r / r of
    every row (any value where r = 0; :func:`hoop_ratio`).  The pair factors of a support
    R_ij are computed when R_ij changes along the row (once for fixed h).  The pairs within
    their support (d_ij < R_ij, d_ij > 0) are packed, in list order, at the start of each
    fluid row's list slots: ``pair_j`` (j), ``pair_d`` (d_ij), ``pair_k`` (f'(d_ij / R_ij),
    the kernel shape's derivative), ``count[i]`` of them (:func:`forces` reads them).
    """
    for i in prange(x.shape[0]):
        grad_rho[i, 0] = 0.0
        grad_rho[i, 1] = 0.0
        dvdr[i, 0] = 0.0
        dvdr[i, 1] = 0.0
        count[i] = 0
        if kind[i] != FLUID:
            continue
        m00 = 0.0
        m01 = 0.0
        m11 = 0.0
        g0 = 0.0
        g1 = 0.0
        a0 = 0.0  # sum A F (q_j - q_i) r_ij, q = v_r / r
        a1 = 0.0
        qi = vg[i, 0] / x[i, 0]
        shep[i] = A[i] * s2 / (Rp[i] * Rp[i])  # Shepard sum, self included
        b0 = 0.0  # sum A F (v_z,j - v_z,i) r_ij
        b1 = 0.0
        gc0 = 0.0  # sum A F r_ij = grad C
        gc1 = 0.0
        wq = shep[i]
        sq = wq * qi
        Rc = -1.0  # the support of the cached pair factors
        sigma = 0.0
        fac = 0.0
        pos = offsets[i]
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0 = x[j, 0] - x[i, 0]
            r1 = min_image(x[j, 1] - x[i, 1], Lz)
            d2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[j])
            if d2 >= R * R or d2 == 0.0:
                continue
            if R != Rc:
                Rc = R
                sigma = s2 / (R * R)
                fac = sigma / R
            d = math.sqrt(d2)
            kd = kernels.kernel_dfdq(d / R, kcode)
            pair_j[pos] = j
            pair_d[pos] = d
            pair_k[pos] = kd
            pos += 1
            s = A[j] * (-fac * kd / d)
            m00 += s * r0 * r0
            m01 += s * r0 * r1
            m11 += s * r1 * r1
            gc0 += s * r0
            gc1 += s * r1
            t = s * (rho[j] - rho[i])
            g0 += t * r0
            g1 += t * r1
            qj = qv[j] if x[j, 0] != 0.0 else qi
            u = s * (qj - qi)
            a0 += u * r0
            a1 += u * r1
            u = s * (vg[j, 1] - vg[i, 1])
            b0 += u * r0
            b1 += u * r1
            w = A[j] * sigma * kernels.kernel_f(d / R, kcode)
            shep[i] += w
            if _isfluid(kind[j]):
                wq += w
                sq += w * qj
        count[i] = pos - offsets[i]
        qs[i] = sq / wq
        gc[i, 0] = gc0
        gc[i, 1] = gc1
        good, c00, c01, c02, c10, c11, c12, c20, c21, c22 = invert_sym3(
            m00, m01, 0.0, m11, 0.0, 1.0, 2, cond_max)
        # smallest eigenvalue of the moment matrix (the identity under full support)
        lam = 0.5 * (m00 + m11 - math.sqrt((m00 - m11) ** 2 + 4.0 * m01 * m01))
        Bm[i, 3] = 1.0 if lam < lam_min else 0.0  # a fragment (see forces)
        Bm[i, 4] = lam
        good = good and lam >= lam_min
        Bm[i, 0] = c00 if good else 1.0
        Bm[i, 1] = c01 if good else 0.0
        Bm[i, 2] = c11 if good else 1.0
        if good:
            grad_rho[i, 0] = c00 * g0 + c01 * g1
            grad_rho[i, 1] = c10 * g0 + c11 * g1
            dvdr[i, 0] = c00 * a0 + c01 * a1
            dvdr[i, 1] = c00 * b0 + c01 * b1
        else:
            grad_rho[i, 0] = g0
            grad_rho[i, 1] = g1
            dvdr[i, 0] = a0
            dvdr[i, 1] = b0


@njit(cache=True, parallel=True)
def forces(x, v, vg, vd, rho, p, A, mt, mu, kind, grad_rho, dvdr, offsets, indices, Rp, s2,
           kcode, Lz, gravity, eps, delta_c, alpha_c, hoop, Bm, qh, frag_no_hoop, fw,
           wall_art, acc, drho, gradv, prr, count, pair_j, pair_d, pair_k):
    """Accelerations and density rates of the real FLUID rows (module docstring); other
    rows are zeroed.  ``hoop``: 1.0, or 0.0 to drop the hoop terms (planar mode).  Arrays
    run over the augmented set (real + mirrors, fields filled).  Pair support R_ij =
    (R_i + R_j) / 2 and h_ij = R_ij / 2 (kernel ``s2`` / R_ij^2 W(d / R_ij), the viscous
    eps h_ij^2, the delta term delta_c h_ij, the artificial viscosity (alpha_c,i +
    alpha_c,j) h_ij / 2, ``alpha_c`` per row: alpha c0, raised next to the axis by
    ``axis_alpha``).  Wall
    pairs: the viscous term times ``fw[i]`` (:mod:`sphfem.fluid.wall_layer`), the artificial
    viscosity times ``wall_art`` (1 or 0).  ``gradv[i]`` = (L00, L01, L10, L11), the
    renormalised velocity gradient L_ab = d v_a / d x_b of the continuity's velocity.
    ``prr``: p / rho^2 of every row (:func:`pressure_ratio`).  The pair factors of a support
    R_ij are computed when R_ij changes along the row (once for fixed h).  The pairs are
    those :func:`gradients` packed (``count``, ``pair_j``, ``pair_d``, ``pair_k``: the
    list's pairs within their support, in list order, with d_ij and f'(d_ij / R_ij))."""
    for i in prange(x.shape[0]):
        acc[i, 0] = 0.0
        acc[i, 1] = 0.0
        drho[i] = 0.0
        if kind[i] != FLUID:
            continue
        ri = rho[i]
        pri = p[i] / (ri * ri)
        mui = mu[i]
        rr = x[i, 0]
        a0 = 0.0
        a1 = 0.0
        G00 = 0.0  # sum_j A_j F_ij (v_j - v_i)_a (x_j - x_i)_b
        G01 = 0.0
        G10 = 0.0
        G11 = 0.0
        diff = 0.0
        Rc = -1.0  # the support of the cached pair factors
        hij = 0.0
        eps2 = 0.0
        fac = 0.0
        for jj in range(offsets[i], offsets[i] + count[i]):
            j = pair_j[jj]
            r0 = x[j, 0] - x[i, 0]
            r1 = min_image(x[j, 1] - x[i, 1], Lz)
            d2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[j])
            if R != Rc:
                Rc = R
                hij = 0.5 * R
                eps2 = eps * hij * hij
                fac = s2 / (R * R * R)
            art_coef = 0.5 * (alpha_c[i] + alpha_c[j]) * hij
            F = -fac * pair_k[jj] / pair_d[jj]
            rj = rho[j]
            fl = _isfluid(kind[j])
            mj = mt[j]
            cp = -mj * (pri + prr[j]) * F
            muj = mu[j] if fl else mui
            rs = ri + rj
            inv = 1.0 / ((d2 + eps2) * rs * rs)
            cv = 4.0 * (mui + muj) * mj * F * d2 * inv
            if not fl:
                cv *= fw[i]
                art_coef *= wall_art
            u0 = vg[j, 0] - v[i, 0]
            u1 = vg[j, 1] - v[i, 1]
            cp += 2.0 * art_coef * mj * F * (u0 * r0 + u1 * r1) * rs * inv
            a0 += cp * r0 + cv * u0
            a1 += cp * r1 + cv * u1
            VF = A[j] * F
            w0 = VF * (vd[j, 0] - v[i, 0])
            w1 = VF * (vd[j, 1] - v[i, 1])
            G00 += w0 * r0
            G01 += w0 * r1
            G10 += w1 * r0
            G11 += w1 * r1
            if fl:
                gs = (grad_rho[i, 0] + grad_rho[j, 0]) * r0 + (grad_rho[i, 1]
                                                               + grad_rho[j, 1]) * r1
                diff += ((rj - ri) - 0.5 * gs) * VF * delta_c * hij
        nu = mui / ri
        # div_2 v = tr(G B): renormalised (B = identity: the plain sum)
        cont = -(G00 * Bm[i, 0] + (G01 + G10) * Bm[i, 1] + G11 * Bm[i, 2])
        # L = -G B (cont = -tr L): the sign the wall layer's eq. (2) reads
        gradv[i, 0] = G00 * Bm[i, 0] + G01 * Bm[i, 1]
        gradv[i, 1] = G00 * Bm[i, 1] + G01 * Bm[i, 2]
        gradv[i, 2] = G10 * Bm[i, 0] + G11 * Bm[i, 1]
        gradv[i, 3] = G10 * Bm[i, 1] + G11 * Bm[i, 2]
        acc[i, 0] = a0 + hoop * nu * dvdr[i, 0] + gravity[0]
        acc[i, 1] = a1 + hoop * nu * dvdr[i, 1] / rr + gravity[1]
        if Bm[i, 3] != 0.0 and frag_no_hoop:  # a fragment: no hoop term (fragment_hoop)
            drho[i] = ri * cont + 2.0 * diff
        else:
            drho[i] = ri * cont - hoop * ri * qh[i] + 2.0 * diff


@njit(cache=True)
def _predict(fidx, x, v, rho, acc, drho, h, v_n, rho_n, lam, hold_r, rho0):
    """The predictor of :meth:`AxisymmetricFluid.step` on the fluid rows ``fidx``: keeps v
    and rho in ``v_n``, ``rho_n``; x += h v, v += h a, rho += h Drho/Dt (h = dt / 2), then
    rho = rho0 where rho < rho0, lam < 0.75 and |r| < ``hold_r`` (the surface hold,
    :meth:`AxisymmetricFluid.surface_hold_radius`; 0: off)."""
    for q in range(fidx.shape[0]):
        i = fidx[q]
        v_n[q, 0] = v[i, 0]
        v_n[q, 1] = v[i, 1]
        rho_n[q] = rho[i]
        x[i, 0] += h * v[i, 0]
        x[i, 1] += h * v[i, 1]
        v[i, 0] += h * acc[i, 0]
        v[i, 1] += h * acc[i, 1]
        rho[i] += h * drho[i]
        if lam[i] < 0.75 and rho[i] < rho0 and abs(x[i, 0]) < hold_r:
            rho[i] = rho0


@njit(cache=True)
def _correct(fidx, x, v, rho, acc, drho, dt, h, v_n, rho_n, lam, hold_r, rho0):
    """The corrector of :meth:`AxisymmetricFluid.step`: v = v_n + dt a, rho = rho_n + dt
    Drho/Dt, the surface hold as in :func:`_predict`, x += h v."""
    for q in range(fidx.shape[0]):
        i = fidx[q]
        v[i, 0] = v_n[q, 0] + dt * acc[i, 0]
        v[i, 1] = v_n[q, 1] + dt * acc[i, 1]
        rho[i] = rho_n[q] + dt * drho[i]
        if lam[i] < 0.75 and rho[i] < rho0 and abs(x[i, 0]) < hold_r:
            rho[i] = rho0
        x[i, 0] += h * v[i, 0]
        x[i, 1] += h * v[i, 1]


@njit(cache=True)
def _reflect_axis(fidx, x, v, plane, zw, r_floor):
    """Fluid rows with r < 0 reflected across the axis (r, v_r negated), then rows with r <
    ``r_floor`` across r = r_floor (r -> 2 r_floor - r, an inward v_r reversed; module
    docstring, "Axis"); with ``plane``, rows below z = ``zw`` reflected across that plane
    (z -> 2 zw - z, v_z negated)."""
    for q in range(fidx.shape[0]):
        i = fidx[q]
        if x[i, 0] < 0.0:
            x[i, 0] *= -1.0
            v[i, 0] *= -1.0
        if x[i, 0] < r_floor:
            x[i, 0] = 2.0 * r_floor - x[i, 0]
            if v[i, 0] < 0.0:
                v[i, 0] = -v[i, 0]
    if plane:
        for q in range(fidx.shape[0]):
            i = fidx[q]
            if x[i, 1] < zw:
                x[i, 1] = 2.0 * zw - x[i, 1]
                v[i, 1] *= -1.0


@njit(cache=True)
def _fluid_extrema(fidx, v, acc, Rp, rho):
    """(max |v|, max |a|, min R_i, min rho) over the fluid rows (:meth:`dt_limits`)."""
    vmax = -np.inf
    amax = -np.inf
    rmin = np.inf
    rhomin = np.inf
    for q in range(fidx.shape[0]):
        i = fidx[q]
        vmax = max(vmax, math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2))
        amax = max(amax, math.sqrt(acc[i, 0] ** 2 + acc[i, 1] ** 2))
        rmin = min(rmin, Rp[i])
        rhomin = min(rhomin, rho[i])
    return vmax, amax, rmin, rhomin


@njit(cache=True)
def _all_finite(fidx, x, rho):
    """True when the positions and densities of the fluid rows are finite."""
    for q in range(fidx.shape[0]):
        i = fidx[q]
        if not (np.isfinite(x[i, 0]) and np.isfinite(x[i, 1]) and np.isfinite(rho[i])):
            return False
    return True


@njit(cache=True)
def scatter_state(idx, fluid, x, v, rho, p, f, px, pv, prho, pp, pm, pvol, pf):
    """Copy the solver's rows onto the particle set's rows ``idx``: x, v, rho, p, the ring
    forces ``f`` (0 on fluid rows) and vol = m / rho on the fluid rows (``fluid`` mask of
    the solver's rows): the write-back of the scene's fluid module
    (:class:`sphfem.axisymmetric_scene.AxisymmetricFluidModule`)."""
    for q in range(idx.shape[0]):
        i = idx[q]
        px[i, 0] = x[q, 0]
        px[i, 1] = x[q, 1]
        pv[i, 0] = v[q, 0]
        pv[i, 1] = v[q, 1]
        prho[i] = rho[q]
        pp[i] = p[q]
        if fluid[q]:
            pvol[i] = pm[i] / prho[i]
            pf[i, 0] = 0.0
            pf[i, 1] = 0.0
        else:
            pf[i, 0] = f[q, 0]
            pf[i, 1] = f[q, 1]


@njit(cache=True)
def changed_velocities(rows, v, v_n, acc, dt):
    """The positions k in ``rows`` whose velocity is not v_n + dt a (a reflection or the
    no-penetration correction changed it after the corrector): the rows with
    max |v - (v_n + dt a)| > 0 (a NaN component: not counted, as numpy's max)."""
    out = np.empty(rows.shape[0], np.int64)
    c = 0
    for k in range(rows.shape[0]):
        i = rows[k]
        d0 = v[i, 0] - (v_n[i, 0] + dt * acc[i, 0])
        d1 = v[i, 1] - (v_n[i, 1] + dt * acc[i, 1])
        if d0 != d0 or d1 != d1:
            continue
        if abs(d0) > 0.0 or abs(d1) > 0.0:
            out[c] = k
            c += 1
    return out[:c]


@njit(cache=True)
def _mirror_positions(n, src, mtype, zw, x):
    """The positions of the mirrors n + q (those of :func:`_fill_mirrors`, alone)."""
    for q in range(src.shape[0]):
        s = src[q]
        g = n + q
        if mtype[q] == 0:
            x[g, 0] = -x[s, 0]
            x[g, 1] = x[s, 1]
        else:
            x[g, 0] = x[s, 0]
            x[g, 1] = 2.0 * zw - x[s, 1]


@njit(cache=True)
def _shift_inputs(gc, B, lam, kind, Rp, lam_min, gcs, nrm, near, kind_out, lam_near=0.75):
    """The per-row inputs of :func:`sphfem.fluid.surface.shift_displacement` for
    :meth:`AxisymmetricFluid._shift` (rows of ``gc``): the outward normal -b / |b|, b = B
    grad C (-b where |b| = 0), ``near`` = lambda < ``lam_near`` and not a fragment (lambda
    <= ``lam_min``), grad C h_i / h_max, fragments' kind set to WALL (no shift).  Returns
    (h_max, h_min), h = R_i / 2."""
    n = gc.shape[0]
    hmax = -np.inf
    hmin = np.inf
    for i in range(n):
        h = 0.5 * Rp[i]
        hmax = max(hmax, h)
        hmin = min(hmin, h)
    for i in range(n):
        b0 = B[i, 0] * gc[i, 0] + B[i, 1] * gc[i, 1]
        b1 = B[i, 1] * gc[i, 0] + B[i, 2] * gc[i, 1]
        nb = math.sqrt(b0 ** 2 + b1 ** 2)
        den = nb if nb > 0.0 else 1.0
        nrm[i, 0] = -b0 / den
        nrm[i, 1] = -b1 / den
        fragment = lam[i] <= lam_min
        near[i] = lam[i] < lam_near and not fragment
        f = (0.5 * Rp[i]) / hmax
        gcs[i, 0] = gc[i, 0] * f
        gcs[i, 1] = gc[i, 1] * f
        kind_out[i] = WALL if fragment else kind[i]
    return hmax, hmin


@njit(cache=True)
def hoop_ratio(x, vg, out):
    """out_j = vg_r,j / r_j (0 where r_j = 0): the q_j of :func:`gradients`, once per row."""
    for j in range(x.shape[0]):
        out[j] = vg[j, 0] / x[j, 0] if x[j, 0] != 0.0 else 0.0


@njit(cache=True)
def pressure_ratio(p, rho, out):
    """out_j = p_j / rho_j^2 (the pressure term's p_j / (rho_j rho_j) of :func:`forces`; 0
    where rho_j = 0)."""
    for j in range(p.shape[0]):
        out[j] = p[j] / (rho[j] * rho[j]) if rho[j] != 0.0 else 0.0


@njit(cache=True)
def _fill_mirrors(n, src, mtype, zw, gz, x, v, vg, rho, p, A, mt, mu, grad_rho, dvdr, Rp):
    """Copy the sources' fields onto the mirrors n + q, in order (a source may be an earlier
    mirror).  ``mtype`` 0: image across the axis (r, v_r, vg_r, grad_r rho and the
    r-derivatives in ``dvdr`` negated); 1: image across the wall plane z = ``zw`` (z,
    v_z, grad_z rho and d_r v_z negated; the viscous velocity vg = -v: no slip; p
    hydrostatically corrected with the body force ``gz``)."""
    for q in range(src.shape[0]):
        s = src[q]
        g = n + q
        rho[g] = rho[s]
        A[g] = A[s]
        Rp[g] = Rp[s]
        mt[g] = mt[s]
        mu[g] = mu[s]
        if mtype[q] == 0:
            x[g, 0] = -x[s, 0]
            x[g, 1] = x[s, 1]
            v[g, 0] = -v[s, 0]
            v[g, 1] = v[s, 1]
            vg[g, 0] = -vg[s, 0]
            vg[g, 1] = vg[s, 1]
            p[g] = p[s]
            grad_rho[g, 0] = -grad_rho[s, 0]
            grad_rho[g, 1] = grad_rho[s, 1]
            dvdr[g, 0] = -dvdr[s, 0]
            dvdr[g, 1] = -dvdr[s, 1]
        else:
            x[g, 0] = x[s, 0]
            x[g, 1] = 2.0 * zw - x[s, 1]
            v[g, 0] = v[s, 0]
            v[g, 1] = -v[s, 1]
            vg[g, 0] = -vg[s, 0]
            vg[g, 1] = -vg[s, 1]
            p[g] = p[s] + rho[s] * gz * (x[g, 1] - x[s, 1])
            grad_rho[g, 0] = grad_rho[s, 0]
            grad_rho[g, 1] = -grad_rho[s, 1]
            dvdr[g, 0] = dvdr[s, 0]
            dvdr[g, 1] = -dvdr[s, 1]


@njit(cache=True)
def _free_slip_ghost(v, vg, kind, nrm, src, mtype, vd):
    """vd_w = ṽ - 2 ((ṽ - v_w) . n_w) n_w, ṽ = 2 v_w - vg_w, at the real WALL rows (``kind``
    and ``nrm`` over the real rows), then copied with v_r negated onto their axis mirrors
    (:meth:`AxisymmetricFluid._divergence_velocity`)."""
    n = kind.shape[0]
    for i in range(n):
        if kind[i] != WALL:
            continue
        vt0 = 2.0 * v[i, 0] - vg[i, 0]
        vt1 = 2.0 * v[i, 1] - vg[i, 1]
        un = (vt0 - v[i, 0]) * nrm[i, 0] + (vt1 - v[i, 1]) * nrm[i, 1]
        vd[i, 0] = vt0 - 2.0 * un * nrm[i, 0]
        vd[i, 1] = vt1 - 2.0 * un * nrm[i, 1]
    for q in range(src.shape[0]):
        s = src[q]
        if s < n and mtype[q] == 0 and kind[s] == WALL:
            vd[n + q, 0] = -vd[s, 0]
            vd[n + q, 1] = vd[s, 1]


class AxisymmetricFluid:
    """Stand-alone axisymmetric delta-SPH fluid with Adami walls (module docstring).

    ``x`` (n, 2) positions (r >= 0, z), ``v`` (n, 2), ``rho`` (n,), ``kind`` FLUID or WALL
    (walls at rest), ``M`` ring masses of the fluid particles [kg] (walls: ignored),
    ``vol`` meridian areas of the wall particles [m^2] (fluid: ignored), support radius
    ``R``, ``params`` (:class:`~sphfem.fluid.wcsph.FluidParams`: rho0, c0, gamma, mu, delta,
    alpha, gravity (g_r, g_z), cfl, visc_cfl, force_cfl, eps_visc, cond_max are used);
    ``periodic_z = (z0, Lz)``: z periodic on [z0, z0 + Lz) (None: open).

    ``wall_z``: a no-slip wall plane z = wall_z below the fluid, modelled by mirror images of
    the fluid (normal velocity negated for the continuity and pressure terms, both components
    for the viscous term; Marrone et al. 2011, sec. 3.2, for delta-SPH) instead of wall
    particles (None: no wall plane).

    ``no_penetration`` (default off; acts only with ``wall_normals``): the kinematic wall
    condition on the position update (:mod:`sphfem.fluid.no_penetration`: a ring found under
    the wall surface is put back on it and loses its inward normal velocity; masses
    unchanged).  It moves rings without a wall force, so a wall-impulse budget must count
    it.  Measured (examples/axisymmetric/impact_robustness.py, 10 m/s, c0 = 10 V): with
    fixed h the D/dx = 32 impact runs clean to 4 t_c only with it (and
    ``renorm_lambda_min``); with adaptive h at D/dx = 16 it makes the lamella noisier
    (p_min -7 vs -2 rho V^2 at 0.4 t_c) and a ring is thrown out, so it is not the default.
    ``renorm_lambda_min``: see the module docstring (0: the old behaviour).
    ``fragment_hoop=False``: on fragments (lambda_min < ``renorm_lambda_min``: isolated
    rings, one-ring sheets, small clusters) the continuity drops its hoop term and keeps the
    meridional divergence and the delta term.  A free ring cannot show the meridional
    spreading that balances -rho v_r / r in a real fluid element, so with the hoop term it
    follows rho r = const: flying out it fell to 0.01-0.03 rho0 (the one-ring rim sheets of
    the D/dx = 32-64 impacts), flying in it reached 2-3 rho0 (a spray ring bouncing next to
    the axis at D/dx = 181, 10 m/s, then fell onto the lamella at ~1.9 t_c with ~1e3 rho V^2
    and blew its centre open).  Colliding fragments still compress and push apart: an
    earlier variant (Drho/Dt = the delta term alone on fragments) had a spray ring at
    1600 m/s (160 V) by 1 t_c in that run, which then set the acoustic step (8x smaller).

    ``adaptive_h="mean-area"``: R_i = R sqrt(<A>_i / a_ref) from the number-weighted mean
    area of the fluid around the ring (:func:`mean_area`, of the previous evaluation) in
    place of its own area: a first-column ring carried out along the wall keeps the
    support of its neighbours (its own area shrinks ~ r0 / r).
    ``shifting`` (A > 0): particle shifting after each step (:meth:`_shift`).
    ``wall_tension=False``: the walls' extrapolated pressure is clipped at 0 (the wall
    pushes, never pulls: the lamella tip's tension is not copied onto the wall);
    ``"bulk"`` (experimental): clipped only on the wall rows with a free-surface ring
    (lambda_min < ``shift_surface_lambda``, previous evaluation) within their support, so
    the tension stays under bulk fluid (the axis-wall corner) and goes at a contact line,
    where it is the kernel's truncation.  ``"contact-line"`` (experimental): clipped in
    proportion to the contact-line weight of the fluid rings in the wall row's support
    (:func:`sphfem.fluid.wall_layer.contact_line_weight`: 1 at the end of a wall row, 0 under
    a film, however thin; previous step), so a thin film keeps its tension everywhere but at
    its edge; needs ``wall_normals``.
    ``free_surface_no_tension``: rings at or next to the free surface are held at rho >=
    rho0 (:meth:`surface_hold_radius`).
    Measured with the three together (examples/axisymmetric/robustness_results.md): the
    D/dx = 32, 10 m/s impact without surface tension keeps |p| < 0.5 rho V^2 to 2.7 t_c
    (without them: spikes of 13-50 rho V^2 and a blow-up at 2.4 t_c).

    ``wall_friction``: "sph" (the no-slip viscous term and the artificial viscosity on wall
    pairs), "viscous" (the no-slip viscous term alone) or "layer" (the viscous term times the
    unresolved-layer factor of :mod:`sphfem.fluid.wall_layer`, no artificial viscosity on
    wall pairs; needs ``wall_normals``) or "none" (free slip: neither term on wall pairs; the
    walls push only through the pressure, e.g. for the dewetting check of
    ``examples/axisymmetric/taylor_culick.py --wall``).
    ``wall_slip`` ("no-slip", "free-slip" or "navier" with ``slip_length`` b [m];
    ``wall_friction = "viscous"``): the tangential part of the walls' ghost velocity in the
    viscous terms follows a Navier slip (:mod:`sphfem.fluid.axisymmetric_wall_slip`); the
    continuity's divergence keeps Adami's ghost.

    ``planar=True``: plain 2D SPH in the (x, y) = (r, z) plane with a symmetry plane at
    x = 0 (the same mirrors), ``M`` then the planar masses [kg/m]: no hoop terms, A = M / rho
    (for cross-checks against :class:`~sphfem.fluid.wcsph.FluidSolver` in 2D).

    ``surface_tension``: sigma [N/m] of the CSF force with the hoop curvature
    (:mod:`sphfem.fluid.axisymmetric_surface_tension`); 0: off.  ``film_tension``: its
    thin-film model (same module, "Thin films"; default off).  ``csf_axis_curvature``: the
    CSF's axis band takes its curvature from the band's edge (same module, "Curvature at
    the axis"; default off).  ``csf_curvature_smoothing``: the CSF's curvature averaged
    along the surface over this many supports (same module, "Curvature smoothing"; 1: off).
    ``csf_meridian``: "csf" (default) or "pair": the meridian curvature's part of the force
    as the pair force of :mod:`sphfem.fluid.axisymmetric_pair_tension` (the hoop part stays
    the CSF's); with it ``free_surface_no_tension`` holds only the rings next to the axis,
    where the CSF's meridian part acts (the pair force's tension lives in the surface
    rings' pressure); or "stress": the whole surface force as the divergence of a surface
    stress (:mod:`sphfem.fluid.axisymmetric_surface_stress`), with the wall plane z =
    ``stress_plane`` as its 90-degree symmetry plane (None: no wall).

    ``axis_alpha``: the artificial viscosity's alpha of the rings within one support of the
    axis (smoothstep back to the scene's alpha at two supports; pairs take the mean of
    their two rows'); below the scene's alpha: off.  Ring waves converge on the axis, and
    there the pair sums' hoop-free pressure gradient and the continuity's hoop term are not
    each other's adjoint: in the 10 m/s impact at D/dx 128 without surface tension an
    acoustic mode of the first columns grew from 2.2 t_c (density +-1 %, pressure +-1e5 Pa
    by 2.5 t_c) and blew a hole at the centre; alpha = 0.05 everywhere removed it.

    ``bulk_damping`` (alpha_b > 0): an acoustic damper, the bulk viscous stress
    Pi_i = -rho_i nu_b,i (div v)_i = nu_b,i (D rho / D t)_i added to the pressure of the
    fluid rows in the momentum equation, nu_b,i = alpha_b c0 max(h_i, l) (h_i = R_i / 2; l =
    ``bulk_damping_length``, 0 by default, so the damper vanishes with h), the
    density rate of the previous evaluation (a bulk viscosity zeta = rho nu_b: it acts on
    the compressible part of the flow alone, so it damps the artificial acoustic waves of a
    weakly compressible fluid, mode k at the rate nu_b k^2 / 2 beyond the delta term's,
    and leaves a divergence-free flow as it is; cf. Sun et al. 2023, J. Comput. Phys. 483,
    112056, who add such a term to delta-SPH).  Time step: nu_b enters the viscous limit.
    A length l > h holds the damping of a wave of given wavelength fixed as the spacing
    shrinks: a bulk viscosity zeta = rho alpha_b c0 l of the artificially compressible
    fluid, which converges to a damped (not an undamped) acoustic field; in the 10 m/s
    impact at D/dx 256 l = h of D/dx 128 cut the axis' breathing-mode ringing by ~30 %
    (docs/validation/droplet_impact, session 34).
    The walls' pressure and the output ``p`` stay the equation of state's.

    ``skin`` (> 0): a Verlet list (Verlet 1967): the neighbour list and the axis mirrors
    reach R (1 + skin) and are reused until R + 2 max_i |x_i - x_i,build| exceeds that
    radius.  Every pair kernel skips pairs beyond its support and list rows are sorted by
    index (the mirrors of the longer reach are a superset in the same order), so the steps
    are those of a list rebuilt at every evaluation to the bit (test); 0 rebuilds it every
    time.

    ``contact_line_slip`` (experimental; ``wall_friction = "layer"``): the rings at the end of
    a wall row slide freely, f_i <- f_i (1 - w_i) with the contact-line weight w_i
    (:func:`sphfem.fluid.wall_layer.contact_line_weight`), instead of the plain no-slip
    term there (f_i <- 1 + (f_i - 1)(1 - w_i)): a Navier slip over the contact line's own
    rings, which regularises the moving contact line's stress singularity (Huh & Scriven
    1971) over one support.

    ``contact_line_slip_length`` (lambda > 0; ``wall_friction = "layer"`` and surface tension):
    the contact line's rings carry the friction of the wedge below the spacing, Cox's (1986)
    law between lambda and dx / 2 (:mod:`sphfem.fluid.contact_line_cox1986`), f_i <- f_i +
    (f_cl,i - f_i) w_i with f_cl,i from ring i's speed along the wall.

    ``debris_rings`` (> 0): every DEBRIS_EVERY steps the free-flying clusters of at most this
    many rings (clear of the walls by R) become inert (:mod:`sphfem.fluid.axisymmetric_debris`:
    a torus of a few rings moving towards the axis cannot thicken as a resolved one does,
    and blew the 10 m/s impact at D/dx 181 up at the axis): no pair sum holds them, they fly
    ballistically with their mass, momentum and density (:meth:`find_debris`,
    :attr:`inert`, :attr:`debris_events`).  Needs an open z.
    """

    def __init__(self, x, v, rho, kind, M, vol, R, params: FluidParams,
                 kernel: str = "wendland_c2", periodic_z=None, planar: bool = False,
                 wall_z: float | None = None, adaptive_h: bool = False, wall_normals=None,
                 smooth_hoop: bool = True, surface_tension: float = 0.0,
                 no_penetration: bool = False, renorm_lambda_min: float = 0.2,
                 fragment_hoop: bool = True, shifting: float = 0.0,
                 wall_tension: bool = True, free_surface_no_tension: bool = False,
                 shift_surface: bool = True, shift_speed: str = "local", skin: float = 0.0,
                 wall_friction: str = "sph", film_tension: bool = False,
                 csf_axis_curvature: bool = False, csf_curvature_smoothing: float = 1.0,
                 axis_alpha: float = 0.0, csf_meridian: str = "csf",
                 shift_surface_lambda: float = 0.75, shift_drift: str = "kept",
                 axis_floor: float = 0.0, stress_plane: float | None = None,
                 bulk_damping: float = 0.0, bulk_damping_length: float = 0.0,
                 debris_rings: int = 0,
                 contact_line_slip: bool = False, contact_line_slip_length: float = 0.0,
                 wall_slip: str = "no-slip", slip_length: float = 0.0):
        self.x = np.array(x, dtype=np.float64)
        n = self.n = self.x.shape[0]
        self.v = np.array(v, dtype=np.float64).reshape(n, 2)
        self.rho = np.array(rho, dtype=np.float64).reshape(n)
        self.kind = np.asarray(kind, dtype=np.int8).reshape(n)
        if np.any((self.kind != FLUID) & (self.kind != WALL)):
            raise ValueError("axisymmetric fluid particles must be FLUID or WALL")
        if np.any(self.x[:, 0] < 0):
            raise ValueError("axisymmetric positions need r >= 0")
        if not 0.0 <= axis_floor < float(R):
            raise ValueError(f"axis_floor must lie in [0, R), got {axis_floor!r}")
        self.M = np.broadcast_to(np.asarray(M, float), (n,)).copy()
        self.vol = np.broadcast_to(np.asarray(vol, float), (n,)).copy()
        self.params = pa = params
        self.mu = np.where(self.kind == FLUID, pa.mu, 0.0)
        self.R = float(R)
        self.h = 0.5 * self.R
        self.kcode = kernels.kernel_code(kernel)
        self.sigma = kernels.kernel_sigma(self.kcode, 2, self.R)
        self.s2 = self.sigma * self.R**2
        self.B = tait_B(pa.rho0, pa.c0, pa.gamma)
        self.gravity = np.zeros(2)
        gp = np.asarray(pa.gravity, float).reshape(-1)
        self.gravity[: min(2, gp.size)] = gp[:2]
        self.acc = np.zeros((n, 2))
        self.drho = np.zeros(n)
        self.p = np.zeros(n)
        self.fluid = self.kind == FLUID
        self._fidx = np.flatnonzero(self.fluid)
        self.planar = bool(planar)
        #: rings are kept at r >= axis_floor [m] (module docstring, "Axis"; 0: at r >= 0,
        #: always in the planar mode, whose x = 0 is a symmetry plane)
        self.axis_floor = 0.0 if self.planar else float(axis_floor)
        self.wall_z = None if wall_z is None else float(wall_z)
        self.z0, self.Lz = (0.0, 0.0) if periodic_z is None else map(float, periodic_z)
        if self.Lz and not self.R < 0.5 * self.Lz:
            raise ValueError("the z period must exceed twice the support radius")
        self.t = 0.0
        self.step_count = 0
        self.wall_s = {"neighbors": 0.0, "forces": 0.0}
        if adaptive_h not in (False, True, "area", "mean-area"):
            raise ValueError(f"adaptive_h must be False, True, 'area' or 'mean-area', got "
                             f"{adaptive_h!r}")
        #: None (fixed R), "area" (R_i from A_i) or "mean-area" (from the local mean area)
        self.h_mode = {False: None, True: "area"}.get(adaptive_h, adaptive_h) \
            if not isinstance(adaptive_h, str) else adaptive_h
        self.adaptive_h = self.h_mode is not None
        self._abar = None
        self.smooth_hoop = bool(smooth_hoop)
        #: renormalisation only where the moment matrix' smallest eigenvalue reaches this
        self.renorm_lambda_min = float(renorm_lambda_min)
        #: False: fragments (lambda_min < renorm_lambda_min) carry no hoop term in Drho/Dt
        self.fragment_hoop = bool(fragment_hoop)
        if not shifting >= 0.0:
            raise ValueError(f"shifting must be >= 0 (the coefficient A), got {shifting!r}")
        #: False: the walls' extrapolated pressure is clipped at 0 (no suction)
        if wall_tension not in (True, False, "bulk", "contact-line"):
            raise ValueError(f'wall_tension must be True, False, "bulk" or "contact-line", got '
                             f'{wall_tension!r}')
        self.wall_tension = wall_tension
        if not (bulk_damping >= 0.0 and math.isfinite(bulk_damping)):
            raise ValueError(f"bulk_damping must be a finite number >= 0, got {bulk_damping!r}")
        self.bulk_damping = float(bulk_damping)
        if not (bulk_damping_length >= 0.0 and math.isfinite(bulk_damping_length)):
            raise ValueError(f"bulk_damping_length must be a finite length >= 0 [m], got "
                             f"{bulk_damping_length!r}")
        #: the damper's length floor l [m]: nu_b,i = alpha_b c0 max(h_i, l) (0: h_i)
        self.bulk_damping_length = float(bulk_damping_length)
        if not (isinstance(debris_rings, (int, np.integer)) and debris_rings >= 0):
            raise ValueError(f"debris_rings must be an integer >= 0, got {debris_rings!r}")
        if debris_rings and periodic_z is not None:
            raise ValueError("debris_rings needs an open z (no periodic_z)")
        #: free-flying clusters of at most this many rings become inert (0: off; class
        #: docstring, :mod:`sphfem.fluid.axisymmetric_debris`)
        self.debris_rings = int(debris_rings)
        #: True: the wall layer's friction factor goes to 0 (not to 1) at the contact line
        #: (``wall_friction = "layer"``; class docstring)
        self.contact_line_slip = bool(contact_line_slip)
        if not (contact_line_slip_length >= 0.0 and math.isfinite(contact_line_slip_length)):
            raise ValueError("contact_line_slip_length must be a finite length >= 0, got "
                             f"{contact_line_slip_length!r}")
        if contact_line_slip_length > 0.0:
            if wall_friction != "layer":
                raise ValueError("contact_line_slip_length (the Cox-Voinov contact line) needs "
                                 "wall_friction = 'layer'")
            if not surface_tension > 0.0:
                raise ValueError("contact_line_slip_length (the Cox-Voinov contact line) needs "
                                 "surface tension")
            if contact_line_slip:
                raise ValueError("contact_line_slip and contact_line_slip_length exclude each "
                                 "other")
        #: > 0: the contact line's rings carry the sub-grid wedge friction of Cox (1986)
        #: with this slip length [m] (:mod:`sphfem.fluid.contact_line_cox1986`)
        self.contact_line_slip_length = float(contact_line_slip_length)
        #: the inert rings (debris): in no pair sum, flying ballistically
        self.inert = np.zeros(n, bool)
        #: (t [s], rows) of each debris detection that found some
        self.debris_events: list[tuple[float, np.ndarray]] = []
        #: the rows made inert by the last step (empty: none)
        self.debris_new = np.zeros(0, np.int64)
        #: True: rings at or next to the free surface (lambda < 0.75) keep rho >= rho0
        self.free_surface_no_tension = bool(free_surface_no_tension)
        #: particle shifting coefficient A of dr = -A h |v| dt grad C (0: off)
        self.shifting = float(shifting)
        #: True: surface rings shifted along the surface ("all"); False: not at all
        #: ("interior"), as ``[fluid] shifting`` of the planar solver
        self.shift_surface = bool(shift_surface)
        if shift_speed not in ("local", "max", "strain"):
            raise ValueError(f"shift_speed must be 'local', 'max' or 'strain', got "
                             f"{shift_speed!r}")
        #: the speed of the shifting law: "local" |v_i|, "max" the largest fluid speed,
        #: "strain" h_i |S_i| (:func:`sphfem.fluid.surface.strain_speed`)
        #: (``[fluid] shifting_speed``)
        self.shift_speed = shift_speed
        if not 0.0 < shift_surface_lambda <= 1.0:
            raise ValueError("shift_surface_lambda must be in (0, 1], got "
                             f"{shift_surface_lambda!r}")
        #: rows with lambda below this are shifted along the surface only
        #: (``[fluid] shifting_surface_lambda``)
        self.shift_surface_lambda = float(shift_surface_lambda)
        if shift_drift not in ("kept", "removed"):
            raise ValueError(f"shift_drift must be 'kept' or 'removed', got {shift_drift!r}")
        #: "removed": each ring's shift less its neighbourhood's kernel-weighted mean
        #: (:func:`sphfem.fluid.surface.remove_local_mean`; ``[fluid] shifting_drift``)
        self.shift_drift = shift_drift
        if not axis_alpha >= 0.0:
            raise ValueError(f"axis_alpha must be >= 0, got {axis_alpha!r}")
        #: the artificial viscosity's alpha next to the axis (class docstring; <= the
        #: scene's alpha: off)
        self.axis_alpha = float(axis_alpha)
        #: largest shift of the last step / h
        self.last_shift = 0.0
        self.csf = (AxisymmetricCSF(surface_tension, self.kcode, hoop=not self.planar,
                                    film=film_tension, axis_curvature=csf_axis_curvature,
                                    curvature_smoothing=csf_curvature_smoothing,
                                    meridian=csf_meridian, rho0=pa.rho0)
                    if surface_tension > 0.0 else None)
        if self.csf is not None:
            self.csf.plane = None if stress_plane is None else float(stress_plane)
            if csf_meridian == "stress":
                from sphfem.fluid.axisymmetric_surface_stress import surface_stress_forces

                self.csf.stress_forces = surface_stress_forces
        self.wall_normals = None if wall_normals is None else np.asarray(
            wall_normals, float).reshape(n, 2)
        if wall_friction not in ("sph", "viscous", "layer", "none"):
            raise ValueError(f"wall_friction must be 'sph', 'viscous', 'layer' or 'none', got "
                             f"{wall_friction!r}")
        #: "sph", "viscous", "layer" or "none" (class docstring)
        self.wall_friction = wall_friction
        if wall_slip not in SLIP_MODES:
            raise ValueError(f"wall_slip must be one of {sorted(SLIP_MODES)}, got "
                             f"{wall_slip!r}")
        if not (slip_length >= 0.0 and math.isfinite(slip_length)):
            raise ValueError(f"slip_length must be a finite length >= 0, got {slip_length!r}")
        if wall_slip == "navier" and not slip_length > 0.0:
            raise ValueError("wall_slip = 'navier' needs slip_length > 0 (the slip length b "
                             "[m]; 0 is no slip)")
        if wall_slip != "no-slip" and wall_friction != "viscous":
            raise ValueError(f"wall_slip = {wall_slip!r} acts on the plain viscous wall term: "
                             f"it needs wall_friction = 'viscous', got {wall_friction!r}")
        #: the walls' slip in the viscous term (0 no slip, 1 free, 2 Navier with
        #: ``slip_length``; :mod:`sphfem.fluid.axisymmetric_wall_slip`)
        self.slip_mode = SLIP_MODES[wall_slip]
        #: Navier slip length b [m] (``wall_slip = "navier"``)
        self.slip_length = float(slip_length)
        wl = self.kind == WALL
        #: per-row factor of the wall pairs' viscous term (sphfem.fluid.wall_layer, eq. 3;
        #: 0 for a free-slip wall)
        self.fw = np.full(n, 0.0 if wall_friction == "none" else 1.0)
        #: weight of the contact line per row: the layer's friction factor is lifted there
        #: (sphfem.fluid.wall_layer, "Contact line")
        self.contact_line = np.zeros(n)
        #: squared shear thickness of each fluid row's wall layer [m^2] (< 0: none)
        self.delta2 = np.full(n, -1.0)
        #: the layer equation's inputs from the last evaluation (``wall_friction = "layer"``)
        self._layer = None
        #: (list, wall normals of its augmented rows) of the last list build (layer)
        self._layer_normals = None
        #: (list, count, j, d, f') of the last list build: the pairs gradients packs
        self._pairs = None
        #: the contact-line weights are tracked (the layer's friction; the "contact-line"
        #: wall tension where there are walls: without them there is nothing to clip)
        self._track_contact_line = wall_friction == "layer" or (
            wall_tension == "contact-line" and bool(wl.any()))
        if self._track_contact_line:
            if self.wall_normals is None or not wl.any():
                what = ("wall_friction = 'layer'" if wall_friction == "layer"
                        else "wall_tension = 'contact-line'")
                raise ValueError(f"{what} needs wall particles with wall normals")
            #: wall spacing [m] (the layer of a wall row: contact_line_weight)
            self.wall_dx = float(np.sqrt(np.median(self.vol[wl])))
        if wall_friction == "layer":
            from sphfem.fluid.wall_layer import plug_traction_constant

            #: the lattice constant S of eq. (1)
            self.wall_S = plug_traction_constant(kernel, self.R / self.wall_dx,
                                                 params.eps_visc)
        #: the kinematic wall condition on the position update (needs ``wall_normals``)
        self.no_penetration = None
        wl = self.kind == WALL
        if no_penetration and self.wall_normals is not None and wl.any():
            self.no_penetration = NoPenetration(self.x[wl], self.wall_normals[wl],
                                                self.vol[wl])
        #: fluid particles put back on the wall surface (count over all position updates)
        self.penetration_corrections = 0
        #: reference meridian area a_ref: R_i = R sqrt(A_i / a_ref) (adaptive_h)
        self.a_ref = float(np.median(self._areas()[self.fluid])) if self.fluid.any() else 1.0
        self.Rp = np.full(n, self.R)
        #: Verlet skin: the list (and the axis mirrors) reach R (1 + skin) and are reused
        #: while no particle moved more than R skin / 2 since the build (0: a new list at
        #: every evaluation)
        self.skin = float(skin)
        if not self.skin >= 0.0:
            raise ValueError(f"skin must be >= 0, got {skin!r}")
        self._list = None
        self.list_builds = 0
        self.list_reuses = 0
        self.evaluate()

    def _alpha_c(self, x, Rp) -> np.ndarray:
        """alpha c0 per row of the augmented set ``x``: the scene's alpha, raised to
        ``axis_alpha`` at |r| <= R_i, smoothstep back to alpha at |r| >= 2 R_i."""
        pa = self.params
        a = np.full(x.shape[0], pa.alpha * pa.c0)
        if self.axis_alpha > pa.alpha and not self.planar:
            u = np.clip(np.abs(x[:, 0]) / Rp - 1.0, 0.0, 1.0)  # Rp: mirrors filled
            w = 1.0 - u * u * (3.0 - 2.0 * u)
            a += (self.axis_alpha - pa.alpha) * pa.c0 * w
        return a

    def _clip_weights(self, src, m) -> np.ndarray:
        """Per augmented row, how much a wall row next to it loses its tension
        (:func:`_clip_surface_walls`), from the previous evaluation (all 0 before the first):
        ``"bulk"``: 1 on the fluid rows at a free surface (lambda_min below
        ``shift_surface_lambda``); ``"contact-line"``: the contact-line weight of the fluid
        rows (:func:`sphfem.fluid.wall_layer.contact_line_weight`: 1 at the end of a wall
        row, 0 under a film)."""
        out = np.zeros(m)
        if self.wall_tension == "contact-line":
            out[: self.n] = self.contact_line
        else:
            lam = getattr(self, "lam", None)
            if lam is None:
                return out
            out[: self.n] = self.fluid & (lam < self.shift_surface_lambda)
        out[self.n:] = out[src]
        return out

    def _areas(self) -> np.ndarray:
        circ = 1.0 if self.planar else 2.0 * math.pi * np.maximum(self.x[:, 0], 1e-300)
        return np.where(self.fluid | self.inert, self.M / (circ * self.rho), self.vol)

    def support_radii(self, A) -> np.ndarray:
        """Per-particle support radii: R everywhere, or with ``adaptive_h`` R_i = R
        sqrt(A_i / a_ref) clipped to [R / 2, 2 R] (h_i ~ sqrt(A_i), so the number of planar
        neighbours stays constant as rings change their meridian area A ~ r0 / r;
        Garcia-Senz & Relano-Pastor 2012, sec. 2; pair kernels use (R_i + R_j) / 2,
        Hernquist & Katz 1989, eq. 2.21, which keeps the pair forces antisymmetric)."""
        if not self.adaptive_h:
            return np.full(A.shape[0], self.R)
        if self.h_mode == "mean-area" and self._abar is not None:
            A = np.where(self.fluid, self._abar, A)
        return np.clip(self.R * np.sqrt(A / self.a_ref), 0.5 * self.R, 2.0 * self.R)

    # -- one force evaluation ------------------------------------------------------------
    def _mirrors(self, R: float | None = None):
        """Sources, types and kinds of the mirrors: images of the fluid across the wall plane
        (if any), then images across the axis of every particle and wall-plane image with
        r < R (the corner images are axis images of wall-plane images); R: the largest
        support radius unless given."""
        n = self.n
        R = float(self.Rp.max()) if R is None else float(R)
        srcs, types = [], []
        if self.wall_z is not None:
            s1 = np.flatnonzero(self.fluid & (self.x[:, 1] - self.wall_z < R))
            srcs.append(s1)
            types.append(np.ones(s1.shape[0], np.int8))
            r_aug = np.concatenate([self.x[:, 0], self.x[s1, 0]])
        else:
            r_aug = self.x[:, 0]
        s0 = np.flatnonzero(r_aug < R)
        srcs.append(s0)
        types.append(np.zeros(s0.shape[0], np.int8))
        src = np.concatenate(srcs).astype(np.int64)
        mtype = np.concatenate(types)
        # the kind of a mirror is its source's (sources beyond n are wall-plane images of
        # the fluid)
        wall_src = np.zeros(src.shape[0], bool)
        real = src < n
        wall_src[real] = self.kind[src[real]] == WALL
        mk = np.where(wall_src, MIRROR_WALL, MIRROR_FLUID).astype(np.int8)
        return src, mtype, np.concatenate([self.kind, mk])

    def evaluate(self) -> None:
        """Pressures, wall states, mirrors, gradients, accelerations and density rates."""
        t0 = time.perf_counter()
        pa, n = self.params, self.n
        A0 = self._areas()
        self.Rp = self.support_radii(A0)
        R = float(self.Rp.max())
        reuse = self._list_valid(R)
        if reuse:
            src, mtype, kind, nl = self._list[1:5]
            self.list_reuses += 1
        else:  # mirrors and list out to the list radius R (1 + skin)
            src, mtype, kind = self._mirrors(R * (1.0 + self.skin))
        m = n + src.shape[0]
        x = np.empty((m, 2))
        x[:n] = self.x
        zw = 0.0 if self.wall_z is None else self.wall_z
        _mirror_positions(n, src, mtype, zw, x)
        if not reuse:
            radius = R * (1.0 + self.skin)
            lo = x.min(axis=0) - radius
            hi = x.max(axis=0) + radius
            period = np.zeros(2)
            if self.Lz:
                lo[1], hi[1], period[1] = self.z0, self.z0 + self.Lz, self.Lz
            nl = build_neighbor_list(x, radius, lo, hi, period, kind=kind, keep=KEEP)
            self._list = (radius, src, mtype, kind, nl, self.x.copy())
            self.list_builds += 1
        t1 = time.perf_counter()
        self.wall_s["neighbors"] += t1 - t0
        v = np.zeros((m, 2))
        v[:n] = self.v
        vg = v.copy()
        rho = np.zeros(m)
        rho[:n] = self.rho
        p = np.zeros(m)
        fl = self.fluid
        p[:n][fl] = tait_pressure(self.rho[fl], pa.rho0, self.B, pa.gamma)
        A = np.zeros(m)
        mt = np.zeros(m)
        mu = np.zeros(m)
        mu[:n] = self.mu
        gr = np.zeros((m, 2))
        dvdr = np.zeros((m, 2))
        shep = np.zeros(m)
        Bm = np.zeros((m, 5))
        gc = np.zeros((m, 2))
        qs = np.zeros(m)
        A[:n] = A0
        Rp = np.zeros(m)
        Rp[:n] = self.Rp
        # mirrors of the fluid first (walls read them), then the walls' state
        _fill_mirrors(n, src, mtype, zw, self.gravity[1], x, v, vg, rho, p, A, mt, mu, gr, dvdr,
                      Rp)
        wall_state(x, v, rho, p, A, kind, nl.offsets, nl.indices, Rp, self.kcode, self.Lz,
                   self.gravity, pa.rho0, self.B, pa.gamma, vg,
                   -np.inf if self.wall_tension else 0.0)
        if self.wall_tension in ("bulk", "contact-line"):
            _clip_surface_walls(x, p, rho, kind, nl.offsets, nl.indices, Rp, self.Lz,
                                self._clip_weights(src, m), pa.rho0, self.B, pa.gamma)
        vga = vg  # Adami's ghost: the continuity's free-slip ghost is built from it
        if self.slip_mode:  # the viscous terms see the wall's slip
            vga = vg.copy()
            slip_ghost_rz(x, v, vg, kind, nl.offsets, nl.indices, Rp, self.kcode, self.Lz,
                          self.slip_mode, self.slip_length)
        mt[:n] = rho[:n] * A[:n]
        _fill_mirrors(n, src, mtype, zw, self.gravity[1], x, v, vg, rho, p, A, mt, mu, gr, dvdr,
                      Rp)
        qv = np.empty(m)
        hoop_ratio(x, vg, qv)
        pc = self._pairs  # packed pairs of gradients for forces: arrays once per list build
        if pc is None or pc[0] is not nl:
            k = nl.indices.shape[0]
            pc = self._pairs = (nl, np.zeros(m, np.int64), np.zeros(k, np.int64), np.zeros(k),
                                np.zeros(k))
        gradients(x, rho, vg, A, kind, nl.offsets, nl.indices, Rp, self.s2, self.kcode,
                  self.Lz, pa.cond_max, self.renorm_lambda_min, gr, dvdr, shep, Bm, qs, gc, qv,
                  *pc[1:])
        #: grad C and the renormalisation B (c00, c01, c11) of the real rows (shifting)
        self._grad_c = (gc[:n].copy(), Bm[:n, :3].copy())
        if self.h_mode == "mean-area":  # R_i of the next evaluation
            abar = np.empty(m)
            mean_area(x, A, kind, nl.offsets, nl.indices, Rp, self.kcode, self.Lz, abar)
            self._abar = abar[:n]
        qh = qs if self.smooth_hoop else v[:, 0] / np.where(x[:, 0] != 0.0, x[:, 0], 1.0)
        if self.planar:  # the plain planar divergence of FluidSolver
            Bm[:, :3] = (1.0, 0.0, 1.0)
        p_eos = p[:n].copy() if self.bulk_damping > 0.0 else p[:n]
        if self.bulk_damping > 0.0:  # the acoustic damper's bulk stress (class docstring)
            lb = np.maximum(0.5 * self.Rp[fl], self.bulk_damping_length)
            p[:n][fl] += (self.bulk_damping * lb * pa.c0) * self.drho[fl]  # = before for l = 0
        _fill_mirrors(n, src, mtype, zw, self.gravity[1], x, v, vg, rho, p, A, mt, mu, gr, dvdr,
                      Rp)
        vd = self._divergence_velocity(v, vga, src, mtype)
        acc = np.zeros((m, 2))
        drho = np.zeros(m)
        gradv = np.zeros((m, 4))
        fw = np.ones(m)
        fw[:n] = self.fw
        mirror_scalar(n, src, fw)
        wall_art = 1.0 if self.wall_friction == "sph" else 0.0
        prr = np.empty(m)
        pressure_ratio(p, rho, prr)
        forces(x, v, vg, vd, rho, p, A, mt, mu, kind, gr, dvdr, nl.offsets, nl.indices, Rp,
               self.s2, self.kcode, self.Lz, self.gravity, pa.eps_visc, pa.delta * pa.c0,
               self._alpha_c(x, Rp),
               0.0 if self.planar else 1.0, Bm, qh, not self.fragment_hoop, fw,
               wall_art, acc, drho, gradv, prr, *pc[1:])
        #: the renormalised velocity gradient (L00, L01, L10, L11) of the real rows (a view
        #: of this evaluation's array)
        self.gradv = gradv[:n]
        if self._track_contact_line:
            self._layer_inputs(x, kind, nl, Rp, src, mtype, gradv, qh)
        if self.csf is not None:  # CSF over the fluid's widest support (adaptive_h)
            self.csf.accumulate(x, A, rho, kind, nl.offsets, nl.indices, n, src, mtype,
                                float(Rp[:n][self.fluid].max(initial=self.R)), self.Lz, acc,
                                lam=Bm[:n, 4])
        self.acc[:] = acc[:n]
        self.drho[:] = drho[:n]
        self.p[:] = p_eos
        self.area = A[:n].copy()
        #: the augmented state of this evaluation (real rows, then mirrors), for callers that
        #: need pair sums of it (the wall forces of sphfem.axisymmetric_scene)
        self.augmented = dict(x=x, v=v, vg=vg, rho=rho, p=p, A=A, mt=mt, mu=mu, kind=kind,
                              Rp=Rp, nbrs=nl, src=src, mtype=mtype, grad_rho=gr, fw=fw,
                              wall_art=wall_art)
        #: sum_j A_j W_ij over all neighbours, self included (1 where the areas tile the
        #: plane; ~1/2 at a free surface)
        self.shepard = shep[:n].copy()
        #: smallest eigenvalue of each row's moment matrix (1 inside, ~0.5 at a free surface)
        self.lam = Bm[:n, 4].copy()
        self.wall_s["forces"] += time.perf_counter() - t1

    def _layer_inputs(self, x, kind, nl, Rp, src, mtype, gradv, qh) -> None:
        """The band, wall normals and surface divergence of the fluid rows
        (:mod:`sphfem.fluid.wall_layer`, eq. 2) from this evaluation."""
        from sphfem.fluid.wall_layer import band_normals, surface_divergence

        n = self.n
        c = self._layer_normals  # the augmented rows' wall normals, fixed per list build
        if c is None or c[0] is not nl:
            nrm = np.zeros((x.shape[0], 2))
            nrm[:n] = np.where((self.kind == WALL)[:, None], self.wall_normals, 0.0)
            mirror_normals(n, src, mtype, nrm, np.zeros(x.shape[0]))
            self._layer_normals = c = (nl, nrm)
        nrm = c[1]
        bn = np.zeros((n, 2))
        band = np.zeros(n, np.int8)
        band_normals(x, kind, nl.offsets, nl.indices, Rp, nrm, self.kcode, n, bn, band)
        a = np.zeros(n)
        if self.wall_friction == "layer":  # eq. (2)'s strain rate (not the contact line's)
            hoop = qh[:n] if not self.planar else np.zeros(n)
            surface_divergence(gradv[:n], np.ascontiguousarray(hoop), bn, band, a)
        self._layer = (band, a, x, nl, Rp, bn, kind)

    def _advance_layer(self, dt: float) -> None:
        """Eq. (2) of :mod:`sphfem.fluid.wall_layer` over dt from the last evaluation, then
        the friction factors of the next evaluations (eq. 3; ``wall_friction = "layer"``),
        and the contact-line weights of the band rows (the layer's friction, the
        ``"contact-line"`` wall tension)."""
        from sphfem.fluid.wall_layer import advance_layer, contact_line_weight, friction_factor

        band, a, x, nl, Rp, bn, kind = self._layer
        cl = self.contact_line
        contact_line_weight(x, (kind == FLUID) | (kind == MIRROR_FLUID), nl.offsets,
                            nl.indices, band, bn, self.n, Rp, self.kcode, 0.75 * self.wall_dx,
                            np.array([0.0, float(self.Lz)]), cl)
        if self.wall_friction != "layer":
            return
        nu = self.params.mu / self.params.rho0
        advance_layer(self.delta2, band, a, nu, dt, float(self.R) ** 2, x, nl.offsets,
                      nl.indices, Rp, self.kcode)
        fw = friction_factor(self.delta2, self.wall_dx, self.wall_S, nu, dt, self.h,
                             self.params.visc_cfl)
        if self.contact_line_slip_length > 0.0:  # the sub-grid wedge's friction (Cox 1986)
            from sphfem.fluid.contact_line_cox1986 import contact_line_factors

            bn = self._layer[5]
            v = self.v
            vn = v[:, 0] * bn[:, 0] + v[:, 1] * bn[:, 1]
            ut = np.hypot(v[:, 0] - vn * bn[:, 0], v[:, 1] - vn * bn[:, 1])
            fcl = contact_line_factors(ut, self.wall_S, self.wall_dx,
                                       self.contact_line_slip_length, self.params.mu,
                                       self.csf.sigma)
            cap = max(1.0, self.params.visc_cfl * self.h * self.h / (nu * dt))
            self.fw = fw + (np.minimum(fcl, cap) - fw) * cl
        elif self.contact_line_slip:  # the contact line's rings slide freely
            self.fw = fw * (1.0 - cl)
        else:
            self.fw = 1.0 + (fw - 1.0) * (1.0 - cl)

    def _list_valid(self, R: float) -> bool:
        """True when the list of the last build still holds every pair and mirror within R:
        no particle moved more than half the margin, R + 2 max |x - x_build| <= the list
        radius (pairs then moved apart or together by at most the margin; Verlet 1967)."""
        if self._list is None or self.skin <= 0.0:
            return False
        d = self.x - self._list[5]
        if self.Lz:
            d[:, 1] -= self.Lz * np.round(d[:, 1] / self.Lz)
        move = math.sqrt(float(np.max(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])))
        return R + 2.0 * move <= self._list[0]

    def _divergence_velocity(self, v, vg, src, mtype):
        """The velocity the continuity's divergence sees: the fluid's (and its mirrors'); at
        wall particles with normals the free-slip ghost ṽ - 2 ((ṽ - v_w) . n) n of the
        Adami-extrapolated fluid velocity ṽ = 2 v_w - vg (the normal velocity then passes
        v_w . n at the wall surface, the tangential one is continued smoothly); without normals
        the wall's own velocity."""
        vd = v.copy()
        if self.wall_normals is None:
            return vd
        _free_slip_ghost(v, vg, self.kind, self.wall_normals, src, mtype, vd)
        return vd

    # -- time stepping -------------------------------------------------------------------
    def dt_limits(self) -> dict[str, float]:
        """Acoustic, viscous and force limits [s] (as :meth:`FluidSolver.dt_limits`)."""
        pa = self.params
        vmax, amax, rmin, rhomin = _fluid_extrema(self._fidx, self.v, self.acc, self.Rp,
                                                  self.rho)
        if not self._fidx.size:  # no fluid left in the pair sums (all of it inert debris)
            vmax, amax, rmin, rhomin = 0.0, 0.0, self.R, pa.rho0
        h = 0.5 * rmin
        lim = {"acoustic": pa.cfl * h / (pa.c0 + vmax)}
        if pa.mu > 0:
            lim["viscous"] = pa.visc_cfl * h**2 * rhomin / pa.mu
        if self.bulk_damping > 0.0:  # nu_b = alpha_b c0 max(h, l) (h of the largest support)
            hb = 0.5 * float(self.Rp[self._fidx].max()) if self._fidx.size else h
            hb = max(hb, self.bulk_damping_length)
            lim["bulk"] = pa.visc_cfl * h**2 / (self.bulk_damping * hb * pa.c0)
        if amax > 0:
            lim["force"] = pa.force_cfl * math.sqrt(h / amax)
        if pa.density_cfl > 0.0 and self._fidx.size:  # [fluid] density_cfl
            f = self._fidx
            rate = float(np.max(np.abs(self.drho[f]) / self.rho[f]))
            if rate > 0.0:
                lim["density"] = pa.density_cfl / rate
        return lim

    def stable_dt(self) -> float:
        return min(self.dt_limits().values())

    def step(self, dt: float) -> None:
        """Predictor-corrector position Verlet (:mod:`sphfem.fluid.wcsph`); particles that
        cross the axis are reflected."""
        fi = self._fidx
        if self._layer is not None:
            self._advance_layer(dt)
        v_n = np.empty((fi.shape[0], 2))
        rho_n = np.empty(fi.shape[0])
        hold_r, rho0 = self.surface_hold_radius(), float(self.params.rho0)
        # the numpy updates x[fl] += 0.5 dt v[fl], ... and the surface hold, per row
        _predict(fi, self.x, self.v, self.rho, self.acc, self.drho, 0.5 * dt, v_n, rho_n,
                 self.lam, hold_r, rho0)
        self._reflect()
        self.evaluate()
        _correct(fi, self.x, self.v, self.rho, self.acc, self.drho, dt, 0.5 * dt, v_n, rho_n,
                 self.lam, hold_r, rho0)
        if self.shifting > 0.0:
            self._shift(dt)
        self._reflect()
        if self.inert.any():
            self._fly_inert(dt)
        self.t += dt
        self.step_count += 1
        self.debris_new = (self.find_debris() if self.debris_rings
                           and self.step_count % self.DEBRIS_EVERY == 0 else self.debris_new[:0])
        if not _all_finite(fi, self.x, self.rho):
            raise FloatingPointError(f"axisymmetric fluid: non-finite state at step "
                                     f"{self.step_count}, t = {self.t:.4g} s")

    def surface_hold_radius(self) -> float:
        """``free_surface_no_tension``: a free surface is at the ambient pressure (the capillary
        jump is the surface-tension force's), so the rings at or next to it (lambda_i <
        0.75 at the last evaluation, Marrone et al. 2010) are held at rho >= rho0 by the
        step: they push when compressed and never pull.  Inside the fluid tension is left
        to the equation of state.  Without it a surface ring whose divergence is misjudged
        on its one-sided support drifts below rho0 and its tension pulls its neighbours out
        of the surface.  Returns the radius |r| below which the hold applies: infinite with
        the CSF and the surface stress, the CSF's axis band with the pair force (whose tension
        lives in the surface rings' pressure; planar: nowhere), 0 (off) without
        ``free_surface_no_tension``.  (The surface stress without the hold: the impact's
        surface rings fall to rho 0.83 rho0 by 0.4 t_c and 8 % of the mass breaks off by
        0.7 t_c, 10 m/s at D/dx 64, session 23.)"""
        if not self.free_surface_no_tension:
            return 0.0
        if self.csf is not None and self.csf.meridian == "pair":
            from sphfem.fluid.axisymmetric_pair_tension import PAIR_AXIS_BAND

            return 0.0 if self.planar else float(PAIR_AXIS_BAND[1] * self.R)
        return math.inf

    def _shift(self, dt: float) -> None:
        """Particle shifting (Skillen et al. 2013, Lind et al. 2012, with the free-surface
        treatment of Sun et al. 2017; as ``[fluid] shifting = "all"`` of
        :mod:`sphfem.fluid.surface`): dr_i = -A h_i |v_i| dt grad C_i, grad C_i = sum_j A_j
        grad_i W_ij over the fluid, the walls and the axis mirrors of this step's evaluation
        (a ring is not pushed across the axis), projected on the surface's tangent where
        the moment matrix' lambda_i < ``shift_surface_lambda`` (0.75), none on fragments
        (lambda_i <= 0.2), capped at 0.1 h_i; the density follows, rho_i += <grad rho>_i .
        dr_i; the ring keeps its mass (its meridian area follows from r_i).  It moves the
        rings towards an even planar cover sum_j A_j W_ij = 1 (the areas, not the spacing,
        are evened out).  With ``shift_drift = "removed"`` each ring's shift less the
        kernel-weighted mean of its neighbourhood's (axis and wall mirrors' shifts mirrored;
        :func:`sphfem.fluid.surface.remove_local_mean`) is applied; fragments then move
        too (against the drift) but keep their density."""
        from sphfem.fluid.surface import (
            OWN_SPEED,
            apply_shift,
            remove_local_mean,
            shift_displacement,
            shift_floor_speed,
            strain_speed,
        )

        a = self.augmented
        n = self.n
        gc, B = self._grad_c  # of this step's (mid-step) evaluation
        # outward normal n = -B grad C / |B grad C| (B the identity where it was not used);
        # fragments get kind WALL (no shift); grad C scaled by h_i / h_max (coefficient
        # A h_max below: per-particle h_i)
        nrm = np.empty((n, 2))
        gcs = np.empty((n, 2))
        near = np.empty(n, np.bool_)
        kind = np.empty(n, np.int8)
        hmax, hmin = _shift_inputs(gc, B, self.lam, self.kind, a["Rp"], self.renorm_lambda_min,
                                   gcs, nrm, near, kind, self.shift_surface_lambda)
        out = np.zeros(n)
        speed = OWN_SPEED
        if self.shift_speed == "strain":
            speed = np.empty(n)
            strain_speed(0.5 * a["Rp"][:n], self.gradv, speed)
        dr = np.zeros((n, 2))
        shift_displacement(self.x, self.v, kind, gcs, nrm, near, self.shifting * hmax, dt,
                           0.1 * hmin, self.shift_surface,
                           shift_floor_speed(self.v, self.kind, self.shift_speed), speed, dr)
        grad_rho = a["grad_rho"][:n]
        if self.shift_drift == "removed":  # over the listed rows, the mirrors' shifts mirrored
            xa, ka, nl = a["x"], a["kind"], a["nbrs"]
            dra = np.zeros_like(xa)
            dra[:n] = dr
            mirror_normals(n, a["src"], a["mtype"], dra, np.zeros(xa.shape[0]))
            remove_local_mean(dra, xa, (ka == FLUID) | (ka == MIRROR_FLUID), nl.offsets,
                              nl.indices, a["Rp"], self.kcode, np.array([0.0, self.Lz]), n,
                              dr)
            # fragments (kind WALL above) move against their neighbourhood's drift but keep
            # their density: their unrenormalised grad rho is no Taylor slope (it drove a
            # density negative at D/dx 128)
            grad_rho = np.where((kind != self.kind)[:, None], 0.0, grad_rho)
        apply_shift(self.x, self.rho, grad_rho, dr, 0.1 * hmin, out)
        self.last_shift = float(out.max() / hmin)

    def _reflect(self) -> None:
        """Reflect the fluid at the axis and the wall plane, wrap periodic z, and hold it
        out of particle walls with normals (:mod:`sphfem.fluid.no_penetration`)."""
        _reflect_axis(self._fidx, self.x, self.v, self.wall_z is not None,
                      0.0 if self.wall_z is None else self.wall_z, self.axis_floor)
        if self.Lz:
            self.x[:, 1] = self.z0 + np.mod(self.x[:, 1] - self.z0, self.Lz)
        if self._hold_out_of_walls(self._fidx):
            self.penetration_corrections += 1

    def _hold_out_of_walls(self, rows) -> bool:
        """``no_penetration`` on ``rows``: those found under a particle wall's surface are
        put back on it and lose their inward normal velocity; True when any was moved."""
        if self.no_penetration is None or not rows.size:
            return False
        xs, vs = np.take(self.x, rows, axis=0), np.take(self.v, rows, axis=0)
        if not self.no_penetration.apply(xs, vs):
            return False
        self.x[rows], self.v[rows] = xs, vs
        return True

    #: steps between two debris searches (``debris_rings``)
    DEBRIS_EVERY = 20
    #: debris: rings closer than this many reference spacings sqrt(a_ref) are linked
    DEBRIS_LINK = 2.0

    def find_debris(self) -> np.ndarray:
        """Make the free-flying clusters of at most ``debris_rings`` rings inert
        (:func:`sphfem.fluid.axisymmetric_debris.free_debris`: links of DEBRIS_LINK
        sqrt(a_ref), clear of the wall rings and plane by the support R).  Returns the rows
        made inert now."""
        from sphfem.fluid.axisymmetric_debris import free_debris

        wl = self.kind == WALL
        rows = free_debris(self.x, self._fidx, self.DEBRIS_LINK * math.sqrt(self.a_ref),
                           self.debris_rings, self.x[wl] if wl.any() else None,
                           float(self.Rp.max()), self.wall_z)
        if rows.size:
            self.make_inert(rows)
            self.debris_events.append((self.t, rows))
        return rows

    def make_inert(self, rows) -> None:
        """Take the fluid ``rows`` out of every pair sum (kind INERT: no neighbour list holds
        them) and fly them ballistically from now on; masses, velocities, densities kept."""
        rows = np.asarray(rows, np.int64)
        if not np.all(self.fluid[rows] | self.inert[rows]):
            raise ValueError("make_inert: only fluid rows can become inert")
        self.kind[rows] = INERT
        self.fluid[rows] = False
        self.inert[rows] = True
        self.mu[rows] = 0.0
        self.acc[rows] = self.gravity
        self.drho[rows] = 0.0
        self._fidx = np.flatnonzero(self.fluid)
        self._list = None  # the kinds changed: a new list

    def _fly_inert(self, dt: float) -> None:
        """Ballistic flight of the inert rings over dt under gravity, reflected at the axis
        (and the wall plane), and held out of particle walls with normals as the fluid is
        (``no_penetration``: put back on the surface, the inward normal velocity removed,
        so debris that lands slides along the wall instead of flying through it)."""
        q = np.flatnonzero(self.inert)
        self.x[q] += dt * self.v[q] + 0.5 * dt * dt * self.gravity
        self.v[q] += dt * self.gravity
        _reflect_axis(q, self.x, self.v, self.wall_z is not None,
                      0.0 if self.wall_z is None else self.wall_z, self.axis_floor)
        self._hold_out_of_walls(q)

    def run(self, t_end: float, callback=None, every: float | None = None) -> int:
        """Step to ``t_end`` with the stable step, ``callback(self)`` every ``every`` s."""
        next_cb = self.t + every if every else math.inf
        while self.t < t_end * (1 - 1e-12):
            dt = min(self.stable_dt(), t_end - self.t, max(next_cb - self.t, 1e-300))
            if not dt > 0.0:  # a density <= 0 or a NaN: a broken state, never step back
                raise FloatingPointError(f"axisymmetric fluid: time-step limits "
                                         f"{self.dt_limits()} at t = {self.t:.4g} s")
            self.step(dt)
            if callback is not None and self.t >= next_cb * (1 - 1e-12):
                callback(self)
                next_cb += every
        return self.step_count

    def total_mass(self) -> float:
        """sum of the fluid's ring masses [kg], inert rings included (constant by
        construction)."""
        return float(self.M[self.fluid | self.inert].sum())
