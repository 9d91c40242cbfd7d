"""Reference solution for the contact of a strained fluid layer with a solid: the impact
point of a droplet.

A fluid at T_f flows onto a solid at T_s (both uniform at t = 0) in a stagnation-point flow:
near the wall the fluid's normal velocity is w = -a(t) z, a the wall-parallel divergence of
the flow (axisymmetric stagnation flow u_r = A r: a = 2 A).  Along the stagnation line the
temperature obeys

    fluid (z > 0):  dT/dt - a(t) z dT/dz = alpha_f d2T/dz2,   T(z -> inf) = T_f,
    solid (z < 0):  dT/dt = alpha_s d2T/dz2,                    insulated far below,

with T and k dT/dz continuous at z = 0.  a = 0 is the contact of two semi-infinite bodies
(Carslaw & Jaeger 1959, sec. 2.15); a > 0 holds the fluid layer at a finite thickness, so
the interface warms above the static contact temperature and the heat flux stays higher.

:func:`strained_contact_fv` solves it by finite volumes on grids graded from the interface
(central convection, method of lines with scipy's Radau), independently of the SPH/FEM path
and of the similarity closure of :mod:`coupling.heat_interface` (eq. 6 there), which it
checks (tests/test_heat_interface_strained.py; the droplet-impact validation with the run's
own strain history at the impact point).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.integrate import solve_ivp

__all__ = ["strained_contact_fv"]


def _graded_faces(L: float, h0: float, growth: float) -> np.ndarray:
    f = [0.0]
    d = h0
    while f[-1] < L:
        f.append(f[-1] + d)
        d *= growth
    return np.array(f)


def strained_contact_fv(strain, t_out, T_f: float, T_s: float, fluid, solid,
                        L_f: float | None = None, L_s: float | None = None,
                        h0: float | None = None, growth: float = 1.03, rtol: float = 1e-8,
                        velocity=None):
    """The interface temperature [K] and the heat into the solid [J/m^2] at the times
    ``t_out`` (increasing, > 0) of the strained contact (module docstring).

    ``strain``: a [1/s], a number or a function of t (w = -a z); or ``velocity``, a
    function w(z, t) [m/s] of the fluid's normal velocity (e.g. the viscous stagnation
    layer of :mod:`sphfem.heat.stagnation_layer`), which replaces it; ``fluid``, ``solid``:
    (k, rho, c).
    The grids: fluid over [0, L_f] (default 12 sqrt(alpha_f t_end), with T = T_f at the top:
    inflow), solid over [-L_s, 0] (default 12 sqrt(alpha_s t_end)), first cells ``h0``
    (default 1e-3 sqrt(alpha_f t_end)) growing by ``growth``.  Accuracy: ~1e-5 of the rise
    with the defaults (a = 0 against the closed form: tests)."""
    t_out = np.asarray(t_out, float)
    kf, rf, cf = (float(v) for v in fluid)
    ks, rs, cs = (float(v) for v in solid)
    af, as_ = kf / (rf * cf), ks / (rs * cs)
    t_end = float(t_out[-1])
    L_f = 12.0 * math.sqrt(af * t_end) if L_f is None else float(L_f)
    L_s = 12.0 * math.sqrt(as_ * t_end) if L_s is None else float(L_s)
    h0 = 1e-3 * math.sqrt(af * t_end) if h0 is None else float(h0)
    a_of_t = strain if callable(strain) else (lambda t, _a=float(strain or 0.0): _a)
    ff, fs = _graded_faces(L_f, h0, growth), _graded_faces(L_s, h0, growth)
    zf, zs = 0.5 * (ff[1:] + ff[:-1]), -0.5 * (fs[1:] + fs[:-1])
    dzf, dzs = np.diff(ff), np.diff(fs)
    nf, ns = zf.size, zs.size
    g0 = 1.0 / (0.5 * dzf[0] / kf + 0.5 * dzs[0] / ks)  # interface conductance, half cells
    zup = np.concatenate([zf[1:], [ff[-1]]])
    zdn = np.concatenate([[zf[0]], zf[:-1]])

    def rhs(t, y):
        Tf, Ts = y[:nf], y[nf:]
        q0 = g0 * (Tf[0] - Ts[0])  # into the solid
        gf = np.empty(nf)          # k dT/dz at the fluid cells' upper faces
        gf[:-1] = kf * (Tf[1:] - Tf[:-1]) / (zf[1:] - zf[:-1])
        gf[-1] = kf * (T_f - Tf[-1]) / (ff[-1] - zf[-1])
        dTf = np.diff(np.concatenate([[q0], gf])) / (rf * cf * dzf)
        Tup = np.concatenate([Tf[1:], [T_f]])
        Tdn = np.concatenate([[Tf[0]], Tf[:-1]])  # first cell: one-sided upward difference
        w = velocity(zf, t) if velocity is not None else -a_of_t(t) * zf
        dTf -= w * (Tup - Tdn) / (zup - zdn)
        gs = np.empty(ns)          # conductive flux downward at the solid cells' lower faces
        gs[:-1] = ks * (Ts[:-1] - Ts[1:]) / (zs[:-1] - zs[1:])
        gs[-1] = 0.0
        dTs = (np.concatenate([[q0], gs[:-1]]) - gs) / (rs * cs * dzs)
        return np.concatenate([dTf, dTs])

    n = nf + ns
    band = sp.diags([np.ones(n - 1), np.ones(n), np.ones(n - 1)], [-1, 0, 1], format="lil")
    band[nf - 1, nf] = band[nf, nf - 1] = 0.0   # the two grids meet only at cells 0 / nf
    band[0, nf] = band[nf, 0] = 1.0
    y0 = np.concatenate([np.full(nf, float(T_f)), np.full(ns, float(T_s))])
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="Radau", t_eval=t_out, rtol=rtol,
                    atol=1e-10 * abs(T_f - T_s), jac_sparsity=band.tocsc())
    if not sol.success:
        raise RuntimeError(f"strained_contact_fv: {sol.message}")
    gf0, gs0 = kf / (0.5 * dzf[0]), ks / (0.5 * dzs[0])
    Ti = (gf0 * sol.y[0] + gs0 * sol.y[nf]) / (gf0 + gs0)
    Q = rs * cs * (sol.y[nf:] - T_s).T @ dzs
    return Ti, Q
