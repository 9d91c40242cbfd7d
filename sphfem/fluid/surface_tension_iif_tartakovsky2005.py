"""Inter-particle interaction force (IIF) surface tension (``surface_tension = "iif"``).

The inter-particle interaction force of Tartakovsky & Meakin (2005) with the
mass weighting of Park (2019) eq. 2.78.  The pair force on i from j is

    F_ij = s w_ij cos(3 pi d / (2 R)) e_ji,    d <= R,   e_ji = (x_i - x_j)/d,

repulsive for d < R/3, attractive for R/3 < d < R.  The thesis prints the weight
2 m_i/(m_i + m_j), which makes F_ij != -F_ji for unequal masses (it is the pair
*accelerations* that are then opposite); we use the symmetric weight
w_ij = 2 m_i m_j / ((m_i + m_j) m_bar) (m_bar: mean fluid particle mass), which equals
the thesis' weight for equal masses and conserves linear and angular momentum exactly.
``s`` [N] is the calibration constant of the model (the "1e6 N" of the thesis' droplet
case), *not* the surface tension sigma [N/m].  Calibration (:func:`iif_constant`): for
a pair force f(d) (repulsive > 0) between particles of number density n = rho0/m_bar,
cutting a uniform fluid along a plane costs the energy per area 2 sigma =
-n^2 int_{z>0} z phi(|r|) d^d r (phi the pair potential, f = -phi').  Integrating by
parts,

    sigma_3D = -(pi/8) n^2 int_0^R f(d) d^4 dd,   sigma_2D = -(1/3) n^2 int_0^R f(d) d^3 dd,

so sigma = s n^2 R^(d+2) c_d with c_3D = -(pi/8) int_0^1 cos(3 pi q/2) q^4 dq and
c_2D = -(1/3) int_0^1 cos(3 pi q/2) q^3 dq (:data:`IIF_C`).  This is the half-space
(Kirkwood-Buff, uniform pair distribution) estimate; it is checked against the Laplace
pressure jump of static droplets in the tests and against Rayleigh's oscillation period
in ``sphfem validate droplet-oscillation``.

Not recommended: in the 2D droplet of ``sphfem validate droplet-oscillation`` the IIF run
stops on the speed guard, and in 3D it responds elasto-plastically (period off by ~40 %);
use ``csf`` (:mod:`sphfem.fluid.surface_tension_csf`).  Acts between fluid particles only
(no wall adhesion).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem.fluid.surface_tension import SurfaceTensionMethod, register
from sphfem.kernels import FASTMATH
from sphfem.particles import FLUID
from sphfem.schema import Param
from sphfem.smallmat import pair_sep


def _iif_integral(power: int) -> float:
    q = np.linspace(0.0, 1.0, 20001)
    f = np.cos(1.5 * math.pi * q) * q**power
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


#: sigma = s n^2 R^(dim+2) IIF_C[dim] (half-space integral of the IIF pair force)
IIF_C = {2: -_iif_integral(3) / 3.0, 3: -math.pi / 8.0 * _iif_integral(4)}


def iif_constant(sigma: float, rho0: float, m_bar: float, R: float, dim: int) -> float:
    """Calibration constant s [N] of the IIF model for the surface tension ``sigma`` [N/m]."""
    n = rho0 / m_bar
    return sigma / (n * n * R ** (dim + 2) * IIF_C[dim])


def iif_sigma(s: float, rho0: float, m_bar: float, R: float, dim: int) -> float:
    """Inverse of :func:`iif_constant`: the surface tension [N/m] of constant ``s`` [N]."""
    n = rho0 / m_bar
    return s * n * n * R ** (dim + 2) * IIF_C[dim]


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def iif_accel(x, m, kind, offsets, indices, R, s, m_bar, period, acc):
    """acc[i] += sum_j F_ij / m_i of the IIF model (fluid-fluid pairs within R)."""
    n, dim = x.shape
    R2 = R * R
    periodic = False
    for k in range(dim):
        periodic |= period[k] > 0.0
    c = 1.5 * math.pi / R
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        mi = m[i]
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID:
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            mj = m[j]
            w = 2.0 * mj / ((mi + mj) * m_bar)  # (2 m_i m_j/((m_i+m_j) m_bar)) / m_i
            f = -s * w * np.cos(c * d) / d  # along r = x_j - x_i: minus e_ji
            a0 += f * r0
            a1 += f * r1
            a2 += f * r2
        acc[i, 0] += a0
        if dim > 1:
            acc[i, 1] += a1
        if dim > 2:
            acc[i, 2] += a2



def _calibrate(pa, m_bar: float, R: float, dim: int):
    """(s, the sigma it represents): s = ``iif_s`` if set, else from the material's sigma."""
    s = pa.iif_s if pa.iif_s is not None else iif_constant(pa.sigma, pa.rho0, m_bar, R, dim)
    return s, iif_sigma(s, pa.rho0, m_bar, R, dim)


def _accelerate(solver, state):
    p, nl = solver.p, solver.nbrs
    iif_accel(p.x, p.m, p.kind, nl.offsets, nl.indices, solver.R, solver.st_constant,
              solver.m_bar, solver.period, p.acc)
    return state


METHOD = register(SurfaceTensionMethod(
    name="iif",
    doc="inter-particle interaction force (Tartakovsky & Meakin 2005 with the mass "
        "weighting of Park 2019 eq. 2.78), calibrated to the material's sigma by the "
        "half-space integral of the pair potential (see "
        "sphfem.fluid.surface_tension_iif_tartakovsky2005); fails the droplet oscillation check "
        "(sphfem validate droplet-oscillation)",
    params=(
        Param("iif_s", float, None, unit="N", positive=True, quantity="force",
              when=("surface_tension", ("iif",)),
              doc="calibration constant s of the IIF pair force (the thesis' \"1e6 N\"); "
                  "unset: computed from the material's sigma [N/m]"),
    ),
    constant_key="iif_s",
    calibrate=_calibrate,
    accelerate=_accelerate,
))
