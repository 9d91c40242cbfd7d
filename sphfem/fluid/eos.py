"""Tait equation of state (Park 2019 eq. 2.19 / 2.73; Monaghan 1994; Batchelor's form):

    p = B ((rho / rho0)^gamma - 1),    B = rho0 c0^2 / gamma,

and its inverse rho = rho0 (p / B + 1)^(1/gamma), used for the wall density of the Adami
boundary and for hydrostatic initial densities.  c0 is a *numerical* speed of sound, chosen
so that the Mach number stays below ~0.1 (density variations below ~1 %).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def tait_pressure(rho, rho0, B, gamma):
    """p = B ((rho / rho0)^gamma - 1)."""
    return B * ((rho / rho0) ** gamma - 1.0)


@njit(cache=True, inline="always")
def tait_density(p, rho0, B, gamma):
    """Inverse of :func:`tait_pressure`: rho = rho0 (p / B + 1)^(1/gamma) (p > -B)."""
    s = p / B + 1.0
    if s <= 0.0:  # beyond the EOS' tensile limit: return the vacuum density
        return 0.0
    return rho0 * s ** (1.0 / gamma)


def tait_B(rho0: float, c0: float, gamma: float) -> float:
    """Stiffness B = rho0 c0^2 / gamma [Pa]."""
    return rho0 * c0 * c0 / gamma


def pressure(rho, rho0: float, c0: float, gamma: float = 7.0) -> np.ndarray:
    """Vectorised Tait pressure [Pa] for densities ``rho`` [kg/m^3]."""
    B = tait_B(rho0, c0, gamma)
    return B * ((np.asarray(rho, float) / rho0) ** gamma - 1.0)


def density(p, rho0: float, c0: float, gamma: float = 7.0) -> np.ndarray:
    """Vectorised inverse Tait equation: density [kg/m^3] for pressures ``p`` [Pa]."""
    B = tait_B(rho0, c0, gamma)
    return rho0 * (np.asarray(p, float) / B + 1.0) ** (1.0 / gamma)
