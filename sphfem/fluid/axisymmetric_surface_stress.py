"""Surface tension as the divergence of a surface stress (``[fluid] csf_meridian = "stress"``).

The CSF of :mod:`sphfem.fluid.axisymmetric_surface_tension` is a field force sigma kappa
grad C: its integral over a group of rings is not the flux of anything through the group's
edge, so the pull on the end of a film or a rim is whatever the end's few rings' curvature
makes it.  Measured on a film dewetting a free-slip wall at 90 degrees
(``examples/axisymmetric/taylor_culick.py --wall``, momentum over the exact sigma t): 0.53-0.77
at 8 rows, 0.42-0.89 at 4, spray at 16; the Akinci pair force 1.03-1.18 / 1.12-1.22 /
3.4-5.0; so the rim that stops a spreading lamella is pulled by neither.

This model writes the surface tension as what it is in the continuum, a stress confined to
the interface (Lafaurie et al. 1994, J. Comput. Phys. 113: 134; the CSS),

    T = sigma delta_s (I - n n),      f = div T,                                       (S1)

in the meridian half-plane with the symmetric SPH divergence

    a_i = 1 / rho_i sum_j A_j (S_i + S_j) . grad_i W_ij,                                (S2)

S the planar part tau t t of T (t the interface tangent).  (S2) is antisymmetric in i and j,
so the force on any group of rows is the flux of S through its edge: a film's end is pulled
by the tension its cross-section carries, whatever the end's shape, and a thick body's face
by sigma per face.  The tension per row is set so that the flux is exact on a lattice:

- on the face of thick fluid, tau_i = sigma psi_i / Q_i with psi = omega, the CSF's normal
  weight of the colour gradient g of the fluid and its images (psi = omega |g|, tried
  first, puts the tension mostly on the outer row; neither held an 8-row rim without the
  artificial stress below), t normal to g, and Q_i the largest over
  the row and its neighbours of sum_j A_j w1(t_i . r_ij) psi_j t_i . M_j . t_i over the rows
  of the same face (g_i . g_j > 0; w1 the kernel normalised in 1D, M_j the fluid moment
  matrix): the integral of psi M_tt across the face, whose flux sum_rows s tau M_tt is
  then sigma;
- in films thinner than about the support (weight phi of the film model), the film model's
  S = tau t t with tau = gamma / Q, gamma = 2 sigma free and sigma on a wall
  (:mod:`sphfem.fluid.axisymmetric_surface_tension`, "Thin films");
- S_i = phi_i S_film,i + (1 - phi_i) S_face,i: the stresses are blended, not the forces, so
  the junction of a film with thick fluid keeps (S2)'s balance.

Walls: a wall at 90 degrees is a symmetry plane of the surface stress (the liquid and its
mirror image are a free body, whose surface stress is that of the free surface; sigma_sl =
sigma_sv gives the wall no tangential pull, and the foot of a face meeting the wall is held
by its image as by the solid).  So the model runs on its own set: the fluid rows, their axis
mirrors, and the images of both across the wall plane z = ``plane`` (``[fluid]``: the top of
the wall blocks; None: no wall), with no wall rows at all; a film on the wall is the half
of a free film twice as thick (gamma = 2 sigma on the doubled film, whose real half then
carries sigma).  Walls that are not that plane are not seen by the stress.

Axisymmetric: the
interface stress is isotropic in its plane, so T also has tau e_theta e_theta, whose
divergence adds (tau M_tt / r)(t_r t - e_r) (eq. F3 of the film model); within
``axis_band`` of the axis that ratio is blended (smoothstep) into the planar force's normal
part (the two principal curvatures are equal at the pole).

Measured (session 22, 2026-12-05; tests/test_axisymmetric_surface_stress.py,
examples/axisymmetric/taylor_culick.py with ``--length 20 --t-end 8 --drift removed --mu
1e-3 --c0 30``):

- static pull on the outer half of a film 1-12 rows thick, square or rounded end: 0.994 of
  the line force free and on the wall (the CSF: 0.12-1.35; the 1D quadrature of the kernel
  at R = 3 dx gives 0.994), and -0.99 to -1.07 sigma normal to the wall for 3 rows and more
  (exact: -sigma, the face's turn from horizontal to vertical);
- a free film 4 rows thick retracting: momentum 0.994 x 2 sigma t at every frame, speed
  0.77 V_TC (the pair force 0.84, the CSF 0.59); on the wall (4 rows) 1.05-1.07 sigma t,
  speed 0.33;
- 8 rows and more without an artificial stress: NOT stable.  The rim's rows fan out into
  strings and surface rings are flung out (with the free-surface density hold), or, without
  the hold (the default for this model), a particle-scale wave runs from the rim into the film
  (pressure +-2e4 Pa from ring to ring, the tensile instability of the face rows under tension
  along the surface) and the momentum falls to 0.4-0.5 of 2 sigma t by 6-8 h / V_TC: the free
  film at 8 rows retracts at 0.72 V_TC, on the wall the rim does not form.  Neither stronger
  shifting (A = 5, surface lambda 0.5) nor c0 = 60 V_TC changed that.
- The 10 m/s impact (We 139, Re 3333) at D/dx 64 with the model without the artificial
  stress, member 0: D_max/D 3.60 at 1.83 t_c, 4.2 % broken off, 164 s (the CSF's session-20
  mean at 64: 4.03).  One run.

Artificial stress (:data:`ART_EPS`, 0.3 by default): the pair terms carry (1 - eps f^4),
f = W(r) / W(s) (Monaghan 2000, J. Comput. Phys. 159: 290, applied to the tension: close
pairs of the tensioned face rows are not pulled together further), and S is multiplied by
:func:`art_stress_gain` (1.116 at R = 3 s), which restores the flux on the bulk lattice.
Static pull then 0.955-0.977 of the line force (0.887 for a free single row); the free film
8 rows thick retracts with a compact round rim at 0.77 V_TC, momentum 0.82-0.86 (without
the gain); on the wall (without the gain) 0.86-0.88 at 4 rows and 0.82-0.87 at 8, speed
0.74 / 0.80 sqrt(sigma / (rho h)), the rim on the wall.  With the gain: on the wall
0.96-0.98 (4 rows, speed 0.79), 0.93-0.97 (8 rows, 0.86) and 0.92-1.03 (16 rows, 0.95) of
sigma t; free 0.98 (4 rows,
0.79 V_TC) and 0.91-0.96 (8 rows, 0.81 V_TC) of 2 sigma t.  The 10 m/s impact at D/dx 64
with it comes apart (59 % of the mass broken off by 3.67 t_c, non-finite at 3.69 t_c): not
yet usable for the impact.

Session 23 (the 10 m/s impact at D/dx 64, member 0, frames every 0.05 t_c): the surface
rings are held at rho >= rho0 as with the CSF (without the hold they fall to 0.83 rho0 by
0.4 t_c and 8 % of the mass breaks off by 0.7 t_c).  Three faults of the model in the
impact, none fixed yet:

- the corner of axis and wall: the rings squeezed out along the wall shrink in meridian
  area (A ~ 1 / r), the layer's Shepard sum falls to 0.84-0.88 by 0.2 t_c, |g| R to 0.45,
  so psi = 0.1-0.16 there; as Q scales with psi, tau = sigma psi / Q is the full face
  tension on rows inside the fluid (accelerations of 5e6 m/s^2 toward the axis), and the
  corner is stirred from 0.15 t_c (not with the CSF).  Raising the face threshold
  (:data:`FACE_G_LO`, :data:`FACE_G_HI` 0.5 / 1.0) calms it;
- the top of the drop at the axis: the planar stress force over the rows within 6 dx of the
  axis pulls toward the axis with 0.24 sigma per unit length and lifts the rows (at 0.6 t_c):
  rings at the pole rise and are shot up the axis from ~0.75 t_c;
- from ~1.5 t_c the lamella breaks up (54 % of the mass off the main body by 2.35 t_c with
  the thresholds 0.5 / 1.0; 6-7 % with 0.3 / 0.9, :data:`ART_EPS` 0.3 or 0; D_max/D 3.36-3.60).

The root: the model does not hold a drop at rest (examples/axisymmetric/resting_drop.py:
a drop of radius 20 dx blows apart by 1-1.5 capillary times, with or without the hoop term
or the artificial stress, and so does a torus of the same cross-section away from the
axis); the CSF keeps both calm.  Fix that first.

An artificial-stress factor floored at 0 (max(1 - eps f^4, 0)) was tried there too: 7.4 %
broken off, no better; not kept.

Not modelled: contact angles other than 90 degrees.  Experimental: off by default.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.fluid.passes import grad_factor
from sphfem.fluid.surface_tension_csf import NORMAL_HI, NORMAL_LO
from sphfem.kernels import kernel_f
from sphfem.smallmat import pair_sep

#: floor of Q as a fraction of psi_i times a one-row film's Q (an isolated ring with a
#: colour gradient would otherwise get tau ~ 1 / Q unbounded)
FACE_Q_MIN = 0.5
#: the face weight psi: smoothstep of |g| R from FACE_G_LO to FACE_G_HI (the outer row of
#: a lattice face has |g| R = 1.26 at R = 3 s, the next 0.23); by default the CSF's normal
#: weight omega's thresholds, so psi = omega
FACE_G_LO, FACE_G_HI = NORMAL_LO, NORMAL_HI
#: artificial stress on the tension (Monaghan 2000; 0: off)
ART_EPS = 0.3


@njit(cache=True, parallel=True)
def face_moment(x, A, fl, n, offsets, indices, R, sigma1, kernel_code, period, tang, g, psi,
                M, Q):
    """Q_i = sum_j A_j w1(t_i . r_ij) psi_j t_i . M_j . t_i over the row itself and its
    fluid-like neighbours j of the same face (g_i . g_j > 0), real fluid rows i < n with
    psi_i > 0 (0 elsewhere); w1 the kernel's shape normalised in 1D by ``sigma1``."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        Q[i] = 0.0
        if not fl[i] or psi[i] == 0.0:
            continue
        t0 = tang[i, 0]
        t1 = tang[i, 1]
        q = A[i] * sigma1 * kernel_f(0.0, kernel_code) * psi[i] * (
            t0 * t0 * M[i, 0] + 2.0 * t0 * t1 * M[i, 1] + t1 * t1 * M[i, 2])
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if not fl[j] or psi[j] == 0.0:
                continue
            if g[i, 0] * g[j, 0] + g[i, 1] * g[j, 1] <= 0.0:
                continue
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            mtt = t0 * t0 * M[j, 0] + 2.0 * t0 * t1 * M[j, 1] + t1 * t1 * M[j, 2]
            q += A[j] * sigma1 * kernel_f(abs(t0 * r0 + t1 * r1) / R, kernel_code) * psi[j] \
                * mtt
        Q[i] = q


