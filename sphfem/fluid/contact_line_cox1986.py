"""A moving contact line's friction below the particle spacing (Cox 1986; ``[fluid]
contact_line = "cox-voinov"``).

A no-slip wall cannot carry a moving contact line: the viscous force on a wedge of liquid
of angle theta between the scales lambda and L is (Huh & Scriven 1971, J. Colloid Interface
Sci. 35, 85)

    F / length = mu U ln(L / lambda) / g'(theta),                                     (1)

which diverges as the slip length lambda -> 0.  Cox (1986, J. Fluid Mech. 168, 169) matched
the wedge to the outer flow: the apparent angle theta_a seen at the scale L obeys

    g(theta_a) - g(theta_s) = Ca ln(L / lambda),    Ca = mu U / sigma,
    g(theta) = int_0^theta (x - sin x cos x) / (2 sin x) dx                          (2)

(g ~ theta^3 / 9 for small angles: Voinov's 1976 law), theta_s the static angle at the
molecular scale.  A particle method resolves the flow down to about the spacing: what lies
below it, from lambda to Delta = dx / 2 (the first row's height), is the sub-grid wedge, and
its force on the contact line's particles is the unbalanced Young force at the grid scale,
sigma (cos theta_s - cos theta_Delta), which (2) linearised about theta_s gives as a line
friction

    F / length = -zeta U,    zeta = mu ln(Delta / lambda) sin(theta_s) / g'(theta_s),
    g'(theta) = (theta - sin theta cos theta) / (2 sin theta)                         (3)

(zeta = (4 / pi) mu ln(Delta / lambda) at 90 degrees).  The linearisation over-states the
force by 8 % at c = Ca ln(Delta / lambda) = 0.1 and by 20 % at 0.25 (90 degrees; the 10 m/s
droplet impact's contact line starts at c ~ 0.3), so the friction applied is the secant of
the full law (2) at each ring's own speed along the wall:

    F / length = -zeta(c) U,    zeta(c) / mu = ln(Delta / lambda) phi(c),
    phi(c) = (cos theta_s - cos theta_Delta(c)) / c,    phi(0) = sin theta_s / g'(theta_s),  (3')

the advancing branch (theta_Delta > theta_s) for either direction of motion: a receding
line's larger friction (g is steeper below 90 degrees) is not modelled.

This is the approach of Afkhami, Zaleski & Bussmann (2009, J. Comput. Phys. 228, 5370), who
impose theta_Delta from (2) at the grid scale so that the computed spreading stops depending
on the grid: here it enters as the friction of the contact line's rings instead of as a
boundary angle.  Refining moves wedge dissipation from (3') into the resolved flow; the sum
stays mu U ln(L / lambda) / g'(theta_s) (1).

In the wall layer's friction (:mod:`sphfem.fluid.wall_layer`) the rings at the end of a wall
row (weight w of :func:`~sphfem.fluid.wall_layer.contact_line_weight`) carry the factor

    f_cl = zeta(c) / (S mu),                                                          (4)

S the plug-traction constant of eq. (1) there (the plain wall term on the end column of a
lattice, all rows of the band, is S mu U per unit length of contact line: the wall runs on
under it), capped by the viscous step limit as the layer's factor is.  theta_s is the
angle of the fluid's surface model at the wall: the axisymmetric CSF meets a wall at 90
degrees.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.integrate import quad

#: slip length lambda of water on a smooth solid [m]: the molecular scale (Afkhami et al.
#: 2009 take lambda / Delta from 1e-3 to 1e-1 of their cells; Cox's lambda ~ 1 nm)
SLIP_LENGTH = 1.0e-9


def wedge_function(theta: float) -> float:
    """g(theta) of eq. (2) (Cox 1986, eq. 7.6 without the viscosity ratio), theta in
    radians, 0 < theta < pi."""
    if not 0.0 < theta < math.pi:
        raise ValueError(f"contact angle must lie in (0, pi) rad, got {theta!r}")
    return quad(lambda x: (x - math.sin(x) * math.cos(x)) / (2.0 * math.sin(x)), 0.0,
                theta)[0]


def wedge_slope(theta: float) -> float:
    """g'(theta) = (theta - sin theta cos theta) / (2 sin theta) of eq. (3)."""
    if not 0.0 < theta < math.pi:
        raise ValueError(f"contact angle must lie in (0, pi) rad, got {theta!r}")
    return (theta - math.sin(theta) * math.cos(theta)) / (2.0 * math.sin(theta))


