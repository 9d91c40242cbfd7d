"""Laminar viscosity of Morris, Fox & Zhu (1997) (``viscosity = "morris"``).

J. P. Morris, P. J. Fox, Y. Zhu (1997), J. Comput. Phys. 136, 214 (their SPH viscous term):

    <mu/rho lap u>_i = sum_j m_j (mu_i + mu_j) (r_ij . grad_i W_ij)
                             / (rho_i rho_j (r_ij^2 + eps h^2)) u_ij

with r_ij = x_i - x_j, u_ij = u_i - u_j; in the notation of :mod:`sphfem.fluid.passes`
(r = x_j - x_i, grad_i W_ij = F r) the pair acceleration is m_j (mu_i + mu_j) F |r|^2 /
(rho_i rho_j (|r|^2 + eps h^2)) (u_j - u_i).  It differs from the fused Shao & Lo form
(``"laminar"``) only in the density factor, rho_i rho_j instead of (rho_i + rho_j)^2 / 4,
so the two agree to O((rho_i - rho_j)^2).  ``eps`` is ``[fluid] eps_visc``.  A wall
neighbour (mass rho_w V_w) takes the fluid particle's mu and the wall model's ghost
velocity; each wall particle's ``f_fluid`` receives the exact negative of its pair forces
on the fluid.  One gather pass after the WCSPH forces (the fused pass then sees mu = 0).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import grad_factor
from sphfem.fluid.viscosity import ViscosityMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID, WALL
from sphfem.smallmat import pair_sep


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def morris_viscosity(x, vg, rho, meff, mu, kind, offsets, indices, R, sigma, kernel_code,
                     period, eps2, acc, f_wall):
    """acc[i] += the Morris et al. (1997) viscous acceleration of fluid particle i (fluid
    and wall neighbours); f_wall[w] += the reaction on wall particle w (fluid neighbours).

    ``vg``: velocity seen by the viscous term (v of fluid, ghost velocity of walls),
    ``meff``: mass (m of fluid, rho_w V_w of walls), ``eps2`` = eps_visc h^2.
    """
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / (R * R)
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    for i in prange(n):
        ki = kind[i]
        if ki != FLUID and ki != WALL:
            continue
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            kj = kind[j]
            if kj != FLUID and (ki == WALL or kj != WALL):
                continue  # fluid rows: fluid and wall neighbours; wall rows: fluid only
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            F = grad_factor(np.sqrt(d2), R, fac2, kernel_code)
            mus = 2.0 * mu[j] if ki == WALL else (
                mu[i] + mu[j] if kj == FLUID else 2.0 * mu[i])
            c = meff[j] * mus * F * d2 / (rho[i] * rho[j] * (d2 + eps2))
            a0 += c * (vg[j, 0] - vg[i, 0])
            if dim > 1:
                a1 += c * (vg[j, 1] - vg[i, 1])
            if dim > 2:
                a2 += c * (vg[j, 2] - vg[i, 2])
        if ki == FLUID:
            acc[i, 0] += a0
            if dim > 1:
                acc[i, 1] += a1
            if dim > 2:
                acc[i, 2] += a2
        else:
            f_wall[i, 0] += meff[i] * a0
            if dim > 1:
                f_wall[i, 1] += meff[i] * a1
            if dim > 2:
                f_wall[i, 2] += meff[i] * a2


def _accelerate(solver, state):
    p, s, nl = solver.p, solver._scratch, solver.nbrs
    morris_viscosity(p.x, s.vg, p.rho, s.meff, p.mu, p.kind, nl.offsets, nl.indices,
                     solver.R, solver.sigma, solver.kernel_code, solver.period,
                     solver.params.eps_visc * solver.h * solver.h, p.acc, p.f_fluid)
    return state


METHOD = register(ViscosityMethod(
    name="morris",
    doc="Newtonian, Morris, Fox & Zhu (1997): m_j (mu_i + mu_j) / (rho_i rho_j), "
        "its own pass after the WCSPH forces (a worked example of adding a method)",
    params=(),
    fused=False,
    accelerate=_accelerate,
))