@njit(cache=True, parallel=True)
def stress_force(x, A, rho, n, offsets, indices, R, fac2, kernel_code, period, S, eps, acc):
    """acc[i] = 1 / rho_i sum_j A_j (S_i + S_j) (1 - eps f_ij^4) . grad_i W_ij (eq. S2) of the
    rows i < n over their listed neighbours; S = (S_rr, S_rz, S_zz); f_ij = W(r_ij) /
    W(sqrt(A_i)) (the artificial stress of Monaghan 2000 on the tension; eps = 0: off)."""
    R2 = R * R
    periodic = period[0] > 0.0 or period[1] > 0.0
    for i in prange(n):
        wdx = kernel_f(math.sqrt(A[i]) / R, kernel_code)
        f0 = 0.0
        f1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r0, r1, r2 = pair_sep(x, i, j, 2, period, periodic)
            d2 = r0 * r0 + r1 * r1
            if d2 >= R2 or d2 == 0.0:
                continue
            t = A[j] * grad_factor(math.sqrt(d2), R, fac2, kernel_code)
            if eps > 0.0:
                fij = kernel_f(math.sqrt(d2) / R, kernel_code) / wdx
                t *= 1.0 - eps * fij * fij * fij * fij
            srr = S[i, 0] + S[j, 0]
            srz = S[i, 1] + S[j, 1]
            szz = S[i, 2] + S[j, 2]
            f0 += t * (srr * r0 + srz * r1)
            f1 += t * (srz * r0 + szz * r1)
        acc[i, 0] = f0 / rho[i]
        acc[i, 1] = f1 / rho[i]


