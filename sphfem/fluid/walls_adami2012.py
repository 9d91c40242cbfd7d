"""Solid walls of boundary particles: Adami, Hu & Adams (2012), J. Comput. Phys. 231, 7057.

Wall particles (kind WALL) fill a few layers (>= R / dx) behind the wall surface.  Before
every force evaluation each wall particle w takes, from its *fluid* neighbours f,

    p_w = [sum_f p_f W_wf + (g - a_w) . sum_f rho_f (x_w - x_f) W_wf] / sum_f W_wf   (eq. 27)
    v~_w = sum_f v_f W_wf / sum_f W_wf,     v^ghost_w = 2 v_w - v~_w                   (eq. 22-23)
    rho_w = rho0 (p_w / B + 1)^(1/gamma)    (inverse Tait EOS)                        (eq. 28)

so that the fluid sees a hydrostatic wall pressure (no penetration) and a mirrored tangential
velocity (no slip).  ``a_w`` is the wall's prescribed acceleration, ``v_w`` its velocity.
A wall particle without fluid neighbours gets p = 0, rho = rho0, ghost velocity = v_w.
The fluid sees a wall particle with mass rho_w V_w (V_w its fixed volume ``vol``), so the
pressure force is the same symmetric pair form as between fluid particles, and the wall's
viscosity is taken equal to the fluid particle's (mu_i + mu_j -> 2 mu_i).

``wall_slip`` = "free-slip" / "navier" gives the tangential part of the ghost velocity a
slip (:mod:`sphfem.fluid.wall_slip`; the default "no-slip" is the above).

Registered as ``[fluid] walls = "adami2012"`` (:mod:`sphfem.fluid.walls`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.fluid.eos import tait_density
from sphfem.fluid.wall_slip import apply_slip, slip_params
from sphfem.fluid.walls import WallMethod, register
from sphfem.kernels import FASTMATH, kernel_f
from sphfem.neighbors import min_image
from sphfem.particles import FLUID, WALL


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def adami_wall_state(x, v, rho, p, acc, kind, offsets, indices, R, kernel_code, period,
                     gravity, rho0, B, gamma, vg):
    """Extrapolate p, rho and the ghost velocity ``vg`` onto every WALL particle (in place).

    ``p`` of the fluid particles must be up to date; ``acc`` of a wall particle is its
    prescribed acceleration.  Only rows of wall particles are written.
    """
    n, dim = x.shape
    R2 = R * R
    for i in prange(n):
        if kind[i] != WALL:
            continue
        sw = 0.0
        sp = 0.0
        sr0 = 0.0
        sr1 = 0.0
        sr2 = 0.0
        sv0 = 0.0
        sv1 = 0.0
        sv2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            r0 = min_image(x[i, 0] - x[j, 0], period[0])  # x_w - x_f
            r1 = min_image(x[i, 1] - x[j, 1], period[1]) if dim > 1 else 0.0
            r2 = min_image(x[i, 2] - x[j, 2], period[2]) if dim > 2 else 0.0
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2:
                continue
            w = kernel_f(np.sqrt(d2) / R, kernel_code)
            sw += w
            sp += p[j] * w
            rw = rho[j] * w
            sr0 += rw * r0
            sr1 += rw * r1
            sr2 += rw * r2
            sv0 += v[j, 0] * w
            if dim > 1:
                sv1 += v[j, 1] * w
            if dim > 2:
                sv2 += v[j, 2] * w
        srx = (sr0, sr1, sr2)
        sv = (sv0, sv1, sv2)
        if sw > 0.0:
            hyd = 0.0
            for k in range(dim):
                hyd += (gravity[k] - acc[i, k]) * srx[k]
            pw = (sp + hyd) / sw
            p[i] = pw
            rho[i] = tait_density(pw, rho0, B, gamma)
            if rho[i] < 0.5 * rho0:  # strong suction: keep the wall density sane
                rho[i] = 0.5 * rho0
            for k in range(dim):
                vg[i, k] = 2.0 * v[i, k] - sv[k] / sw
        else:
            p[i] = 0.0
            rho[i] = rho0
            for k in range(dim):
                vg[i, k] = v[i, k]


def _wall_state(solver, g) -> None:
    p, pa, nl = solver.p, solver.params, solver.nbrs
    adami_wall_state(p.x, p.v, p.rho, p.p, p.acc, p.kind, nl.offsets, nl.indices, solver.R,
                     solver.kernel_code, solver.period, g, pa.rho0, solver.B, pa.gamma,
                     solver._scratch.vg)
    apply_slip(solver)  # [fluid] wall_slip (no-slip: nothing)


METHOD = register(WallMethod(
    name="adami2012",
    doc="boundary particles of Adami, Hu & Adams (2012): wall pressure extrapolated from "
        "the fluid with the hydrostatic and wall-acceleration term, density from the "
        "inverse Tait EOS, mirrored (no-slip) ghost velocity, or a free / Navier slip of "
        "its tangential part (wall_slip)",
    params=slip_params(("walls", ("adami2012",))),
    wall_state=_wall_state,
))
