"""Registry of the fluid's rheology (``[fluid] rheology``): the per-particle apparent viscosity.

A generalised Newtonian fluid has the deviatoric stress tau = 2 mu(gamma_dot) D with the
strain-rate tensor and its magnitude (Park 2019 eq. 2.149; the thesis' sec. 2.6.7)

    D_i = (L_i + L_i^T) / 2,   gamma_dot_i = sqrt(2 D_i : D_i),
    L_i = (grad u)_i = sum_j V_j (u_j - u_i) (x) (B_i grad_i W_ij),
    B_i = [sum_j V_j grad_i W_ij (x) r_ij]^-1        (renormalised gradient, eq. 2.5-2.6)

(simple shear u = (G y, 0) gives gamma_dot = |G|).  Every fluid evaluation
(:meth:`sphfem.fluid.wcsph.FluidSolver.evaluate`, before the viscous term) writes gamma_dot
to the field ``gamma_dot`` and the apparent viscosity to the field ``mu``, which the chosen
``[fluid] viscosity`` model then uses (and the viscous step limit visc_cfl h^2 min(rho/mu)).

Herschel & Bulkley (1926): |tau| = tau0 + k gamma_dot^n where the fluid yields, rigid
where |tau| <= tau0; apparent viscosity mu = k gamma_dot^(n-1) + tau0 / gamma_dot, which is
unbounded as gamma_dot -> 0 and is regularised below the shear rate gamma_dot_0:

* ``cutoff`` (Tanner & Milthorpe 1983; Park 2019 eq. 2.112 / 2.148 with the erratum of
  DESIGN.md, exponent n - 1): mu = k gd0^(n-1) + tau0 / gd0 for gamma_dot < gd0, continuous
  at gd0;
* ``papanastasiou`` (Papanastasiou 1987, J. Rheol. 31, 385, with m = 1/gd0):
  mu = k max(gamma_dot, gd0)^(n-1) + tau0 (1 - exp(-gamma_dot / gd0)) / gamma_dot (tends to
  k gd0^(n-1) + tau0 / gd0 at rest; the power-law part is held at gd0 below it, as in the
  cut-off, so that n < 1 stays bounded).

Both are bounded by mu_max = k gd0^(n-1) + tau0 / gd0 (n <= 1), which sets the explicit
viscous step.  Power law (Ostwald 1925, de Waele 1923: tau0 = 0) and Bingham (1922: n = 1,
k the plastic viscosity) are the special cases, each a method module; ``newtonian`` keeps the
material's mu.  The moment matrix of B sums over fluid neighbours only (one-sided at walls,
still exact for linear velocity fields); where it is singular (free surface, isolated
particles) the plain gradient is used and counted (``fallbacks``).  One fluid rheology per
scene (all fluid materials share it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from sphfem.fluid.passes import grad_factor
from sphfem.kernels import FASTMATH
from sphfem.methods import MethodRegistry
from sphfem.particles import FLUID, WALL
from sphfem.schema import Param
from sphfem.smallmat import invert_sym3, pair_sep

#: the rheology modules (one line each; "newtonian" is registered below)
METHOD_MODULES = (
    "sphfem.fluid.rheology_herschel_bulkley1926",
    "sphfem.fluid.rheology_power_law_ostwald1925",
    "sphfem.fluid.rheology_bingham1922",
)
#: the non-Newtonian choices
YIELD = ("herschel-bulkley", "bingham")
SHEAR = ("herschel-bulkley", "power-law", "bingham")
#: the per-particle field the rheology adds (besides the fluid's ``mu``)
FIELDS = {"gamma_dot": 1}
#: condition number beyond which B_i falls back to the identity
COND_MAX = 1e8

#: the rheology keys shared by the non-Newtonian methods (each with its ``when=``)
PARAMS = (
    Param("tau0", float, None, unit="Pa", ge=0.0, when=("rheology", YIELD),
          doc="yield stress tau0 (required when it applies)"),
    Param("k", float, None, positive=True, when=("rheology", SHEAR),
          doc="consistency k [Pa s^n] (Bingham: the plastic viscosity [Pa s]); required"),
    Param("n", float, None, positive=True, when=("rheology", ("herschel-bulkley",
                                                                   "power-law")),
          doc="flow index n (< 1 shear-thinning, 1 Bingham / Newtonian, > 1 thickening); required"),
    Param("regularisation", str, "cutoff", choices=("cutoff", "papanastasiou"),
          when=("rheology", SHEAR),
          doc="below gamma_dot_0: cutoff = the viscosity is held at its value at "
              "gamma_dot_0 (Tanner & Milthorpe 1983, Park 2019 eq. 2.148 corrected); "
              "papanastasiou = tau0 (1 - exp(-gamma_dot/gamma_dot_0))/gamma_dot "
              "(Papanastasiou 1987, m = 1/gamma_dot_0)"),
    Param("gamma_dot_0", float, None, unit="1/s", positive=True,
          when=("rheology", SHEAR),
          doc="regularisation shear rate gd0: the largest viscosity is k gd0^(n-1) + "
              "tau0/gd0 (n <= 1), which sets the explicit viscous step; choose it well "
              "below the flow's shear rates (the plug then shears at <= gd0); required"),
)


#: the keys each non-Newtonian rheology needs (no defaults: they set the physics)
NEEDS = {"herschel-bulkley": ("tau0", "k", "n", "gamma_dot_0"),
         "power-law": ("k", "n", "gamma_dot_0"), "bingham": ("tau0", "k", "gamma_dot_0")}


def missing_keys(params) -> tuple[str, ...]:
    """The keys ``params.rheology`` needs that are unset (a scene record or FluidParams)."""
    return tuple(k for k in NEEDS.get(params.rheology, ())
                 if getattr(params, k, None) is None)


@dataclass(frozen=True)
class RheologyMethod:
    """One rheology.

    name          the value of ``[fluid] rheology``
    doc           its description in the key's documentation
    params        its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    coefficients  ``params -> (tau0, k, n)`` of its Herschel-Bulkley form (None: Newtonian,
                  the material's mu is kept)
    """

    name: str
    doc: str
    params: tuple
    coefficients: Callable | None = None


class _Registry(MethodRegistry):
    def scene_params(self) -> tuple:
        return PARAMS + super().scene_params()


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] rheology``
REGISTRY = _Registry("rheology", METHOD_MODULES)
register = REGISTRY.register
lookup = REGISTRY.lookup

NEWTONIAN = register(RheologyMethod(
    name="newtonian", doc="constant viscosity: each fluid particle's material mu",
    params=()))


# ----------------------------------------------------------------------------- formulae


@njit(cache=True, inline="always")
def hb_viscosity(gd, tau0, k, n, gd0, papanastasiou):
    """Regularised Herschel-Bulkley apparent viscosity mu(gd) [Pa s] (module docstring)."""
    g = gd if gd > gd0 else gd0
    mu = k * g ** (n - 1.0)
    if tau0 == 0.0:
        return mu
    if not papanastasiou:
        return mu + tau0 / g
    x = gd / gd0
    if x < 1e-8:  # (1 - e^-x)/gd -> (1 - x/2)/gd0
        return mu + tau0 * (1.0 - 0.5 * x) / gd0
    return mu + tau0 * -math.expm1(-x) / gd


@njit(cache=True, parallel=True)
def apparent_viscosity(gd, kind, tau0, k, n, gd0, papanastasiou, mu):
    """mu[i] = :func:`hb_viscosity` (gd[i]) on the fluid particles (other rows untouched)."""
    for i in prange(gd.shape[0]):
        if kind[i] == FLUID:
            mu[i] = hb_viscosity(gd[i], tau0, k, n, gd0, papanastasiou)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def strain_rate(x, u, V, kind, offsets, indices, R, sigma, kernel_code, period, cond_max,
                gd, ok, walls=False):
    """gd[i] = sqrt(2 D_i : D_i) of fluid particle i from the renormalised velocity gradient
    over its fluid neighbours and, with ``walls``, its wall neighbours (module docstring);
    ``u``: the velocities (walls: the wall model's ghost velocity); ok[i] False where B_i
    fell back to I.  Other rows get 0."""
    n, dim = x.shape
    R2 = R * R
    fac2 = sigma / R2
    periodic = False
    for c in range(dim):
        periodic |= period[c] > 0.0
    for i in prange(n):
        gd[i] = 0.0
        ok[i] = True
        if kind[i] != FLUID:
            continue
        m00 = m01 = m02 = m11 = m12 = m22 = 0.0
        # g_ab = sum_j V_j F (u_j - u_i)_a r_b
        g00 = g01 = g02 = g10 = g11 = g12 = g20 = g21 = g22 = 0.0
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if kind[j] != FLUID and not (walls and kind[j] == WALL):
                continue
            r0, r1, r2 = pair_sep(x, i, j, dim, period, periodic)
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 >= R2 or d2 == 0.0:
                continue
            w = V[j] * grad_factor(math.sqrt(d2), R, fac2, kernel_code)
            m00 += w * r0 * r0
            m01 += w * r0 * r1
            m02 += w * r0 * r2
            m11 += w * r1 * r1
            m12 += w * r1 * r2
            m22 += w * r2 * r2
            du0 = w * (u[j, 0] - u[i, 0])
            du1 = w * (u[j, 1] - u[i, 1]) if dim > 1 else 0.0
            du2 = w * (u[j, 2] - u[i, 2]) if dim > 2 else 0.0
            g00 += du0 * r0
            g01 += du0 * r1
            g02 += du0 * r2
            g10 += du1 * r0
            g11 += du1 * r1
            g12 += du1 * r2
            g20 += du2 * r0
            g21 += du2 * r1
            g22 += du2 * r2
        good, b00, b01, b02, b10, b11, b12, b20, b21, b22 = invert_sym3(
            m00, m01, m02, m11, m12, m22, dim, cond_max)
        if not good:  # the plain gradient
            ok[i] = False
            b00, b01, b02, b10, b11, b12, b20, b21, b22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, \
                0.0, 1.0
        # L = g B (B symmetric); 2 D:D = sum_ab (L_ab + L_ba)^2 / 2
        l00 = g00 * b00 + g01 * b10 + g02 * b20
        l01 = g00 * b01 + g01 * b11 + g02 * b21
        l02 = g00 * b02 + g01 * b12 + g02 * b22
        l10 = g10 * b00 + g11 * b10 + g12 * b20
        l11 = g10 * b01 + g11 * b11 + g12 * b21
        l12 = g10 * b02 + g11 * b12 + g12 * b22
        l20 = g20 * b00 + g21 * b10 + g22 * b20
        l21 = g20 * b01 + g21 * b11 + g22 * b21
        l22 = g20 * b02 + g21 * b12 + g22 * b22
        s01 = l01 + l10
        s02 = l02 + l20
        s12 = l12 + l21
        gd[i] = math.sqrt(2.0 * (l00 * l00 + l11 * l11 + l22 * l22)
                          + s01 * s01 + s02 * s02 + s12 * s12)


# ----------------------------------------------------------------------------- the hook


def update_viscosity(solver) -> int:
    """Strain rate and apparent viscosity of ``solver``'s fluid particles at its current
    positions and velocities (``FluidSolver.evaluate``); returns the number of B_i
    fallbacks.  Newtonian: nothing to do (0)."""
    method = solver.rheology
    if method.coefficients is None:
        return 0
    missing = missing_keys(solver.params)
    if missing:
        raise ValueError(f"rheology = {method.name!r} needs {', '.join(missing)}")
    tau0, k, n = method.coefficients(solver.params)
    gd0 = solver.params.gamma_dot_0
    p, s, nl = solver.p, solver._scratch, solver.nbrs
    if not hasattr(p, "gamma_dot"):
        p.add_field("gamma_dot", 1)
    ok = getattr(solver, "_rheology_ok", None)
    if ok is None or ok.shape[0] != p.n:
        ok = solver._rheology_ok = np.ones(p.n, dtype=np.bool_)
    strain_rate(p.x, s.vg, s.V, p.kind, nl.offsets, nl.indices, solver.R, solver.sigma,
                solver.kernel_code, solver.period, COND_MAX, p.gamma_dot, ok, True)
    apparent_viscosity(p.gamma_dot, p.kind, float(tau0), float(k), float(n), float(gd0),
                       solver.params.regularisation == "papanastasiou", p.mu)
    solver.rheology_fallbacks = int(p.n - np.count_nonzero(ok))  # of the last evaluation
    return solver.rheology_fallbacks


def max_viscosity(params) -> float | None:
    """The largest apparent viscosity of ``params``' rheology [Pa s] (None: Newtonian):
    k gd0^(n-1) + tau0/gd0 for n <= 1 (for n > 1 the viscosity grows without bound with
    gamma_dot)."""
    method = lookup(params.rheology)
    if method.coefficients is None:
        return None
    tau0, k, n = method.coefficients(params)
    gd0 = params.gamma_dot_0
    return k * gd0 ** (n - 1.0) + tau0 / gd0 if n <= 1.0 else math.inf