def art_stress_gain(eps: float, R_over_s: float, kernel_code: int) -> float:
    """The factor that restores the flux of a uniform tension through a cut of the square
    lattice of spacing s when the pairs carry (1 - eps f^4) (:func:`stress_force`):
    sum F (t . r)^2 / sum F (1 - eps f^4) (t . r)^2 over the lattice within the support."""
    if eps <= 0.0:
        return 1.0
    R = float(R_over_s)
    m = int(math.ceil(R))
    fac2 = kernels.kernel_sigma(kernel_code, 2, R) / (R * R)
    w1 = kernel_f(1.0 / R, kernel_code)
    full = art = 0.0
    for a in range(-m, m + 1):
        for b in range(-m, m + 1):
            d = math.hypot(a, b)
            if d == 0.0 or d >= R:
                continue
            F = grad_factor(d, R, fac2, kernel_code)
            f = kernel_f(d / R, kernel_code) / w1
            full += F * a * a
            art += F * (1.0 - eps * f**4) * a * a
    return full / art


def face_tension(csf, x, A, fl, n, offsets, indices, R, period, g, omega, M, src, mtype):
    """The face tension tau (augmented rows, 0 off the faces) and the face tangent (module
    docstring): tau_i = sigma psi_i / Q_i, psi = omega."""
    from sphfem.fluid.axisymmetric_surface_tension import row_moment

    kcode = csf.kernel_code
    gn = np.sqrt(g[:, 0] ** 2 + g[:, 1] ** 2)
    a = np.clip((gn * R - FACE_G_LO) / (FACE_G_HI - FACE_G_LO), 0.0, 1.0)
    psi = np.where(fl & (gn > 0.0), a * a * (3.0 - 2.0 * a), 0.0)
    nz = np.where(gn > 0.0, gn, 1.0)
    tang = np.column_stack([-g[:, 1] / nz, g[:, 0] / nz])
    Q = np.zeros(x.shape[0])
    face_moment(x, A, fl, n, offsets, indices, R, kernels.kernel_sigma(kcode, 1, R), kcode,
                period, tang, g, psi, M, Q)
    from sphfem.fluid.axisymmetric_surface_tension import film_max, mirror_scalar

    mirror_scalar(n, src, Q)  # Q the largest over the row and its neighbours (as the film's)
    Qm = np.zeros_like(Q)
    film_max(x, fl, n, offsets, indices, R, period, Q, Qm)
    Q = Qm
    sp = np.sqrt(np.maximum(A, 1e-300))
    Qf = np.maximum(Q, FACE_Q_MIN * psi * row_moment(sp, R, kcode))
    tau = np.where(Qf > 0.0, csf.sigma * psi / np.where(Qf > 0.0, Qf, 1.0), 0.0)
    return tau, tang


