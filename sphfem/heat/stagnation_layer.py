"""The fluid's thermal layer under a viscous stagnation-point flow, for the contact closure
(:mod:`coupling.heat_interface`, ``layer = "strained-viscous"``).

Near a no-slip wall the flow that stretches the thermal layer is itself slowed: in the
stagnation-point boundary layer (Hiemenz 1911, planar; Homann 1936, axisymmetric)

    u_par = A x f'(eta),  w = -c sqrt(A nu) f(eta),  eta = z / delta,  delta = sqrt(nu / A),
    f''' + c f f'' + 1 - f'^2 = 0,  f(0) = f'(0) = 0,  f'(inf) = 1,                          (1)

c = 1 planar, c = 2 axisymmetric (f''(0) = 1.2326 and 1.3119).  The wall-parallel divergence
of the outer flow is a_o = c A, and w = -a_o delta f(z / delta).

Energy integral.  With the erf profile of the closure, theta = erfc(z / 2s), integrated
over the layer, dT/dt + w dT/dz = alpha T_zz gives

    d(s^2)/dt = alpha - a_o delta^2 J(s / delta) = alpha - c nu J(s / delta),
    J(sigma) = int_0^inf f(zeta) exp(-zeta^2 / (4 sigma^2)) dzeta,                           (2)

exact for a linear w (J = 2 sigma^2: eq. 6 of the interface, d(s^2)/dt = alpha - 2 a_o s^2),
and J -> sqrt(pi) f''(0) sigma^3 for a layer deep inside the viscous one (w ~ z^2).  Inside
the viscous layer the erf is not the steady profile: (2)'s steady flux k dT / (sqrt(pi) s)
overshoots the exact similarity solution (theta'' + Pr c f theta' = 0, Nu = theta'(0) =
1 / int_0^inf exp(-Pr c int_0^eta f) d eta) by 5.2 / 6.6 / 8.0 % at Pr = 0.7 / 2 / 7
(planar; axisymmetric 6.0 / 7.4 / 8.7 %).  The closure therefore uses

    d(s^2)/dt = alpha (1 - J(s / delta) / J*),   J* = J(sigma*),  sigma* = 1 / (sqrt(pi) Nu),  (2')

which keeps both exact limits of (2): pure conduction while J(s / delta) << J* (the layer
thin against its steady value: the first instants, and any a_o -> 0) and the exact steady
layer of (1) (the profile-shape error of the energy integral removed where it is largest).

The strain the particles show.  The SPH wall cell (height h) moves with the cell mean of
the tangential flow, so the divergence fitted from the wall layer's velocities is

    a_1 = a_o F(h / delta),  F(x) = f(x) / x                                                  (3)

(-> a_o for h >> delta, -> a_o f''(0) h / (2 delta) for h << delta); with delta =
sqrt(c nu / a_o) this is lambda f(lambda) = a_1 h^2 / (c nu), lambda = h / delta, solved for
a_o by table inversion (lambda f(lambda) increases monotonically).  So the outer strain
and the viscous layer come from the run's own flow at any spacing, and (2) gives the layer.
Where a_1 <= 0 (a converging or lifting flow: no stagnation structure) the linear strain
a = a_1 is used.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["integrate_layer", "layer_J", "outer_strain", "stagnation_profile",
           "stagnation_velocity", "steady_nusselt", "viscous_layer_rate"]

_ETA_MAX = 12.0


def _table_key(c: int) -> dict:
    """What the on-disk tables of flow ``c`` depend on (the recipe and the library
    versions that computed them)."""
    import scipy

    return {"c": int(c), "eta_max": _ETA_MAX, "recipe": 1, "numpy": np.__version__,
            "scipy": scipy.__version__}


@functools.lru_cache(maxsize=4)
def stagnation_profile(c: int):
    """(eta, f, f'') on [0, 12] of eq. (1) (c = 1 Hiemenz, c = 2 Homann), by scipy's
    solve_bvp to 1e-10; beyond eta = 12, f = eta - beta (beta = eta - f there).  Kept on
    disk (:func:`sphfem.cache.cached_array`, key: c and the numpy / scipy versions): the
    solve takes ~0.8 CPU-s, the first coupling step of every strained-viscous run."""
    from sphfem.cache import cached_array

    table = cached_array("stagnation_profile", _table_key(c),
                         lambda: np.stack(_solve_profile(c)))
    return table[0], table[1], table[2]


def _solve_profile(c: int):
    from scipy.integrate import solve_bvp

    def fun(x, y):
        return np.vstack([y[1], y[2], -c * y[0] * y[2] - 1.0 + y[1] ** 2])

    def bc(ya, yb):
        return np.array([ya[0], ya[1], yb[1] - 1.0])

    x = np.linspace(0.0, _ETA_MAX, 600)
    y = np.vstack([np.log(np.cosh(x)), np.tanh(x), 1.0 / np.cosh(x) ** 2])
    sol = solve_bvp(fun, bc, x, y, tol=1e-10, max_nodes=200000)
    if sol.status != 0:
        raise RuntimeError(f"stagnation_profile: solve_bvp failed: {sol.message}")
    eta = np.linspace(0.0, _ETA_MAX, 12001)
    Y = sol.sol(eta)
    return eta, Y[0], Y[2]


def stagnation_velocity(z, a_o: float, delta: float, c: int):
    """The wall-normal velocity w = -a_o delta f(z / delta) of eq. (1) at heights ``z``
    (f = eta - beta beyond the table's eta = 12)."""
    eta, f, _ = stagnation_profile(c)
    beta = float(eta[-1] - f[-1])
    zeta = np.asarray(z, float) / delta
    return -a_o * delta * np.where(zeta < eta[-1], np.interp(zeta, eta, f), zeta - beta)


@functools.lru_cache(maxsize=4)
def _tables(c: int):
    eta, f, _ = stagnation_profile(c)
    beta = float(eta[-1] - f[-1])
    # J(sigma) on a log grid: quadrature on the table, then the tail f = eta - beta exactly
    # (kept on disk as the profile: 0.4 CPU-s)
    from sphfem.cache import cached_array

    sig = np.logspace(-4, 4, 801)
    J = cached_array("stagnation_J", _table_key(c), lambda: _J_table(eta, f, beta, sig))
    # lambda f(lambda) for the inversion of eq. (3)
    lam = eta[1:]
    P = lam * f[1:]
    ext = np.logspace(math.log10(eta[-1]) + 1e-4, 8.0, 400)  # beyond: f = eta - beta
    lam = np.concatenate([lam, ext])
    P = np.concatenate([P, ext * (ext - beta)])
    return sig, J, lam, P, beta


def _J_table(eta, f, beta: float, sig):
    from scipy.special import erfc

    J = np.empty_like(sig)
    E = eta[-1]
    for i, s in enumerate(sig):
        g = np.exp(-eta ** 2 / (4.0 * s * s))
        head = np.trapezoid(f * g, eta)
        # int_E^inf (z - beta) exp(-z^2 / 4s^2) dz
        tail = 2.0 * s * s * math.exp(-E * E / (4 * s * s)) - beta * s * math.sqrt(math.pi) \
            * erfc(E / (2 * s))
        J[i] = head + tail
    return J


def layer_J(sigma, c: int):
    """J(sigma) of eq. (2), elementwise (log-log table, uniform in log sigma, between 1e-4
    and 1e4; the asymptotes sqrt(pi) f''(0) sigma^3 and 2 sigma^2 - sqrt(pi) beta sigma
    beyond)."""
    sig, J, _, _, beta = _tables(c)
    logJ = _log_table(c)
    s = np.asarray(sigma, float)
    u = (np.log(np.maximum(s, 1e-300)) - math.log(sig[0])) * ((sig.size - 1)
                                                               / math.log(sig[-1] / sig[0]))
    i = np.clip(u.astype(np.int64), 0, sig.size - 2)
    w = u - i
    out = np.exp(logJ[i] * (1.0 - w) + logJ[i + 1] * w)
    below, above = u < 0.0, u > sig.size - 1
    if below.any() or above.any():
        fpp0 = stagnation_profile(c)[2][0]
        out = np.where(below, math.sqrt(math.pi) * fpp0 * s ** 3, out)
        out = np.where(above, 2.0 * s * s - math.sqrt(math.pi) * beta * s, out)
    return out


@functools.lru_cache(maxsize=4)
def _log_table(c: int):
    return np.log(_tables(c)[1])


def outer_strain(a1, h, nu: float, c: int):
    """(a_o, delta): the outer strain and the viscous length of eq. (3) from the strain
    ``a1`` that the wall cells of height ``h`` show; a1 <= 0 gives (a1, inf)."""
    _, _, lam, P, _ = _tables(c)
    a1 = np.asarray(a1, float)
    h = np.broadcast_to(np.asarray(h, float), a1.shape)
    target = np.maximum(a1, 0.0) * h * h / (c * nu)
    lam_k = np.exp(np.interp(np.log(np.maximum(target, 1e-300)), np.log(P), np.log(lam)))
    pos = a1 > 0.0
    a_o = np.where(pos, c * nu * lam_k ** 2 / np.where(pos, h * h, 1.0), a1)
    delta = np.where(pos, h / np.maximum(lam_k, 1e-300), np.inf)
    return a_o, delta


@functools.lru_cache(maxsize=64)
def steady_nusselt(prandtl: float, c: int) -> float:
    """Nu = theta'(0) of the exact steady similarity layer on (1): 1 / int_0^inf
    exp(-Pr c int_0^eta f) d eta (the tail beyond eta = 12 with f = eta - beta)."""
    from scipy.special import erfc

    eta, f, _ = stagnation_profile(c)
    # the cumulative trapezoid rule, as scipy.integrate.cumulative_trapezoid(f, eta,
    # initial=0) (importing scipy.integrate costs ~0.5 CPU-s once the profile is on disk)
    F = np.concatenate([[0.0], np.cumsum(np.diff(eta) * (f[1:] + f[:-1]) / 2.0)])
    head = np.trapezoid(np.exp(-prandtl * c * F), eta)
    beta = float(eta[-1] - f[-1])
    k = prandtl * c
    E = eta[-1]
    # int_E^inf exp(-k (F_E + (z - beta)^2 / 2 - (E - beta)^2 / 2)) dz
    tail = (math.exp(-k * (F[-1] - 0.5 * (E - beta) ** 2)) * math.sqrt(math.pi / (2 * k))
            * erfc(math.sqrt(k / 2) * (E - beta)))
    return 1.0 / (head + tail)


@functools.lru_cache(maxsize=64)
def _J_star(prandtl: float, c: int) -> float:
    return float(layer_J(1.0 / (math.sqrt(math.pi) * steady_nusselt(prandtl, c)), c))


def viscous_layer_rate(a1, h, nu: float, alpha: float, c: int):
    """The right-hand side of eq. (2') as a function of s^2, for wall cells of height ``h``
    showing the strain ``a1`` (per node; a1 <= 0: the linear strain of eq. 6 of the
    interface): returns rate(s2) -> d(s^2)/dt."""
    a_o, delta = outer_strain(a1, h, nu, c)
    pos = a_o > 0.0
    J_star = _J_star(float(nu / alpha), int(c))
    delta_pos = np.where(pos, delta, 1.0)  # the same at every call of rate
    two_a_o = 2.0 * a_o

    def rate(s2):
        s = np.sqrt(np.maximum(s2, 0.0))
        visc = alpha * (1.0 - layer_J(s / delta_pos, c) / J_star)
        return np.where(pos, visc, alpha - two_a_o * s2)

    return rate


@functools.lru_cache(maxsize=8)
def gauss_legendre(n: int):
    """``np.polynomial.legendre.leggauss(n)`` (points, weights), made once per n (read-only
    arrays: it costs ~1 ms a call, made at every coupling step before)."""
    g, gw = np.polynomial.legendre.leggauss(n)
    g.flags.writeable = False
    gw.flags.writeable = False
    return g, gw


def integrate_layer(s2, tau0, dt: float, rate, alpha: float, n: int = 8, sub: int = 1):
    """Advance d(s^2)/dt = rate(s^2) over the step [tau0, dt] (tau0 > 0: wetted inside it)
    and return (s^2 at the end, the step mean (1/dt) int 1/s dt).  Per node, in
    u = sqrt(t - tau0 + s2 / alpha) (s ~ sqrt(alpha) u near wetting, so 2 u / s is smooth):
    RK4 (``sub`` steps between the ``n`` Gauss-Legendre points of the mean and the end)."""
    s2 = np.asarray(s2, float)
    tau0 = np.broadcast_to(np.asarray(tau0, float), s2.shape)
    L = np.maximum(dt - tau0, 0.0)
    u0 = np.sqrt(np.maximum(s2, 0.0) / alpha)
    u1 = np.sqrt(u0 * u0 + L)
    g, gw = gauss_legendre(n)
    pts = np.concatenate([0.5 * (g + 1.0), [1.0]])       # in [0, 1] of (u - u0) / (u1 - u0)

    def du(u, y):  # d(s^2)/du = 2 u rate
        return 2.0 * u * rate(y)

    y = s2.copy()
    prev = 0.0
    acc = np.zeros_like(s2)
    span = u1 - u0
    for k, p in enumerate(pts):
        hstep = (p - prev) / sub
        for j in range(sub):
            u = u0 + (prev + j * hstep) * span
            hh = hstep * span
            k1 = du(u, y)
            k2 = du(u + 0.5 * hh, y + 0.5 * hh * k1)
            k3 = du(u + 0.5 * hh, y + 0.5 * hh * k2)
            k4 = du(u + hh, y + hh * k3)
            y = np.maximum(y + hh / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), 0.0)
        prev = p
        if k < n:
            uk = u0 + p * span
            s = np.sqrt(y)
            with np.errstate(divide="ignore", invalid="ignore"):
                f = np.where(s > 0, 2.0 * uk / s, 2.0 / math.sqrt(alpha))
            acc += 0.5 * span * gw[k] * f
    return y, acc / dt