def subgrid_friction(theta_s_deg: float, delta: float, slip_length: float) -> float:
    """zeta / mu of eq. (3): the line friction of the wedge between the slip length and the
    grid scale ``delta`` [m] (0 when delta <= slip_length: the wedge is resolved)."""
    if not slip_length > 0.0:
        raise ValueError(f"contact_line_slip_length must be > 0, got {slip_length!r}")
    if not delta > 0.0:
        raise ValueError(f"grid scale must be > 0, got {delta!r}")
    th = math.radians(theta_s_deg)
    return max(0.0, math.log(delta / slip_length)) * math.sin(th) / wedge_slope(th)


def contact_line_factor(S: float, dx: float, slip_length: float,
                        theta_s_deg: float = 90.0) -> float:
    """f_cl of eq. (4) for wall spacing ``dx`` (Delta = dx / 2) and the plug-traction
    constant ``S`` (:func:`sphfem.fluid.wall_layer.plug_traction_constant`)."""
    if not S > 0.0:
        raise ValueError(f"plug-traction constant must be > 0, got {S!r}")
    return subgrid_friction(theta_s_deg, 0.5 * dx, slip_length) / S


@functools.lru_cache(maxsize=8)
def _secant_table(theta_s_deg: float):
    """(c_k, phi_k) of eq. (3') on theta_Delta from theta_s to pi - 1e-4 (c increasing)."""
    th_s = math.radians(theta_s_deg)
    g_s = wedge_function(th_s)
    th = th_s + (math.pi - 1e-4 - th_s) * np.linspace(0.0, 1.0, 401)[1:] ** 2
    c = np.empty(th.size + 1)
    phi = np.empty(th.size + 1)
    c[0], phi[0] = 0.0, math.sin(th_s) / wedge_slope(th_s)
    acc, prev = g_s, th_s
    for k, t in enumerate(th, start=1):
        acc += quad(lambda x: (x - math.sin(x) * math.cos(x)) / (2.0 * math.sin(x)), prev,
                    t)[0]
        prev = t
        c[k] = acc - g_s
        phi[k] = (math.cos(th_s) - math.cos(t)) / c[k]
    return c, phi


def secant_ratio(c, theta_s_deg: float = 90.0) -> np.ndarray:
    """phi(c) of eq. (3') for c = Ca ln(Delta / lambda) >= 0 (array or scalar); beyond the
    table (theta_Delta -> pi) the force saturates at sigma (cos theta_s + 1)."""
    ck, pk = _secant_table(float(theta_s_deg))
    c = np.abs(np.asarray(c, float))
    out = np.interp(c, ck, pk)
    far = c > ck[-1]
    if np.any(far):
        out = np.where(far, (math.cos(math.radians(theta_s_deg)) + 1.0)
                       / np.maximum(c, 1e-300), out)
    return out


def contact_line_factors(speed, S: float, dx: float, slip_length: float, mu: float,
                         sigma: float, theta_s_deg: float = 90.0) -> np.ndarray:
    """f_cl of eq. (4) per ring from its speed along the wall ``speed`` [m/s] (array): wall
    spacing ``dx`` (Delta = dx / 2), plug-traction constant ``S``
    (:func:`sphfem.fluid.wall_layer.plug_traction_constant`), slip length, viscosity and
    surface tension of the liquid."""
    if not sigma > 0.0:
        raise ValueError("the Cox-Voinov contact line needs surface tension (sigma > 0), got "
                         f"{sigma!r}")
    if not slip_length > 0.0:
        raise ValueError(f"contact_line_slip_length must be > 0, got {slip_length!r}")
    ln = max(0.0, math.log(0.5 * dx / slip_length))
    c = mu * np.abs(np.asarray(speed, float)) * ln / sigma
    return ln * secant_ratio(c, theta_s_deg) / S
