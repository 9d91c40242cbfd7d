"""Weak forms of linear thermo-elasticity, as factories returning scikit-fem forms.

Constitutive law (thesis eqs. 2.79-2.81; plane strain in 2D)::

    sigma = lam tr(eps) I + 2 G eps - (3 lam + 2 G) alpha dT I

The thermal part moves to the right-hand side: ``int (3 lam + 2 G) alpha dT div(v)``.
Every factory binds its constants in a closure and returns a pure ``(v, w)`` form, as
``skfem.models.elasticity`` does.  Fields the forms read at quadrature points are passed
as keyword arguments of ``.assemble(basis, name=...)`` (``w.dT``, ``w.t``, ``w.f``).
"""

from __future__ import annotations

import numpy as np
from skfem import BilinearForm, LinearForm
from skfem.helpers import ddot, div, dot, eye, trace
from skfem.models.elasticity import lame_parameters, linear_elasticity, linear_stress

__all__ = [
    "lame_parameters",
    "elasticity",
    "linear_elasticity",
    "linear_stress",
    "thermal_modulus",
    "thermal_load",
    "traction_load",
    "body_force_load",
    "thermo_elastic_stress",
    "von_mises",
    "mass",
]


def elasticity(lam: float, mu: float) -> BilinearForm:
    """Stiffness ``int lam div(u) div(v) + 2 mu eps(u) : eps(v) dx``.

    The same bilinear form as ``skfem.models.elasticity.linear_elasticity`` written without
    building the stress tensor (no identity-tensor temporaries): about 3x faster to
    assemble.
    """

    @BilinearForm
    def form(u, v, w):
        gu, gv = u.grad, v.grad
        eu = 0.5 * (gu + np.swapaxes(gu, 0, 1))
        ev = 0.5 * (gv + np.swapaxes(gv, 0, 1))
        return lam * trace(gu) * trace(gv) + 2.0 * mu * np.einsum("ij...,ij...->...", eu, ev)

    return form


def thermal_modulus(lam: float, mu: float) -> float:
    """(3 lam + 2 mu) = E / (1 - 2 nu): the stress per unit thermal strain."""
    return 3.0 * lam + 2.0 * mu


def thermal_load(lam: float, mu: float, alpha: float) -> LinearForm:
    """``int (3 lam + 2 mu) alpha dT div(v) dx`` with ``dT`` given at quadrature points
    (``.assemble(basis, dT=...)``: a DiscreteField or an array (nelems, nqp))."""
    beta = thermal_modulus(lam, mu) * alpha

    @LinearForm
    def form(v, w):
        return beta * w.dT * div(v)

    return form


def traction_load(traction=None) -> LinearForm:
    """``int t . v ds`` on a FacetBasis.

    ``traction`` is a constant vector, a callable ``t(x) -> (dim, ...)`` of the quadrature
    point coordinates, or None, in which case ``w.t`` (an array (dim, nfacets, nqp)) must be
    passed to ``assemble``.
    """
    if traction is None:

        @LinearForm
        def form(v, w):
            return dot(w.t, v)

    elif callable(traction):

        @LinearForm
        def form(v, w):
            return dot(np.asarray(traction(w.x)) + 0.0 * w.x, v)

    else:
        tvec = np.asarray(traction, float)

        @LinearForm
        def form(v, w):
            t = tvec.reshape((-1,) + (1,) * (w.x.ndim - 1)) + 0.0 * w.x
            return dot(t, v)

    return form


def body_force_load(force) -> LinearForm:
    """``int f . v dx`` with ``f`` a constant vector or a callable ``f(x) -> (dim, ...)``."""
    if callable(force):

        @LinearForm
        def form(v, w):
            return dot(np.asarray(force(w.x)) + 0.0 * w.x, v)

    else:
        fvec = np.asarray(force, float)

        @LinearForm
        def form(v, w):
            return dot(fvec.reshape((-1,) + (1,) * (w.x.ndim - 1)) + 0.0 * w.x, v)

    return form


@BilinearForm
def mass(u, v, w):
    """Scalar mass matrix (for the L2 projection of stresses to nodes)."""
    return u * v


def thermo_elastic_stress(lam: float, mu: float, alpha: float, grad_u, dT, plane_strain=None):
    """Cauchy stress (3, 3, ...) from the displacement gradient (dim, dim, ...) and dT (...).

    In 2D (plane strain, eps_zz = 0) the out-of-plane component is
    ``sigma_zz = lam tr(eps) - (3 lam + 2 mu) alpha dT``.
    """
    grad_u = np.asarray(grad_u)
    dim = grad_u.shape[0]
    eps = sym_grad_array(grad_u)
    beta = thermal_modulus(lam, mu) * alpha
    tr = trace(eps)
    iso = lam * tr - beta * np.asarray(dT)
    s2 = 2.0 * mu * eps
    for i in range(dim):  # + iso I, without an identity-tensor temporary
        s2[i, i] += iso
    if dim == 3:
        return s2
    out = np.zeros((3, 3) + s2.shape[2:])
    out[:2, :2] = s2
    out[2, 2] = iso
    return out


def sym_grad_array(grad_u: np.ndarray) -> np.ndarray:
    """Symmetric part of a gradient array (dim, dim, ...)."""
    return 0.5 * (grad_u + np.swapaxes(grad_u, 0, 1))


def von_mises(S: np.ndarray) -> np.ndarray:
    """von Mises stress of 3x3 stress tensors stacked in the leading axes (3, 3, ...)."""
    S = np.asarray(S)
    dev = S - eye(trace(S) / 3.0, 3)
    return np.sqrt(1.5 * ddot(dev, dev))

