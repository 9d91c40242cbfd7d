"""Navier slip at the walls of the axisymmetric fluid (``[fluid] wall_slip``, ``slip_length``).

The (r, z) form of :mod:`sphfem.fluid.wall_slip`.  Adami's ghost velocity 2 v_w - v~_w
mirrors the fluid's extrapolated velocity v~_w about the wall's (no slip).  With a slip
length b the ghost keeps the mirrored normal part and continues the tangential part along
the linear profile u_t = G (b + y) through the wall face (Navier 1823: u_t = b du_t/dn):

    vg_w = v_w - (u . n) n + lambda_w (u - (u . n) n),   u = v~_w - v_w,
    lambda_w = (b - y_w) / (b + y_w),   y_w = |d_w| / 2,                          (1)

d_w = sum_f (x_w - x_f) W_wf / sum_f W_wf the kernel-weighted mean separation from the
fluid (and its axis mirrors), whose direction is the wall normal.  lambda = -1 for b = 0
(Adami), +1 for free slip (b -> infinity).

Why (issue 16): on a no-slip wall a moving contact line carries the stress singularity of
Huh & Scriven (1971), whose dissipation grows as ln(L / dx) under refinement, so a
spreading drop's maximum diameter falls with dx without end; a slip length b regularises
it (the dissipation saturates at ln(L / b)), and the spread converges once dx << b
(docs/validation/droplet_impact, session 32).  The wall's viscous traction becomes
mu u_slip / b where the profile is resolved.
"""

from __future__ import annotations

import math

from numba import njit, prange

from sphfem import kernels
from sphfem.axisymmetric import MIRROR_FLUID
from sphfem.fluid.wall_slip import MODES  # noqa: F401  (the ``wall_slip`` choices -> mode)
from sphfem.neighbors import min_image
from sphfem.particles import FLUID, WALL


@njit(cache=True, parallel=True)
def slip_ghost_rz(x, v, vg, kind, offsets, indices, Rp, kcode, Lz, mode, b):
    """Eq. (1) on the real WALL rows of the augmented state (``kind`` over the augmented
    rows; fluid neighbours = FLUID and their axis mirrors, pair support (R_w + R_f) / 2).
    ``vg`` holds Adami's ghost on entry; rows without fluid neighbours keep theirs.
    ``mode`` 1: free slip (lambda = 1), 2: Navier with slip length ``b`` [m]."""
    for i in prange(x.shape[0]):
        if kind[i] != WALL:
            continue
        sw = 0.0
        d0 = 0.0
        d1 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID and kind[j] != MIRROR_FLUID:
                continue
            r0 = x[i, 0] - x[j, 0]
            r1 = min_image(x[i, 1] - x[j, 1], Lz)
            q2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[j])
            if q2 >= R * R:
                continue
            w = kernels.kernel_f(math.sqrt(q2) / R, kcode)
            sw += w
            d0 += w * r0
            d1 += w * r1
        if sw <= 0.0:
            continue
        dn = math.sqrt(d0 * d0 + d1 * d1) / sw
        if dn <= 0.0:
            continue
        n0 = d0 / (sw * dn)
        n1 = d1 / (sw * dn)
        lam = 1.0 if mode == 1 else (b - 0.5 * dn) / (b + 0.5 * dn)
        u0 = v[i, 0] - vg[i, 0]  # u = v~ - v_w = v_w - vg (Adami's ghost on entry)
        u1 = v[i, 1] - vg[i, 1]
        un = u0 * n0 + u1 * n1
        vg[i, 0] = v[i, 0] - un * n0 + lam * (u0 - un * n0)
        vg[i, 1] = v[i, 1] - un * n1 + lam * (u1 - un * n1)
