"""SPH smoothing kernels W(r, R) and their radial derivatives, normalised in 1D, 2D and 3D.

Every kernel here is written in terms of its *support radius* ``R`` (W = 0 for r >= R) and
the normalised distance ``q = r / R`` in [0, 1].  This avoids the h-versus-2h ambiguity of
the literature: the thesis' "h = 3 dx" is the support radius, i.e. ``R = 3 dx``.

Kernels (selected by name in the scene, by the integer code below inside numba kernels):

``wendland_c2``  Wendland (1995) C2 function, the "quintic Wendland" of Dehnen & Aly (2012):
                 f(q) = (1 - q)^4 (1 + 4 q); sigma = 3/(2R), 7/(pi R^2), 21/(2 pi R^3).
``cubic_spline`` Monaghan & Lattanzio (1985) M4 B-spline with h = R/2, s = 2q:
                 f = 1 - 1.5 s^2 + 0.75 s^3 (s < 1), 0.25 (2 - s)^3 (1 <= s < 2);
                 sigma = 2/(3h), 10/(7 pi h^2), 1/(pi h^3).

W(r) = sigma_d(R) f(r/R) and dW/dr = sigma_d(R) f'(r/R) / R; the gradient with respect to
x_i of W(|x_i - x_j|) is dW/dr * (x_i - x_j) / r.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: LLVM fast-math flags of every numba kernel of sphfem (reassociation, contraction,
#: approximate reciprocal and functions; no ``nnan``/``ninf``: NaN checks stay valid)
FASTMATH = {"reassoc", "contract", "arcp", "afn"}

WENDLAND_C2 = 0
CUBIC_SPLINE = 1

KERNELS = {"wendland_c2": WENDLAND_C2, "cubic_spline": CUBIC_SPLINE}


def kernel_code(name: str) -> int:
    """Integer code of the kernel called ``name`` (``wendland_c2`` or ``cubic_spline``)."""
    try:
        return KERNELS[name]
    except KeyError:
        raise ValueError(f"unknown kernel {name!r}; expected one of {sorted(KERNELS)}") from None


def kernel_sigma(kind: int, dim: int, R: float) -> float:
    """Normalisation constant sigma_d(R) so that the d-dimensional integral of W is 1."""
    if dim not in (1, 2, 3):
        raise ValueError(f"dimension must be 1, 2 or 3, got {dim}")
    if not R > 0:
        raise ValueError(f"support radius must be positive, got {R}")
    if kind == WENDLAND_C2:
        c = (1.5, 7.0 / math.pi, 21.0 / (2.0 * math.pi))[dim - 1]
        return c / R**dim
    if kind == CUBIC_SPLINE:
        h = 0.5 * R
        c = (2.0 / 3.0, 10.0 / (7.0 * math.pi), 1.0 / math.pi)[dim - 1]
        return c / h**dim
    raise ValueError(f"unknown kernel code {kind}")


@njit(cache=True, inline="always")
def kernel_f(q, kind):
    """Un-normalised shape f(q), q = r/R in [0, 1]; zero outside."""
    if q >= 1.0:
        return 0.0
    if kind == WENDLAND_C2:
        a = 1.0 - q
        a2 = a * a
        return a2 * a2 * (1.0 + 4.0 * q)
    s = 2.0 * q
    if s < 1.0:
        return 1.0 - 1.5 * s * s + 0.75 * s * s * s
    b = 2.0 - s
    return 0.25 * b * b * b


@njit(cache=True, inline="always")
def kernel_dfdq(q, kind):
    """Derivative f'(q) of the un-normalised shape; zero outside the support."""
    if q >= 1.0:
        return 0.0
    if kind == WENDLAND_C2:
        a = 1.0 - q
        return -20.0 * q * a * a * a
    s = 2.0 * q
    if s < 1.0:
        return 2.0 * (-3.0 * s + 2.25 * s * s)
    b = 2.0 - s
    return 2.0 * (-0.75 * b * b)


@njit(cache=True)
def kernel_w(r, R, sigma, kind):
    """W(r) for support radius R and normalisation ``sigma = kernel_sigma(kind, dim, R)``."""
    return sigma * kernel_f(r / R, kind)


@njit(cache=True)
def kernel_dwdr(r, R, sigma, kind):
    """dW/dr for support radius R (non-positive)."""
    return sigma * kernel_dfdq(r / R, kind) / R


def w(r, R, dim, name="wendland_c2"):
    """Vectorised W(r) (numpy), for tests and plotting."""
    kind = kernel_code(name)
    sigma = kernel_sigma(kind, dim, R)
    r = np.asarray(r, dtype=float)
    return np.vectorize(lambda s: kernel_w(s, R, sigma, kind))(r)


def grad_w(dx, R, name="wendland_c2"):
    """Vectorised grad_i W(|dx|) for separation vectors ``dx = x_i - x_j`` of shape (n, dim)."""
    kind = kernel_code(name)
    dx = np.atleast_2d(np.asarray(dx, dtype=float))
    dim = dx.shape[1]
    sigma = kernel_sigma(kind, dim, R)
    r = np.linalg.norm(dx, axis=1)
    dwdr = np.array([kernel_dwdr(s, R, sigma, kind) for s in r])
    out = np.zeros_like(dx)
    nz = r > 0
    out[nz] = (dwdr[nz] / r[nz])[:, None] * dx[nz]
    return out