def surface_stress_forces(csf, x, A, rho, kind, n, src, mtype, R, Lz, plane) -> np.ndarray:
    """The acceleration of the real fluid rows i < n (module docstring) from the augmented
    set of the fluid (``kind``: FLUID, WALL and their mirrors n + q of ``src[q]``, type
    ``mtype[q]``), its z period ``Lz`` (0: open) and the wall plane z = ``plane`` (None)."""
    from sphfem.axisymmetric import MIRROR_FLUID
    from sphfem.fluid.axisymmetric_surface_tension import (
        NORMAL_HI,
        NORMAL_LO,
        film_hoop,
        mirror_normals,
        mirror_scalar,
    )
    from sphfem.fluid.surface_tension_csf import csf_normals
    from sphfem.neighbors import build_neighbor_list
    from sphfem.particles import FLUID

    kind = np.asarray(kind)
    own = np.flatnonzero(kind[:n] == FLUID)
    mir = np.flatnonzero(kind[n:] == MIRROR_FLUID)
    idx = np.concatenate([own, n + mir])
    pos = np.full(x.shape[0], -1, np.int64)
    pos[idx] = np.arange(idx.size)
    k = own.size
    msrc = pos[np.asarray(src)[mir]]
    mtyp = np.asarray(mtype, np.int8)[mir]
    xs, As, rs = x[idx], A[idx], rho[idx]
    if plane is not None:  # the images (type 2) across the wall plane, after the mirrors
        near = np.flatnonzero(xs[:, 1] - plane < R)
        im = xs[near].copy()
        im[:, 1] = 2.0 * plane - im[:, 1]
        xs = np.vstack([xs, im])
        As = np.concatenate([As, As[near]])
        rs = np.concatenate([rs, rs[near]])
        msrc = np.concatenate([msrc, near])
        mtyp = np.concatenate([mtyp, np.full(near.size, 2, np.int8)])
    m = xs.shape[0]
    period = np.array([0.0, float(Lz)])
    lo = xs.min(axis=0) - R
    hi = xs.max(axis=0) + R
    nl = build_neighbor_list(xs, R, lo, hi, period)
    off, ind = nl.offsets, nl.indices
    ks = np.full(m, FLUID, np.int8)
    kc = csf.kernel_code
    g = np.zeros((m, 2))
    omega = np.zeros(m)
    csf_normals(xs, As, ks, off, ind, R, kernels.kernel_sigma(kc, 2, R), kc, period,
                NORMAL_LO, NORMAL_HI, g, omega)
    mirror_normals(k, msrc, mtyp, g, omega)
    ks[k:] = MIRROR_FLUID
    f = csf.film_fields(xs, As, rs, ks, off, ind, k, msrc, mtyp, R, period)
    fl, M, phi = f["fl"], f["M"], f["phi"]
    tau_f, tang_f = face_tension(csf, xs, As, fl, k, off, ind, R, period, g, omega, M,
                                 msrc, mtyp)
    mirror_scalar(k, msrc, tau_f)
    tf = np.column_stack([tang_f[:, 0] ** 2, tang_f[:, 0] * tang_f[:, 1],
                          tang_f[:, 1] ** 2])
    S = phi[:, None] * f["S"] + (1.0 - phi)[:, None] * (tau_f[:, None] * tf)
    if ART_EPS > 0.0:
        S *= art_stress_gain(ART_EPS, R / float(np.sqrt(np.median(As[:k]))), kc)
    fac2 = kernels.kernel_sigma(kc, 2, R) / (R * R)
    acc = np.zeros((k, 2))
    stress_force(xs, As, rs, k, off, ind, R, fac2, kc, period, S, ART_EPS, acc)
    csf.stress_planar = acc.copy()
    csf.stress_phi = phi[:k].copy()
    if csf.hoop:
        s = csf.axis_fade(xs[:k, 0], R)[:, None]
        p = phi[:k, None]
        hoop = (p * film_hoop(xs[:k], rs[:k], f["tau"][:k], f["tang"][:k], M[:k])
                + (1.0 - p) * film_hoop(xs[:k], rs[:k], tau_f[:k], tang_f[:k], M[:k]))
        gn = np.sqrt(g[:k, 0] ** 2 + g[:k, 1] ** 2)
        nrm = g[:k] / np.where(gn > 0.0, gn, 1.0)[:, None]
        pole = np.sum(acc * nrm, axis=1)[:, None] * nrm  # the pole: hoop = meridian part
        acc += s * hoop + (1.0 - s) * (1.0 - p) * pole
    out = np.zeros((n, 2))
    out[own] = acc
    return out
