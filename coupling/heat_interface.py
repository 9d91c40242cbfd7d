"""Conservative heat flux from SPH fluid particles into an FEM substrate surface, valid
when the thermal layers are thinner than the particle spacing.

The problem
-----------
When a fluid at T_f touches a solid at T_s the two thermal layers grow like
sqrt(alpha t); over an impact (microseconds) they stay below a micrometre in water, far
below the particle spacing dx.  A particle-to-particle wall conduction k (T_i - T_s)/dx
then carries a flux ~ sqrt(alpha t)/dx of the true one.  The true contact flux of two
semi-infinite bodies is (Carslaw & Jaeger 1959, sec. 2.15)

    q = e_f (T_inf - T_i) / sqrt(pi t) = e_s (T_i - T_s0) / sqrt(pi t),
    T_i = (e_f T_inf + e_s T_s0) / (e_f + e_s),   e = sqrt(k rho c),                  (1)

i.e. the fluid side delivers q = k_f (T_inf - T_wall) / sqrt(pi alpha_f t) to a wall at
T_wall, with the fluid profile T = T_wall + (T_inf - T_wall) erf(z / (2 sqrt(alpha_f t))).

The closure (one formula from unresolved to resolved layers)
-------------------------------------------------------------
At each wetted surface node a (FEM surface basis function N_a, lumped area
A_a = int N_a dS) the near-wall fluid is sampled from the contact layer L through the
particles' footprints on the wall: particle i (size h_i, default V_i^(1/dim), centre at
z_i from the wall) owns the patch F_i of side h_i centred on its projection (an annulus
2 pi r dS on axisymmetric meshes), and

    w_ai = B_ai / sum_j B_aj,   B_ai = [i in L] int_{F_i} N_a dS,
    L = {i : -h_i/2 < z_i,  z_i - h_i/2 < g h_i,  sum_{j below i} o_ij < 1/2}           (2)

(the integral by Gauss points, ``n_gauss`` per lateral axis).  L is the first cell layer:
the particles whose cell's lower face lies within g = ``contact_gap`` (default 1) cells
of the wall and which lie over the wall, not over other fluid: o_ij is the share of i's
footprint over particle j's (prod_k (1 - |y_i,k - y_j,k| / h_ij)_+, h_ij the mean size),
summed over the j at least h_ij/2 lower.  The SPH wall holds the fluid 0-1 cell off the
surface (the first layer's lower face rides anywhere in [0, h) during an impact), so the
layer is counted whatever its height in its first cell, and each of its cells is read
as adjacent to the wall (z_i = h_i/2 in (3)): its heat m c T is the heat of the fluid
touching the wall.  (The earlier criterion, ``wetting="chi"``, weighted the particles by
chi(z_i/h_i) = clip(2 - 2 z_i/h_i, 0, 1), a function of the ride height: the wetted
area of the droplet job changed +80 % from dx = 10 to 6.25 um.)  Because the N_a are a
partition of unity, sum_a B_ai is particle i's footprint area: when the footprints tile
the wall, a uniform flux takes the same heat per unit footprint from every wall
particle, so the sampled temperature of a node is depleted by exactly Q / (rho c h) when
the node has given Q [J/m^2] (a kernel-weighted
Shepard sample with the same weights for removal over-weights the particles it depletes
most; measured 3-5 % flux error on the contact problem at dx = 6.25 um).  A particle's
temperature is the average of the fluid field over its cell (the finite-volume reading of an SPH
particle: its heat m c T is the cell's heat), so with the similarity profile of (1),
s = sqrt(alpha_f t_w), t_w the time since node a was wetted,

    T_f,a - T_wall = (T_inf - T_wall) Phi_a(s),   Phi_a = sum_i w_ai <erf(z/2s)>_{cell i}  (3)

and the wall flux of the fluid side, q = k_f (T_inf - T_wall)/(sqrt(pi) s), becomes

    q_a = h_a (T_f,a - T_wall),   h_a = k_f / L_a,   L_a = sqrt(pi) s Phi_a(s).         (4)

Limits: s << h (unresolved): Phi -> 1 - (cell-1 share) 2s/(sqrt(pi) h), L_a -> sqrt(pi
alpha_f t_w): the contact-conduction flux e_f (T_inf - T_wall)/sqrt(pi t_w) of (1), with
the depletion of the wall cell by the heat it already gave (its T is a cell average,
T_inf - Q/(rho c h)) undone by the same Phi.  s >> h (resolved): <erf> -> z/(sqrt(pi) s),
L_a -> sum_i w_ai z_c,i (cell centres): the one-sided wall conduction k_f (T_f - T_wall)/d
of the resolved field.  Nothing in (4) is fitted: it is (1) read through the particles'
cell averages, so it is exact for the two semi-infinite bodies at any spacing, and it
hands over to the resolved conduction as the layer outgrows the particles.  Over a step
the layer's 1/sqrt(t) is integrated exactly: h_a uses the step mean
2 (sqrt(t_w + dt) - sqrt(t_w)) / dt of 1/sqrt(t) and Phi at the start of the step (the
state of the particles' temperatures it reads; Phi(0) = 1).

Conservation
------------
The exchange is implicit in the substrate's surface temperature (the Robin term of
:class:`sphfem.fem.heat_transient.TransientHeat`, eq. 1-2 there) and explicit in the
fluid temperatures T_f,a (the fluid's heat capacity per wetted node is much larger than
that of the sub-um surface layer).  The heat the substrate takes in at node a in the step,
F_a dt, is removed from the particles with the weights (2):

    dE_i = sum_a w_ai F_a dt,   sum_i dE_i = sum_a F_a dt                                 (5)

(sum_i w_ai = 1 on every wetted node; dry nodes exchange nothing), so the heat the fluid
loses equals the heat the substrate gains to round-off.  Read literally, (5) takes a
node's heat from its particles by their weights whatever their own temperatures: a
particle already at the wall's temperature under a node whose mean is hotter loses its
share and is cooled below the wall (the 10 m/s droplet job at D/dx 64 left contact-line
rings 5-8 K below the 20 C substrate, 2026-12-07).  So the share follows each particle's
own excess over the surface as well (:func:`removal`):

    dE_i = sum_a F_a dt w_ai e_ai / sum_j w_aj e_aj,   e_ai = max(sgn(F_a) (T_i - T_s,a), 0)  (5')

which is (5) when the node's particles share one temperature (the uniform-flux tiling
above) and still sums to sum_a F_a dt.  A particle then loses at most dt sum_a w_ai hA_a
(T_i - T_s,a) (F_a <= hA_a dt (T_f,a - T_s,a) and the node mean's excess is at most the
sum of its positive parts), so it cannot cross the surface's temperature while

    dt sum_a w_ai hA_a <= m_i c_i                                                       (5'')

and when the caller passes the capacities m_i c_i the nodes' conductances are scaled
down until (5'') holds (``capped`` counts the node-steps: a ring next to the axis, whose
mass goes as r, under a strain spike).

Wetting: node a becomes wetted when the contact layer's footprints cover at least
``wet_fraction`` (1/2) of it, sum_i B_ai >= wet_fraction A_a, and stays wetted while
the layer taken within ``stay_gap`` (2) cells covers any of it (a wetted node then
samples that layer).  The hysteresis keeps the layer's age where the SPH fluid lifts
off the wall for a moment: in the droplet job the lowest fluid under the impact point
rises to a gap of 1.1 dx at 0.8-0.9 us and returns (without it the node dried, its age
restarted and the surface overshot the contact temperature by 5 K).  A node enters when
it lies inside the footprints' union (for a straight edge through a node the cover is
exactly 1/2), so the wetted area is the union's area to the lumping of the surface
nodes.  Its error against the fluid's true contact area: a contact line that meets the
wall steeply is placed to within the rounding of the edge to a lattice cell and a node
(zero mean; order 3/2 in the heat over a spreading history, limited by the last cell
wetted, where sqrt(t - t_w) is not smooth: tests/test_heat_interface_wetting.py), a free
surface that approaches the wall at a glancing angle (an impacting droplet's first
contact) is counted from the time it comes within g h of the wall, early by at most
g h / v (first order).  t_w counts from the wetting time: the start of the first step
when the node is wet at the first observation, else the midpoint of the step in which
it became wet (it was dry at the start, wet at the end); it restarts when the node dries.

The strained layer (``layer = "strained"``)
-------------------------------------------
Over a spreading droplet the fluid is not stagnant: near the wall the tangential flow
stretches the layer at the rate a = div_wall u_par (the wall-parallel divergence; by
continuity the normal velocity is w = -a z close to the wall), and the layer stops
growing once the stretching balances conduction.  The erf profile stays the exact
solution of the strained layer dT/dt - a z dT/dz = alpha_f d2T/dz2 for any a(t), with

    T = T_wall + (T_inf - T_wall) erf(z / (2 s)),   d(s^2)/dt = alpha_f - 2 a s^2,          (6)

(substitute T(z / 2s(t)): the erf's F'' = -2 eta F' needs 2 s s' + 2 a s^2 = alpha_f);
a = 0 gives back s^2 = alpha_f t_w, a constant a the steady s^2 = alpha_f / (2 a) of the
stagnation-point layer (axisymmetric u_r = A r: a = 2 A).  With "strained", the closure
(3)-(4) reads s from (6) per wetted node (s^2 = 0 at wetting, advanced exactly over a
step for a held constant; the flux's step mean of 1/s by Gauss quadrature in u =
sqrt(t - t_start)), and a from the contact layer's own motion: a weighted least-squares
linear fit of the particles' tangential velocities within ``strain_radius`` particle
sizes of the node (:func:`surface_divergence`; on axisymmetric walls u_r/r added, the
particles mirrored at the axis).  That a is also the rate at which the SPH flow renews
the wall cell (the first row is stretched apart and refilled from above at div_wall u),
so the temperature the closure reads from the wall cell is the one (3) assumes: the
stagnant closure in a strained flow reads a renewed, hot wall cell through a layer
s = sqrt(alpha_f t_w) that keeps growing, infers T_inf too high by 1/Phi, and the
impact-point temperature then rises with resolution (validation droplet-impact).

On a no-slip wall the stretching flow is itself slowed inside the viscous layer, which a
thermal layer of Pr ~ 1 shares: ``layer = "strained-viscous"`` reads the outer strain and
the viscous length from the fitted strain of the wall cells through the Hiemenz / Homann
stagnation-point profile and advances s by the energy integral of the erf profile in that
flow (:mod:`sphfem.heat.stagnation_layer`, eq. 2'; exact at a = 0 and at the steady layer).
It needs the fluid's kinematic viscosity ``nu_f``.

The maximum principle.  Eq. (3) infers T_inf from the wall cell's temperature through
Phi, which holds while the cell keeps the deficit of the heat it gave.  An SPH wall cell
can lose that deficit faster than the fluid layer does: its particles move with the cell's
mean tangential velocity (the real deficit sits at z < s, where the no-slip flow is
slowest) and are replaced by fresh fluid from above, and the SPH conduction refills it
across a whole spacing.  The cell then reads hotter than (3) allows and the inferred T_inf
leaves the fluid's own temperature range (measured in the droplet job: up to 111 C from a
100 C drop at D/dx 16).  No fluid layer can have a far field outside the temperatures the
fluid holds, so the closure holds it there:

    q_a = k_f <1/s> (T_inf,a - T_wall) / sqrt(pi),  T_inf,a held in [min T_fluid, max T_fluid]  (7)

(the Robin pair becomes h_a Phi_a and the bound); ``diagnostics()`` counts the held
node-steps and the largest excess.

What the model assumes (and where it is not exact): the fluid layer is the similarity
solution from the wetting time (stagnant: a = 0; strained: (6) with the strain of the
wall cell, which on a no-slip wall is the strain at half a cell's height: larger than
inside a layer thinner than the viscous one); T_inf and T_wall vary slowly compared with
the layer's age; one fluid material per node.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import erf

from sphfem.fem.heat_transient import ierfc
from sphfem.heat.stagnation_layer import gauss_legendre

__all__ = ["ContactHeatInterface", "cell_mean_erf", "contact_solution",
           "step_mean_inv_sqrt", "strained_layer_s2", "strained_mean_inv_s",
           "surface_divergence"]

#: wetting criteria: "contact-layer" (eq. 2) or "chi" (the earlier height taper, eq. 2')
WETTING = ("contact-layer", "chi")
#: fluid-side layer models: "stagnant" (s^2 = alpha_f t_w), "strained" (eq. 6) or
#: "strained-viscous" (eq. 6 under the viscous stagnation-point layer, sphfem.heat.stagnation_layer)
LAYERS = ("stagnant", "strained", "strained-viscous")


def cell_mean_erf(a, b, s):
    """Mean of erf(z / (2 s)) over [a, b] (0 <= a < b), elementwise:
    (G(b) - G(a)) / (b - a),  G(z) = int_0^z erf(u / 2s) du = z - 2s/sqrt(pi) + 2s ierfc(z/2s)."""
    a, b, s = (np.asarray(v, float) for v in (a, b, s))
    s = np.maximum(s, 1e-300)

    def G(z):
        return z - 2.0 * s / math.sqrt(math.pi) + 2.0 * s * ierfc(z / (2.0 * s))

    width = b - a
    out = np.where(width > 1e-12 * np.maximum(b, 1e-300),
                   (G(b) - G(a)) / np.where(width > 0, width, 1.0),
                   erf(0.5 * (a + b) / (2.0 * s)))
    return out


def step_mean_inv_sqrt(t_w, dt):
    """(1/dt) int_t^{t+dt} (t' - t_wet)^(-1/2) dt' for a layer of age ``t_w`` = t - t_wet at
    the start of the step (t_w < 0: wetted inside the step, nothing before t_wet):
    2 (sqrt(max(t_w + dt, 0)) - sqrt(max(t_w, 0))) / dt, in a form free of cancellation."""
    t_w = np.asarray(t_w, float)
    a = np.sqrt(np.maximum(t_w, 0.0))
    b = np.sqrt(np.maximum(t_w + dt, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(t_w >= 0.0, 2.0 / (a + b), 2.0 * b / dt)


def contact_solution(t, T_f, T_s, k_f, rho_f, c_f, k_s, rho_s, c_s):
    """Two semi-infinite bodies brought into contact at t = 0 (eq. 1): interface
    temperature T_i, flux q(t) [W/m^2] into the solid and heat Q(t) = 2 q t [J/m^2]."""
    ef = math.sqrt(k_f * rho_f * c_f)
    es = math.sqrt(k_s * rho_s * c_s)
    Ti = (ef * T_f + es * T_s) / (ef + es)
    t = np.asarray(t, float)
    C = ef * es * (T_f - T_s) / ((ef + es) * math.sqrt(math.pi))
    with np.errstate(divide="ignore"):
        return Ti, C / np.sqrt(t), 2.0 * C * np.sqrt(t)


def strained_layer_s2(s2, a, alpha, tau):
    """s^2 after a time ``tau`` of eq. (6), d(s^2)/dt = alpha - 2 a s^2 with the strain
    ``a`` held constant, from ``s2``: s2 e^(-2 a tau) + alpha tau (1 - e^(-x)) / x,
    x = 2 a tau (-> s2 + alpha tau as a -> 0), elementwise."""
    s2, a, tau = np.broadcast_arrays(*(np.asarray(v, float) for v in (s2, a, tau)))
    x = np.maximum(2.0 * a * tau, -50.0)
    small = np.abs(x) < 1e-6
    xs = np.where(small, 1.0, x)
    g = np.where(small, 1.0 - 0.5 * x + x * x / 6.0, -np.expm1(-xs) / xs)
    return s2 * np.exp(-x) + alpha * tau * g


def strained_mean_inv_s(s2, a, alpha, tau0, dt, n: int = 8):
    """(1/dt) int_{tau0}^{dt} 1/s dt' over a step of length ``dt`` for a layer that
    starts at ``s2`` at tau0 (0 <= tau0 < dt: wetted inside the step) and follows eq. (6):
    Gauss-Legendre in u = sqrt(t' - tau0 + s2 / alpha) (the stagnant layer's age: then
    1/s = 1/(sqrt(alpha) u) and the integrand 2 u / s is constant for a = 0, so the rule is
    exact there and smooth for any a).  Elementwise over nodes."""
    s2, a, tau0 = np.broadcast_arrays(*(np.asarray(v, float) for v in (s2, a, tau0)))
    L = np.maximum(dt - tau0, 0.0)
    t_s = np.maximum(s2, 0.0) / alpha
    g, gw = gauss_legendre(n)
    u0, u1 = np.sqrt(t_s)[..., None], np.sqrt(t_s + L)[..., None]
    u = u0 + 0.5 * (g + 1.0) * (u1 - u0)
    s = np.sqrt(strained_layer_s2(s2[..., None], a[..., None], alpha,
                                  np.maximum(u * u - t_s[..., None], 0.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(s > 0, 2.0 * u / s, 2.0 / math.sqrt(alpha))
    return np.sum(0.5 * (u1 - u0) * gw * f, axis=-1) / dt


def surface_divergence(yp, up, Y, radius: float, axisymmetric: bool = False,
                       min_points: int | None = None):
    """Divergence of a tangential velocity field on a plane wall at the points ``Y``
    (k, L) (L = 1 or 2 lateral axes), from samples ``up`` (m, L) at ``yp`` (m, L): at each
    point the weighted least-squares linear fit u(y) = c + G (y - Y) over the samples
    within ``radius`` (weights (1 - d / radius)^2), and div = trace G; axisymmetric walls
    (L = 1, y = r >= 0, u = u_r): samples mirrored at the axis (r -> -r, u_r -> -u_r) and
    div = dG + c / r (2 dG on the axis).  Returns (k,) with nan where fewer than
    ``min_points`` (default L + 2) samples fall in the radius or the fit is singular:
    exact for a linear field."""
    from scipy.spatial import cKDTree

    yp = np.atleast_2d(np.asarray(yp, float))
    up = np.atleast_2d(np.asarray(up, float))
    Y = np.atleast_2d(np.asarray(Y, float))
    k, L = Y.shape
    out = np.full(k, np.nan)
    if k == 0 or yp.shape[0] == 0:
        return out
    if axisymmetric:
        if L != 1:
            raise ValueError("surface_divergence: an axisymmetric wall has one lateral axis")
        m = yp[:, 0] < radius
        yp = np.vstack([yp, -yp[m]])
        up = np.vstack([up, -up[m]])
    need = L + 2 if min_points is None else int(min_points)
    D = cKDTree(Y).sparse_distance_matrix(cKDTree(yp), radius, output_type="coo_matrix")
    rows, cols = D.row, D.col
    w = (1.0 - D.data / radius) ** 2
    # pairs at distance 0 are dropped by the sparse matrix: add them back
    d0, j0 = cKDTree(yp).query(Y, k=1)
    z = np.flatnonzero(d0 == 0.0)
    rows = np.concatenate([rows, z])
    cols = np.concatenate([cols, j0[z]])
    w = np.concatenate([w, np.ones(z.size)])
    phi = np.concatenate([np.ones((rows.size, 1)), (yp[cols] - Y[rows]) / radius], axis=1)
    M = np.zeros((k, L + 1, L + 1))
    b = np.zeros((k, L + 1, L))
    for p in range(L + 1):
        for q in range(L + 1):
            M[:, p, q] = np.bincount(rows, weights=w * phi[:, p] * phi[:, q], minlength=k)
        for q in range(L):
            b[:, p, q] = np.bincount(rows, weights=w * phi[:, p] * up[cols, q], minlength=k)
    count = np.bincount(rows, minlength=k)
    ok = count >= need
    if not ok.any():
        return out
    cond = np.linalg.cond(M[ok])
    good = np.flatnonzero(ok)[np.isfinite(cond) & (cond < 1e8)]
    if good.size == 0:
        return out
    G = np.linalg.solve(M[good], b[good])           # (g, L + 1, L): c, then radius * grad
    div = sum(G[:, 1 + q, q] for q in range(L)) / radius
    if axisymmetric:
        r = Y[good, 0]
        on_axis = r <= 1e-9 * radius
        div = div + np.where(on_axis, G[:, 1, 0] / radius,
                             G[:, 0, 0] / np.where(on_axis, 1.0, r))
    out[good] = div
    return out


def removal(heat, rows, cols, w, T, Ts, n: int) -> np.ndarray:
    """Eq. (5'): the heat each of ``n`` particles (temperatures ``T``) loses when the
    surface nodes take in ``heat`` [J] (F_a dt; surface temperatures ``Ts`` at the end of
    the step), given the weights ``w`` of the pairs (``rows`` node, ``cols`` particle):
    node a's heat is shared in proportion to w_ai e_ai, e_ai = max(sgn(F_a) (T_i -
    Ts_a), 0), each particle's own excess over the surface (by w_ai alone where no
    particle of the node has any; the weights sum to 1 over each node, as
    :meth:`ContactHeatInterface.weights` returns them).  sum_i dE_i = sum_a F_a dt
    exactly."""
    if rows.size == 0:
        return np.zeros(n)
    g = w * np.maximum(np.sign(heat[rows]) * (T[cols] - Ts[rows]), 0.0)
    G = np.bincount(rows, weights=g, minlength=heat.size)[rows]
    share = np.where(G > 0.0, g / np.where(G > 0.0, G, 1.0), w)
    return np.bincount(cols, weights=share * heat[rows], minlength=n)


class ContactHeatInterface:
    """Fluid particles -> :class:`~sphfem.fem.heat_transient.TransientHeat` surface (module
    docstring).

    ``substrate``: the FEM heat solver (its flux group is the wetted surface, a plane
    ``x[axis] = level``; the fluid lies on the side ``side`` = +1 / -1 of it).  ``k_f``,
    ``rho_f``, ``c_f``: the fluid's properties; ``period`` (dim,) periodic lengths along
    the wall (0: open) of the cell starting at ``lo`` (footprints wrap); footprint parts
    beyond an open surface's extent are dropped.  ``layer``: "stagnant" (s^2 = alpha_f
    t_w) or "strained" (eq. 6, the strain fitted within ``strain_radius`` particle sizes;
    :meth:`step` then needs the particles' velocities).  Call :meth:`step` once per
    coupling step.
    """

    def __init__(self, substrate, k_f: float, rho_f: float, c_f: float,
                 axis: int = -1, level: float | None = None,
                 side: int = 1, wet_fraction: float = 0.5, period=None, lo=None,
                 n_gauss: int = 4, wetting: str = "contact-layer", contact_gap: float = 1.0,
                 stay_gap: float = 2.0, layer: str = "stagnant",
                 strain_radius: float = 3.0, nu_f: float | None = None):
        self.sub = substrate
        self.k_f, self.rho_f, self.c_f = float(k_f), float(rho_f), float(c_f)
        self.alpha_f = self.k_f / (self.rho_f * self.c_f)
        self.X = substrate.surface_points()
        self.dim = self.X.shape[1]
        self.axis = axis % self.dim
        self.level = float(np.mean(self.X[:, self.axis])) if level is None else float(level)
        if np.ptp(self.X[:, self.axis]) > 1e-9 * max(np.ptp(self.X), 1e-300):
            raise ValueError("ContactHeatInterface: the flux group must be a plane "
                             "x[axis] = level")
        self.side = 1 if side >= 0 else -1
        self.wet_fraction = float(wet_fraction)
        if wetting not in WETTING:
            raise ValueError(f"ContactHeatInterface: wetting must be one of {WETTING}, "
                             f"got {wetting!r}")
        self.wetting = wetting
        if layer not in LAYERS:
            raise ValueError(f"ContactHeatInterface: layer must be one of {LAYERS}, "
                             f"got {layer!r}")
        self.layer = layer
        if not strain_radius > 0.0:
            raise ValueError(f"ContactHeatInterface: strain_radius must be > 0, "
                             f"got {strain_radius!r}")
        self.strain_radius = float(strain_radius)
        if layer == "strained-viscous" and not (nu_f is not None and nu_f > 0.0):
            raise ValueError('ContactHeatInterface: layer = "strained-viscous" needs the '
                             f"fluid's kinematic viscosity nu_f > 0, got {nu_f!r}")
        self.nu_f = None if nu_f is None else float(nu_f)
        self.contact_gap = float(contact_gap)
        self.stay_gap = max(float(stay_gap), self.contact_gap)
        self.period = (np.zeros(self.dim) if period is None
                       else np.broadcast_to(np.asarray(period, float), (self.dim,)).copy())
        self.lo = (np.zeros(self.dim) if lo is None
                   else np.broadcast_to(np.asarray(lo, float), (self.dim,)).copy())
        if self.period[self.axis] > 0:
            raise ValueError("ContactHeatInterface: the wall-normal axis cannot be periodic")
        self.n_gauss = int(n_gauss)
        self._shape = _SurfaceShape(substrate, self.axis)
        self._slo = self.X.min(axis=0)
        self._shi = self.X.max(axis=0)
        self._eps = 1e-9 * float(np.max(np.ptp(self.X, axis=0)))
        n = self.X.shape[0]
        self.t = 0.0
        self.t_wet = np.full(n, np.nan)   #: wetting time per surface node (nan: dry)
        self.s2 = np.full(n, np.nan)      #: strained layer's s^2 per node (eq. 6; nan: dry)
        self.strain = np.zeros(n)         #: the last step's strain a per node [1/s]
        self.heat_to_substrate = 0.0      #: sum of the substrate's F dt [J]
        self.heat_from_fluid = 0.0        #: sum of the particles' dE [J]
        self.steps = 0
        #: maximum principle (eq. 7): wetted node-steps whose inferred T_inf was held at
        #: the fluid's temperature range, and the largest excess before the hold [K]
        self.held = 0
        self.held_excess_max = 0.0
        #: node-steps whose conductance eq. (5'') capped
        self.capped = 0
        self._phi_n = None
        self.last: dict = {}
        self._cache = None

    # -- sampling -----------------------------------------------------------------------
    def weights(self, x, vol, h=None, was_wet=None):
        """Sampling / removal weights (2) of the particles ``x`` (n, dim) with volumes
        ``vol`` and sizes ``h`` (default V^(1/dim)); ``was_wet`` (surface nodes) the
        nodes wetted before, which stay wetted while the layer within ``stay_gap`` cells
        covers any of them ("Wetting" in the module docstring; None: no history).

        Returns ``(rows, cols, w, wet, z, h)``: rows the surface node, cols the particle,
        ``w`` = B_ai / sum_j B_aj over each wetted node (module docstring, eq. 2); ``z``
        the distances read by the closure (contact-layer cells at h/2)."""
        import scipy.sparse as sp

        x = np.atleast_2d(np.asarray(x, float))
        n = x.shape[0]
        vol = np.broadcast_to(np.asarray(vol, float), (n,))
        h = vol ** (1.0 / self.dim) if h is None else np.broadcast_to(
            np.asarray(h, float), (n,))
        z = self.side * (x[:, self.axis] - self.level)
        nX = self.X.shape[0]
        if self.wetting == "chi":
            chi = np.clip(2.0 - 2.0 * np.maximum(z, 0.0) / h, 0.0, 1.0)
            near = np.flatnonzero((z > -0.5 * h) & (chi > 0.0))  # the wall layer
        else:  # the contact layer (eq. 2), its cells read as adjacent to the wall
            held = was_wet is not None and bool(np.any(was_wet))
            layer = self.contact_layer(x, z, h, self.stay_gap if held else None)
            enter = layer & (z - 0.5 * h < self.contact_gap * h)
            near = np.flatnonzero(layer)
            chi = np.ones(n)
            z = z.copy()
            z[near] = 0.5 * h[near]
        if near.size == 0:
            e = np.zeros(0)
            return (e.astype(np.int64), e.astype(np.int64), e, np.zeros(nX, bool), z, h)
        # footprint quadrature: n_g Gauss points per lateral axis over [-h/2, h/2]
        g, gw = gauss_legendre(self.n_gauss)
        lat = [a for a in range(self.dim) if a != self.axis]
        grids = np.meshgrid(*[g] * len(lat), indexing="ij")
        off = np.stack([q.ravel() for q in grids], -1) * 0.5          # (nq, L), in [-1/2, 1/2]
        wq = np.prod(np.meshgrid(*[gw * 0.5] * len(lat), indexing="ij"), axis=0).ravel()
        nq = wq.size
        P = np.repeat(x[near], nq, axis=0)
        hq = np.repeat(h[near], nq)
        for c, a in enumerate(lat):
            P[:, a] += np.tile(off[:, c], near.size) * hq
        P[:, self.axis] = self.level - self.side * self._eps
        meas = np.tile(wq, near.size) * hq ** len(lat) * np.repeat(chi[near], nq)
        if self.sub.axisymmetric:
            meas = meas * 2.0 * np.pi * np.abs(P[:, 0])
            P[:, 0] = np.abs(P[:, 0])  # a footprint across the axis folds back
        part = np.repeat(near, nq)
        for a in lat:  # periodic axes wrap; open ones drop points beyond the surface
            if self.period[a] > 0:
                P[:, a] = self.lo[a] + np.mod(P[:, a] - self.lo[a], self.period[a])
                P[:, a] = np.clip(P[:, a], self._slo[a], self._shi[a])
        inside = np.all((P[:, lat] >= self._slo[lat]) & (P[:, lat] <= self._shi[lat]),
                        axis=1)
        P, meas, part = P[inside], meas[inside], part[inside]
        if P.shape[0] == 0:
            e = np.zeros(0)
            return (e.astype(np.int64), e.astype(np.int64), e, np.zeros(nX, bool), z, h)
        N = self._shape(P[:, lat])
        # B_ai = int_{footprint i} N_a dS
        B = sp.coo_matrix((N.data * meas[N.row], (N.col, part[N.row])),
                          shape=(nX, n)).tocsr()
        B.sum_duplicates()
        Bc = B.tocoo()
        if self.wetting == "chi":
            use = np.ones(Bc.nnz, bool)
            cover = np.asarray(B.sum(axis=1)).ravel()
            wet = cover >= self.wet_fraction * self.sub.surface_area
        else:  # new nodes by the layer within contact_gap; wetted ones held by stay_gap
            old = np.zeros(nX, bool) if was_wet is None else np.asarray(was_wet, bool)
            use = old[Bc.row] | enter[Bc.col]
            cover_in = np.bincount(Bc.row, weights=Bc.data * enter[Bc.col], minlength=nX)
            cover = np.bincount(Bc.row, weights=Bc.data * use, minlength=nX)
            wet = (cover_in >= self.wet_fraction * self.sub.surface_area) | (old & (cover > 0))
            cover = np.where(old, cover, cover_in)
        keep = wet[Bc.row] & (Bc.data > 0) & use
        rows, cols = Bc.row[keep], Bc.col[keep]
        w = Bc.data[keep] / cover[rows]
        return rows, cols, w, wet, z, h

    def contact_layer(self, x, z, h, gap=None) -> np.ndarray:
        """Mask of the contact layer (module docstring, eq. 2) among the particles ``x``
        (n, dim) at distances ``z`` from the wall with sizes ``h``: lower face within
        ``gap`` (default ``contact_gap``) h of the wall (centre above -h/2) and less than
        half the footprint over cells lying at least half a cell lower."""
        n = len(z)
        gap = self.contact_gap if gap is None else gap
        band = (z > -0.5 * h) & (z - 0.5 * h < gap * h)
        cand = np.flatnonzero(band)
        if cand.size < 2:
            return band
        lat = [a for a in range(self.dim) if a != self.axis]
        Y = x[np.ix_(cand, lat)].copy()
        if self.sub.axisymmetric:
            Y[:, 0] = np.abs(Y[:, 0])
        hmax = float(h[cand].max())
        box = np.empty(len(lat))
        for c, a in enumerate(lat):  # a torus along periodic axes, no wrap along open ones
            if self.period[a] > 0:
                Y[:, c] = np.mod(Y[:, c] - self.lo[a], self.period[a])
                box[c] = self.period[a]
            else:
                Y[:, c] -= Y[:, c].min()
                box[c] = Y[:, c].max() + 4.0 * hmax
        Y = np.minimum(Y, np.nextafter(box, 0.0))
        pairs = cKDTree(Y, boxsize=box).query_pairs(hmax, output_type="ndarray")
        if pairs.size == 0:
            return band
        i, j = pairs[:, 0], pairs[:, 1]
        d = np.abs(Y[i] - Y[j])
        d = np.minimum(d, box - d)
        hb = 0.5 * (h[cand[i]] + h[cand[j]])
        overlap = np.prod(np.clip(1.0 - d / hb[:, None], 0.0, None), axis=1)
        zi, zj = z[cand[i]], z[cand[j]]
        # footprint share of the higher particle lying over a lower one
        hi_i = zi >= zj + 0.5 * hb
        hi_j = zj >= zi + 0.5 * hb
        cover = (np.bincount(i[hi_i], weights=overlap[hi_i], minlength=cand.size)
                 + np.bincount(j[hi_j], weights=overlap[hi_j], minlength=cand.size))
        out = np.zeros(n, bool)
        out[cand[cover < 0.5]] = True
        return out

    # -- one coupling step ---------------------------------------------------------------
    @staticmethod
    def _phi(s_n, rows, cols, w, z, h, n_nodes):
        """Phi_a(s) of eq. (3) per node for layer thicknesses ``s_n`` (per node)."""
        a = np.maximum(z[cols] - 0.5 * h[cols], 0.0)
        b = np.maximum(z[cols] + 0.5 * h[cols], a + 1e-12 * h[cols])
        return np.bincount(rows, weights=w * cell_mean_erf(a, b, s_n[rows]),
                           minlength=n_nodes)

    def conductance(self, t_w, dt, rows, cols, w, z, h, n_nodes):
        """h_a of eq. (4) [W/(m^2 K)] per node for layer ages ``t_w`` at the start of the
        step: the exact step mean of the similarity flux for the fluid state at the start
        of the step, k_f / (sqrt(pi alpha_f) Phi_a(s_n)) * 2 (sqrt(t_w + dt) - sqrt(t_w)) / dt,
        since T_inf - T_wall = (T_f,a - T_wall) / Phi_a(s_n) holds for the particles'
        temperatures T_f,a at the start (eq. 3) and stays constant in the ideal contact."""
        s_n = np.sqrt(self.alpha_f * np.maximum(t_w, 0.0))
        phi = self._phi_n = self._phi(s_n, rows, cols, w, z, h, n_nodes)
        mean_inv_sqrt = step_mean_inv_sqrt(t_w, dt)
        with np.errstate(divide="ignore"):
            return np.where(phi > 0, self.k_f * mean_inv_sqrt
                            / (math.sqrt(math.pi * self.alpha_f) * phi), 0.0)

    def strained_conductance(self, s2, inv_s, rows, cols, w, z, h, n_nodes):
        """h_a of eq. (4) with a strained layer: k_f <1/s>_step / (sqrt(pi) Phi_a(s_n)),
        s_n = sqrt(s2) the layer at the start of the step (0: wetted inside it), ``inv_s``
        the step mean <1/s> (:func:`strained_mean_inv_s`,
        :func:`sphfem.heat.stagnation_layer.integrate_layer`)."""
        phi = self._phi_n = self._phi(np.sqrt(np.maximum(s2, 0.0)), rows, cols, w, z, h,
                                      n_nodes)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(phi > 0, self.k_f * inv_s / (math.sqrt(math.pi) * phi), 0.0)

    def node_strain(self, x, v, h, cols, wet) -> np.ndarray:
        """Strain a = div_wall u_par per surface node (zero on dry nodes and where the fit
        of :func:`surface_divergence` over the contact layer ``cols`` is singular)."""
        a = np.zeros(self.X.shape[0])
        idx = np.flatnonzero(wet)
        part = np.unique(cols)
        if idx.size == 0 or part.size == 0:
            return a
        lat = [c for c in range(self.dim) if c != self.axis]
        yp = x[np.ix_(part, lat)]
        up = np.asarray(v, float)[np.ix_(part, lat)]
        if self.sub.axisymmetric:
            up = np.where(yp < 0.0, -up, up)
            yp = np.abs(yp)
        for c, ax in enumerate(lat):  # periodic axes: samples within reach on both sides
            if self.period[ax] > 0:
                P = self.period[ax]
                yp = np.vstack([yp, yp + P * np.eye(len(lat))[c], yp - P * np.eye(len(lat))[c]])
                up = np.vstack([up, up, up])
        R = self.strain_radius * float(np.mean(h[part]))
        div = surface_divergence(yp, up, self.X[np.ix_(idx, lat)], R,
                                 axisymmetric=self.sub.axisymmetric)
        a[idx] = np.nan_to_num(div)
        return a

    def step(self, x, T, vol, dt: float, h=None, v=None, capacity=None) -> np.ndarray:
        """Exchange heat over ``dt`` between the particles (positions ``x`` (n, dim),
        temperatures ``T`` [K], volumes ``vol``, velocities ``v`` (n, dim), needed by the
        strained layer; fluid particles only) and the substrate, whose temperature it
        advances (one :meth:`TransientHeat.step`).  Returns the heat each particle loses
        [J] (eq. 5'): apply it as T_i -= dE_i / (m_i c_i).  ``capacity``: the particles'
        m_i c_i [J/K]; with it the conductances are capped so that no particle can cross
        the surface's temperature in the step (eq. 5'', "Conservation")."""
        T = np.asarray(T, float)
        if self.layer != "stagnant" and v is None:
            raise ValueError(f'ContactHeatInterface.step: layer = "{self.layer}" needs the '
                             "particles' velocities v")
        was_wet = ~np.isnan(self.t_wet)
        key = (np.array(x, float, copy=True), np.array(vol, float, ndmin=1, copy=True),
               None if h is None else np.array(h, float, ndmin=1, copy=True), was_wet)
        c = self._cache
        if c is not None and all(
                (a is None and b is None) or (a is not None and b is not None
                                              and a.shape == b.shape and np.array_equal(a, b))
                for a, b in zip(key, c[0], strict=True)):
            rows, cols, w, wet, z, hh = c[1]  # particles unchanged: the same weights
        else:
            rows, cols, w, wet, z, hh = self.weights(x, vol, h, was_wet)
            self._cache = (key, (rows, cols, w, wet, z, hh))
        nX = self.X.shape[0]
        newly = wet & np.isnan(self.t_wet)
        # wetted between two observations: at the step's midpoint (unbiased); wet at the
        # first observation: from the start of the step
        self.t_wet[newly] = self.t + (0.5 * dt if self.steps > 0 else 0.0)
        self.t_wet[~wet] = np.nan
        t_w = np.where(wet, self.t - np.nan_to_num(self.t_wet), 0.0)
        T_f = np.bincount(rows, weights=w * T[cols], minlength=nX)
        if self.layer != "stagnant":
            tau0 = np.clip(-t_w, 0.0, dt)  # wetted inside the step: from t_wet on
            self.s2[newly] = 0.0
            self.s2[~wet] = np.nan
            s2 = np.where(wet, np.nan_to_num(self.s2), 0.0)
            self.strain = self.node_strain(np.asarray(x, float), v, hh, cols, wet)
            # the layer of the wetted nodes only (a dry node's is not used: hA = 0 and
            # s^2 = nan there); every operation is elementwise per node
            iw = np.flatnonzero(wet)
            s2_end, inv_s = np.zeros(nX), np.zeros(nX)
            if self.layer == "strained":
                inv_s[iw] = strained_mean_inv_s(s2[iw], self.strain[iw], self.alpha_f,
                                                tau0[iw], dt)
                s2_end[iw] = strained_layer_s2(s2[iw], self.strain[iw], self.alpha_f,
                                               dt - tau0[iw])
            else:
                from sphfem.heat.stagnation_layer import integrate_layer, viscous_layer_rate

                h_node = np.bincount(rows, weights=w * hh[cols], minlength=nX)
                h_node = np.where(h_node > 0, h_node, float(np.mean(hh)) if hh.size else 1.0)
                c = 1 if (self.dim == 2 and not self.sub.axisymmetric) else 2
                rate = viscous_layer_rate(self.strain[iw], h_node[iw], self.nu_f,
                                          self.alpha_f, c)
                s2_end[iw], inv_s[iw] = integrate_layer(s2[iw], tau0[iw], dt, rate,
                                                        self.alpha_f)
            hA = np.where(wet, self.strained_conductance(s2, inv_s, rows, cols, w, z, hh,
                                                         nX), 0.0)
            self.s2 = np.where(wet, s2_end, np.nan)
        else:
            hA = np.where(wet, self.conductance(t_w, dt, rows, cols, w, z, hh, nX), 0.0)
        hA = hA * self.sub.surface_area
        Ts0 = self.sub.surface_temperature()
        T_ext = np.where(wet, T_f, Ts0)
        self._hold_inferred(hA, T_ext, wet, Ts0, T)
        if capacity is not None:
            self._cap_conductance(hA, rows, cols, w, dt, capacity, len(T))
        heat = self.sub.step(dt, robin=(hA, T_ext))  # F_a dt per surface node [J]
        dry_heat = float(np.abs(heat[~wet]).sum())
        dE = removal(heat, rows, cols, w, T, self.sub.surface_temperature(), len(T))
        self.heat_to_substrate += float(heat.sum())
        self.heat_from_fluid += float(dE.sum())
        self.t += dt
        self.steps += 1
        self.last = {"wetted": int(wet.sum()), "T_fluid": T_f, "hA": hA,
                     "heat": heat, "dry_heat": dry_heat}
        return dE

    def _cap_conductance(self, hA, rows, cols, w, dt, capacity, n: int) -> None:
        """Eq. (5''): scale the conductances ``hA`` (in place) so that every particle's
        dt sum_a w_ai hA_a <= m_i c_i (``capacity``, ``n`` particles); counted in
        ``capped``."""
        if rows.size == 0:
            return
        cap = np.broadcast_to(np.asarray(capacity, float), (n,))
        load = np.bincount(cols, weights=dt * w * hA[rows], minlength=cap.size)
        with np.errstate(divide="ignore", invalid="ignore"):
            over = np.where(load > cap, cap / load, 1.0)
        if over.min() >= 1.0:
            return
        f = np.ones(hA.size)
        np.minimum.at(f, rows, over[cols])
        self.capped += int(np.sum(f < 1.0))
        hA *= f

    def _hold_inferred(self, hA, T_ext, wet, Ts0, T) -> None:
        """Eq. (7): where the T_inf that eq. (3) infers from a wetted node's cell, T_wall +
        (T_f,a - T_wall) / Phi_a, lies outside the fluid's temperatures [min T, max T], the
        flux is k_f <1/s> (T_inf - T_wall) / sqrt(pi) with T_inf held at that bound
        (``hA`` and ``T_ext`` changed in place: hA Phi_a, the bound)."""
        phi = self._phi_n
        if phi is None or not wet.any() or T.size == 0:
            return
        lo, hi = float(T.min()), float(T.max())
        ok = wet & (phi > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            T_inf = np.where(ok, Ts0 + (T_ext - Ts0) / np.where(ok, phi, 1.0), T_ext)
        held = ok & ((T_inf > hi) | (T_inf < lo))
        if not held.any():
            return
        bound = np.clip(T_inf[held], lo, hi)
        self.held += int(held.sum())
        self.held_excess_max = max(self.held_excess_max,
                                   float(np.abs(T_inf[held] - bound).max()))
        hA[held] *= phi[held]
        T_ext[held] = bound

    def diagnostics(self) -> dict:
        return {"steps": self.steps, "t": self.t,
                "inferred_T_inf_held": self.held,
                "inferred_T_inf_excess_max_K": self.held_excess_max,
                "conductance_capped": self.capped,
                "heat_to_substrate_J": self.heat_to_substrate,
                "heat_from_fluid_J": self.heat_from_fluid,
                "balance_rel": ((self.heat_from_fluid - self.heat_to_substrate)
                                / max(abs(self.heat_to_substrate), 1e-300)),
                "wetted_nodes": self.last.get("wetted", 0),
                "substrate_factorisations": self.sub.factorisations}


class _SurfaceShape:
    """Values of the substrate's surface basis functions (P1 / Q1: one dof per node) at
    points of the planar flux group, given by their lateral coordinates: hat functions on
    the sorted surface nodes (2D / axisymmetric meshes), linear shape functions on the
    surface triangles (3D; quadrilateral facets split in two, which keeps the partition
    of unity).  Returns a COO matrix (points x surface dofs)."""

    def __init__(self, sub, axis: int):
        mesh = sub.mesh
        if sub.basis.N != mesh.nvertices:
            raise ValueError("ContactHeatInterface: the substrate needs a P1/Q1 element "
                             "(one dof per node)")
        nodes = np.asarray(sub.surface_dofs)
        self.n = nodes.size
        pos = np.full(mesh.nvertices, -1, np.int64)
        pos[nodes] = np.arange(self.n)
        lat = [a for a in range(mesh.p.shape[0]) if a != axis]
        self.dim_lat = len(lat)
        if self.dim_lat == 1:
            c = mesh.p[lat[0], nodes]
            order = np.argsort(c)
            self.c = c[order]
            self.idx = order
            return
        fac = pos[mesh.facets[:, mesh.boundaries[sub.flux_group]]]
        pl = mesh.p[np.ix_(lat, nodes)]
        if fac.shape[0] == 3:
            tri = fac
        else:  # quadrilaterals: order the corners around the centre, then split
            cen = pl[:, fac].mean(axis=1)
            ang = np.arctan2(pl[1, fac] - cen[1], pl[0, fac] - cen[0])
            q = np.take_along_axis(fac, np.argsort(ang, axis=0), axis=0)
            tri = np.hstack([q[[0, 1, 2]], q[[0, 2, 3]]])
        self.tri = tri
        self.pl = pl
        self.tree = cKDTree(pl[:, tri].mean(axis=1).T)

    def __call__(self, Y):
        import scipy.sparse as sp

        Y = np.atleast_2d(np.asarray(Y, float))
        m = Y.shape[0]
        if self.dim_lat == 1:
            y = Y[:, 0]
            i = np.clip(np.searchsorted(self.c, y), 1, self.c.size - 1)
            c0, c1 = self.c[i - 1], self.c[i]
            t = np.clip((y - c0) / (c1 - c0), 0.0, 1.0)
            rows = np.concatenate([np.arange(m), np.arange(m)])
            cols = np.concatenate([self.idx[i - 1], self.idx[i]])
            vals = np.concatenate([1.0 - t, t])
        else:
            e, lam = self._locate(Y)
            rows = np.tile(np.arange(m), 3)
            cols = self.tri[:, e].ravel()
            vals = lam.T.ravel()
        return sp.coo_matrix((vals, (rows, cols)), shape=(m, self.n))

    def _bary(self, Y, e):
        v = self.pl[:, self.tri[:, e]]  # (2, 3, m)
        d1, d2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        r = Y.T - v[:, 0]
        det = d1[0] * d2[1] - d1[1] * d2[0]
        l1 = (r[0] * d2[1] - r[1] * d2[0]) / det
        l2 = (d1[0] * r[1] - d1[1] * r[0]) / det
        return np.column_stack([1.0 - l1 - l2, l1, l2])

    def _locate(self, Y, k: int = 8):
        """Triangle and barycentric coordinates of each point: the first of its ``k``
        nearest triangles (by centroid) that contains it; a point in none (round-off at
        the surface's edge) takes the candidate it is least outside of, its coordinates
        clipped to >= 0 and renormalised (the partition of unity holds either way)."""
        m = Y.shape[0]
        k = min(k, self.tri.shape[1])
        _, cand = self.tree.query(Y, k)
        cand = np.asarray(cand).reshape(m, k)
        best_e = cand[:, 0].copy()
        best_lam = self._bary(Y, best_e)
        best_min = best_lam.min(axis=1)
        for j in range(1, k):
            todo = np.flatnonzero(best_min < -1e-12)
            if todo.size == 0:
                break
            lam = self._bary(Y[todo], cand[todo, j])
            better = lam.min(axis=1) > best_min[todo]
            t = todo[better]
            best_e[t], best_lam[t], best_min[t] = cand[t, j], lam[better], lam[better].min(1)
        lam = np.maximum(best_lam, 0.0)
        return best_e, lam / lam.sum(axis=1, keepdims=True)
