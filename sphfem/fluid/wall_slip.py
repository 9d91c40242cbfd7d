"""Slip of the viscous term at boundary-particle walls (``[fluid] wall_slip``).

The Adami et al. (2012) ghost velocity 2 v_w - v~_w mirrors the fluid's velocity v~_w
(extrapolated onto wall particle w) about the wall velocity: no slip.  On a no-slip wall
a moving contact line meets the stress singularity of Huh & Scriven (1971) (the viscous
force diverges as the log of the cut-off), and a particle contact line stays pinned near
its start.  SPH codes relax it with a free-slip or Navier-slip wall for the viscous term
(Huber et al. 2016, Breinlinger et al. 2013).  Here the ghost velocity keeps the mirrored
normal component (no penetration, as Adami) and gives the tangential one the slip:

    v^ghost_w = v_w - (v~_w - v_w)_n + lambda_w (v~_w - v_w)_t,
    lambda_w = (b - y_w) / (b + y_w)        (Navier: u_t = b du_t/dn at the wall face)

``no-slip``: lambda = -1 (Adami's ghost velocity; this module is then not called at all);
``free-slip``: lambda = +1 (b -> infinity: du_t/dn = 0); ``navier``: slip length
b = ``slip_length`` [m].  lambda follows from the linear profile u_t = G (b + y) through
the wall face, mirrored as Adami does: the fluid's mean lies at height y_w above the face
when the wall particle lies y_w below it, so 2 y_w = |d_w| with the kernel-weighted mean
separation d_w = sum_f (x_w - x_f) W_wf / sum_f W_wf, whose direction is the wall normal
n (pointing into the wall).  Everything that reads the ghost velocity (the fused viscous
pass, a non-fused viscosity model, the rheology's strain rate) sees the slip.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.kernels import FASTMATH, kernel_f
from sphfem.neighbors import min_image
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param

#: the ``wall_slip`` choices -> code of :func:`slip_ghost_velocity`
MODES = {"no-slip": 0, "free-slip": 1, "navier": 2}


def slip_params(when: tuple) -> tuple:
    """The scene keys ``wall_slip`` and ``slip_length`` (valid under ``when``)."""
    return (
        Param("wall_slip", str, "no-slip", choices=tuple(MODES), when=when,
              doc="tangential velocity of the walls in the viscous term "
                  "(sphfem.fluid.wall_slip): no-slip = Adami's mirrored ghost velocity; "
                  "free-slip = the fluid's tangential velocity (du_t/dn = 0); navier = "
                  "slip length `slip_length` (u_t = b du_t/dn); the normal component stays "
                  "mirrored (no penetration).  A moving contact line needs slip.  "
                  "Axisymmetric scenes: with wall_friction = \"viscous\" "
                  "(sphfem.fluid.axisymmetric_wall_slip)"),
        Param("slip_length", float, 0.0, unit="m", ge=0.0, quantity="length", when=when,
              doc="Navier slip length b [m] of wall_slip = \"navier\" (0: no slip)"),
    )


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def slip_ghost_velocity(x, v, kind, offsets, indices, R, kernel_code, period, mode, b, vg):
    """Replace the ghost velocity ``vg`` of every wall row (module doc): from Adami's
    2 v_w - v~_w (on entry) to the slip form; ``mode`` 1 free-slip, 2 Navier with slip
    length ``b``.  Rows without fluid neighbours keep theirs (v_w)."""
    n, dim = x.shape
    R2 = R * R
    for i in prange(n):
        if kind[i] != WALL:
            continue
        sw = 0.0
        d0 = 0.0
        d1 = 0.0
        d2_ = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            r0 = min_image(x[i, 0] - x[j, 0], period[0])  # x_w - x_f
            r1 = min_image(x[i, 1] - x[j, 1], period[1]) if dim > 1 else 0.0
            r2 = min_image(x[i, 2] - x[j, 2], period[2]) if dim > 2 else 0.0
            q2 = r0 * r0 + r1 * r1 + r2 * r2
            if q2 >= R2:
                continue
            w = kernel_f(np.sqrt(q2) / R, kernel_code)
            sw += w
            d0 += w * r0
            d1 += w * r1
            d2_ += w * r2
        if sw <= 0.0:
            continue
        dn = np.sqrt(d0 * d0 + d1 * d1 + d2_ * d2_) / sw
        if dn <= 0.0:
            continue
        nv = (d0 / (sw * dn), d1 / (sw * dn), d2_ / (sw * dn))
        if mode == 1:
            lam = 1.0
        else:
            y = 0.5 * dn
            lam = (b - y) / (b + y)
        # u = v~ - v_w = v_w - vg (Adami's ghost on entry)
        un = 0.0
        for k in range(dim):
            un += (v[i, k] - vg[i, k]) * nv[k]
        for k in range(dim):
            u = v[i, k] - vg[i, k]
            ut = u - un * nv[k]
            vg[i, k] = v[i, k] - un * nv[k] + lam * ut


def apply_slip(solver) -> None:
    """Give the wall rows of ``solver._scratch.vg`` the slip of ``solver.params``
    (``wall_slip``, ``slip_length``); nothing for no-slip (or a parameter set without the
    keys)."""
    pa = solver.params
    mode = MODES[getattr(pa, "wall_slip", "no-slip") or "no-slip"]
    if mode == 0:
        return
    p, nl = solver.p, solver.nbrs
    slip_ghost_velocity(p.x, p.v, p.kind, nl.offsets, nl.indices, solver.R, solver.kernel_code,
                        solver.period, mode, float(getattr(pa, "slip_length", 0.0) or 0.0),
                        solver._scratch.vg)
