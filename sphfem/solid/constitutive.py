"""Thermo-elastic Saint Venant-Kirchhoff material with a multiplicative thermal split.

Park (2019) eqs. 2.118-2.125 (after Vujosevic & Lubarda 2002):

    F = F_e . F_theta,   F_theta = v I,   v = 1 + alpha (theta - theta0)        (2.118-2.119)
    E_e = (F_e^T F_e - I) / 2 = (C / v^2 - I) / 2,   C = F^T F                    (2.120)
    S_e = lam tr(E_e) I + 2 mu E_e                 (SVK in the intermediate configuration)
    S   = v S_e                                    (second Piola-Kirchhoff, eq. 2.122)

S = v S_e follows from a free energy per reference volume W = v^3 W_e(E_e): with
E_e = (C/v^2 - I)/2, S = 2 dW/dC = v^3 S_e / v^2.  Linearised in the strain and in
alpha (theta - theta0) it is eq. 2.125, S = lam tr(E) I + 2 mu E - (3 lam + 2 mu) alpha
(theta - theta0) I, i.e. the linear thermo-elasticity of the FEM substrate.  This module
implements the F_e-based (finite-strain) form above; lam, mu, alpha are constant in theta.

Two-dimensional bodies are in *plane strain*: F is embedded in 3x3 with F_33 = 1, so the
out-of-plane thermal strain is constrained (E_e,33 = (1/v^2 - 1)/2) and S_33 is the
out-of-plane stress that the Cauchy stress and von Mises output include.

First Piola-Kirchhoff P = F S (in-plane block), Cauchy sigma = F S F^T / J,
von Mises sqrt(3/2 s:s) with s the deviator of the 3x3 Cauchy stress.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sphfem.kernels import FASTMATH


@njit(cache=True, fastmath=FASTMATH)
def _pk2(F, i, dtheta, alpha, lam, mu, S3, C):
    """S (3x3) of particle i into S3 (C: 3x3 scratch)."""
    dim = F.shape[1]
    C[:, :] = 0.0
    for p in range(dim):
        for q in range(dim):
            s = 0.0
            for k in range(dim):
                s += F[i, k, p] * F[i, k, q]
            C[p, q] = s
    if dim == 2:
        C[2, 2] = 1.0
    v = 1.0 + alpha[i] * dtheta[i]
    iv2 = 1.0 / (v * v)
    tr = 0.0
    for p in range(3):
        tr += 0.5 * (C[p, p] * iv2 - 1.0)
    for p in range(3):
        for q in range(3):
            Ee = 0.5 * C[p, q] * iv2 - (0.5 if p == q else 0.0)
            S3[p, q] = v * (2.0 * mu[i] * Ee + (lam[i] * tr if p == q else 0.0))


@njit(cache=True, fastmath=FASTMATH)
def _pk1_2d(F, dtheta, alpha, lam, mu, S, P):
    """Scalar twin of :func:`pk1_stress` for plane strain (F_33 = 1, S_13 = S_23 = 0)."""
    for i in range(F.shape[0]):
        f00, f01, f10, f11 = F[i, 0, 0], F[i, 0, 1], F[i, 1, 0], F[i, 1, 1]
        v = 1.0 + alpha[i] * dtheta[i]
        iv2 = 1.0 / (v * v)
        e00 = 0.5 * ((f00 * f00 + f10 * f10) * iv2 - 1.0)
        e01 = 0.5 * (f00 * f01 + f10 * f11) * iv2
        e11 = 0.5 * ((f01 * f01 + f11 * f11) * iv2 - 1.0)
        e22 = 0.5 * (iv2 - 1.0)
        lt = lam[i] * (e00 + e11 + e22)
        m2 = 2.0 * mu[i]
        s00 = v * (lt + m2 * e00)
        s01 = v * m2 * e01
        s11 = v * (lt + m2 * e11)
        S[i, 0, 0] = s00
        S[i, 0, 1] = s01
        S[i, 1, 0] = s01
        S[i, 1, 1] = s11
        S[i, 2, 2] = v * (lt + m2 * e22)
        S[i, 0, 2] = S[i, 2, 0] = S[i, 1, 2] = S[i, 2, 1] = 0.0
        P[i, 0, 0] = f00 * s00 + f01 * s01
        P[i, 0, 1] = f00 * s01 + f01 * s11
        P[i, 1, 0] = f10 * s00 + f11 * s01
        P[i, 1, 1] = f10 * s01 + f11 * s11


@njit(cache=True, fastmath=FASTMATH)
def pk1_stress(F, dtheta, alpha, lam, mu, S, P):
    """S (n, 3, 3) second and P = F S (n, dim, dim) first Piola-Kirchhoff stresses."""
    n, dim = F.shape[0], F.shape[1]
    if dim == 2:
        _pk1_2d(F, dtheta, alpha, lam, mu, S, P)
        return
    S3 = np.empty((3, 3))
    C = np.empty((3, 3))
    for i in range(n):
        _pk2(F, i, dtheta, alpha, lam, mu, S3, C)
        for p in range(3):
            for q in range(3):
                S[i, p, q] = S3[p, q]
        for p in range(dim):
            for q in range(dim):
                s = 0.0
                for k in range(dim):
                    s += F[i, p, k] * S3[k, q]
                P[i, p, q] = s


@njit(cache=True, fastmath=FASTMATH)
def cauchy_stress(F, S):
    """sigma = F S F^T / J (n, 3, 3); 2D: F_33 = 1 (plane strain)."""
    n, dim = F.shape[0], F.shape[1]
    out = np.zeros((n, 3, 3))
    F3 = np.zeros((3, 3))
    for i in range(n):
        F3[:, :] = 0.0
        F3[2, 2] = 1.0
        for p in range(dim):
            for q in range(dim):
                F3[p, q] = F[i, p, q]
        J = (F3[0, 0] * (F3[1, 1] * F3[2, 2] - F3[1, 2] * F3[2, 1])
             - F3[0, 1] * (F3[1, 0] * F3[2, 2] - F3[1, 2] * F3[2, 0])
             + F3[0, 2] * (F3[1, 0] * F3[2, 1] - F3[1, 1] * F3[2, 0]))
        for p in range(3):
            for q in range(3):
                s = 0.0
                for a in range(3):
                    for b in range(3):
                        s += F3[p, a] * S[i, a, b] * F3[q, b]
                out[i, p, q] = s / J
    return out


@njit(cache=True, fastmath=FASTMATH)
def strain_energy(F, dtheta, alpha, lam, mu, vol):
    """Free energy sum_i V0_i v^3 (lam/2 tr(E_e)^2 + mu E_e:E_e) of the thermo-elastic SVK
    material (the potential of S = v S_e, see the module docstring); 2D: plane strain,
    per unit depth."""
    n, dim = F.shape[0], F.shape[1]
    total = 0.0
    E = np.zeros((3, 3))
    for i in range(n):
        v = 1.0 + alpha[i] * dtheta[i]
        iv2 = 1.0 / (v * v)
        E[:, :] = 0.0
        for p in range(dim):
            for q in range(dim):
                s = 0.0
                for k in range(dim):
                    s += F[i, k, p] * F[i, k, q]
                E[p, q] = 0.5 * s * iv2
        if dim == 2:
            E[2, 2] = 0.5 * iv2
        tr = 0.0
        ee = 0.0
        for p in range(3):
            E[p, p] -= 0.5
            tr += E[p, p]
        for p in range(3):
            for q in range(3):
                ee += E[p, q] * E[p, q]
        total += vol[i] * v * v * v * (0.5 * lam[i] * tr * tr + mu[i] * ee)
    return total


def von_mises(sigma: np.ndarray) -> np.ndarray:
    """von Mises stress of (n, 3, 3) stress tensors."""
    tr = np.trace(sigma, axis1=1, axis2=2)
    dev = sigma - tr[:, None, None] / 3.0 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))


def lame(E: float, nu: float) -> tuple[float, float]:
    """(lambda, mu) from Young's modulus and Poisson's ratio."""
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
