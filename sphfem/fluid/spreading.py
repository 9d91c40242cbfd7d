"""Maximum spreading of a droplet on a flat wall: published correlations and a measurement.

Dimensionless groups (D the droplet diameter, v the impact speed, theta the contact angle)::

    We = rho v^2 D / sigma,   Re = rho v D / mu,   beta_max = D_max / D

Correlations (all diameter-based; ``theta`` in degrees, the advancing contact angle):

* Pasandideh-Fard, Qiao, Chandra & Mostaghimi (1996), Phys. Fluids 8, 650 -- energy balance
  with viscous dissipation in a boundary layer of thickness 2 D / sqrt(Re)::

      beta_max = sqrt((We + 12) / (3 (1 - cos theta) + 4 We / sqrt(Re)))

  Valid where the boundary layer is thinner than the splat (Re >> 1) and We >> 1.
* Ukiwe & Kwok (2005), Langmuir 21, 666 -- the same balance with the surface energy of the
  splat at maximum spreading taken as a cylinder plus its top (an implicit cubic)::

      (We + 12) beta = 8 + beta^3 (3 (1 - cos theta) + 4 We / sqrt(Re))

* Clanet, Beguin, Richard & Quere (2004), J. Fluid Mech. 517, 199 -- scaling laws with the
  impact parameter P = We Re^(-4/5): capillary regime (P < 1) beta_max = 0.9 We^(1/4),
  viscous regime (P > 1) beta_max = Re^(1/5).  The two branches differ by 10 % at P = 1.
* Roisman (2009), Phys. Fluids 21, 052104 -- semi-empirical, for inertia-dominated impacts
  (Re >> 1, We >> 1)::

      beta_max = 0.87 Re^(1/5) - 0.40 Re^(2/5) We^(-1/2)

* Laan, de Bruin, Bartolo, Josserand & Bonn (2014), Phys. Rev. Applied 2, 044018 -- a Pade
  interpolation between the capillary and viscous regimes with P = We Re^(-2/5)::

      beta_max = Re^(1/5) sqrt(P) / (A + sqrt(P)),   A = 1.24

Scheller & Bousfield (1995) is not included (its fitted form could not be checked against
the paper here), nor are experimental points: this module holds no measured data.

Measurement (:func:`contact_diameter`, :func:`max_spreading`): the wetted (contact-line)
diameter of a frame is twice the largest distance from the impact axis of the fluid
particles lying within ``within`` particle spacings above the wall, plus one spacing (each
particle stands for a cell of width dx, so the fluid reaches dx/2 beyond its centre),
optionally over the largest connected sheet only (``link``); :func:`area_diameter` is the
diameter of a disc with the wetted area.  The maximum spreading is the largest wetted
diameter over the frames.  The wetted edge is the tip of the sheet the impact ejects along
the wall; :func:`lamella_root_radius` finds the sheet's root, where the droplet's body
ends (the radius Wagner's theory predicts).

Artificial viscosity: the Monaghan (1992) term with pair coefficient alpha h c0 acts in the
continuum limit as a kinematic viscosity nu_art = alpha h c0 / (2 (d + 2)) (Monaghan 2005,
Rep. Prog. Phys. 68, 1703, sec. 4.1), so an SPH run behaves like Re_eff = v D / (nu +
nu_art) (:func:`effective_reynolds`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FLUID_KIND = 0  # sphfem.particles.FLUID (not imported: keep this module numba-free)


# --------------------------------------------------------------------------------------
# dimensionless groups


def weber(rho: float, v: float, D: float, sigma: float) -> float:
    """We = rho v^2 D / sigma (diameter-based)."""
    return rho * v * v * D / sigma


def reynolds(rho: float, v: float, D: float, mu: float) -> float:
    """Re = rho v D / mu (diameter-based)."""
    return rho * v * D / mu


def artificial_nu(alpha: float, h: float, c0: float, dim: int) -> float:
    """Kinematic viscosity of the artificial viscosity alpha h c0: alpha h c0 / (2 (d + 2))
    [m^2/s] (Monaghan 2005, sec. 4.1); ``h`` is the smoothing length (sphfem: R / 2)."""
    return alpha * h * c0 / (2.0 * (dim + 2))


def effective_reynolds(v: float, D: float, nu: float, nu_art: float = 0.0) -> float:
    """Re_eff = v D / (nu + nu_art): the Reynolds number the SPH fluid behaves like."""
    return v * D / (nu + nu_art)


def disc_spread_ratio(h_over_D):
    """D_disc / D of the droplet's volume spread as a flat disc of thickness h:
    pi D^3 / 6 = pi D_disc^2 h / 4  ->  D_disc / D = sqrt(2 D / (3 h)).

    With h the thinnest lamella a particle method can hold (about one spacing dx), this
    bounds the spreading it can show: sqrt(2 (D / dx) / 3), e.g. 2.83 at D / dx = 12; the
    correlations' beta_max = 6 needs h = D / 54."""
    return np.sqrt(2.0 / (3.0 * np.asarray(h_over_D, float)))


#: residual film thickness h_res = RESIDUAL_FILM D Re^(-2/5) (Roisman 2009)
RESIDUAL_FILM = 0.79
#: particles across the residual film below which the spreading is decided under the spacing
MIN_FILM_PARTICLES = 3.0


def residual_film(D: float, Re: float) -> float:
    """Thickness [m] of the viscous film the spreading leaves on the wall, h_res = 0.79 D
    Re^(-2/5) (Roisman 2009, Phys. Fluids 21, 052104: the film where the viscous
    boundary layer has grown through the whole lamella).

    The lamella never gets thinner than this while it spreads, so a particle run resolves
    the spreading only if h_res spans a few spacings: 2.0 (D/dx 64) / 3.9 (D/dx 128)
    particles for water D = 0.1 mm at 10 m/s (Re 3333), 1.0 / 2.1 at 50 m/s (Re 16667)."""
    if not (D > 0 and Re > 0):
        raise ValueError(f"residual_film: D and Re must be > 0, got D={D!r}, Re={Re!r}")
    return RESIDUAL_FILM * D * Re ** -0.4


def _meridian(r, z, wall_level: float):
    """``r`` and the height above ``wall_level``, ``z - wall_level``, as float arrays of one
    shape (a ValueError otherwise)."""
    r = np.asarray(r, float)
    z = np.asarray(z, float) - wall_level
    if r.shape != z.shape:
        raise ValueError(f"r and z differ in shape: {r.shape} vs {z.shape}")
    return r, z


#: the inviscid lamella at the impact axis, h(0, t) = ETA D / (tau + TAU0)^2 (Roisman,
#: Berberovic & Tropea 2009): the constants fitted to their simulations of a drop on a wall
LAMELLA_ETA = 0.39
LAMELLA_TAU0 = 0.25


def lamella_thickness_inviscid(tau, D: float, eta: float = LAMELLA_ETA,
                               tau0: float = LAMELLA_TAU0):
    """Thickness [m] of the lamella at the impact axis in the inviscid, inertia-dominated
    stage, h(0, t) = eta D / (tau + tau0)^2, tau = t V / D counted from the moment the
    droplet touches the wall (Roisman, Berberovic & Tropea 2009, Phys. Fluids 21, 052103:
    the lamella's flow is the self-similar stretching u_r = r / (t + t0), so its thickness
    falls as 1 / (t + t0)^2; eta = 0.39 and tau0 = 0.25 fitted to their numerical
    simulations).  Independent of We and Re while the viscous boundary layer is thinner
    than the lamella: a remote asymptote, approached once the droplet's body has turned
    into the lamella (in sphfem's axisymmetric runs from tau ~ 0.8: 0.70 / 0.86 / 0.99 of
    it at tau = 0.45 / 0.6 / 0.76, We 30, Re 1000, D/dx 61), and left as the viscous
    layer thickens towards the residual film (:func:`residual_film`), which freezes the
    film above this law."""
    tau = np.asarray(tau, float)
    if not D > 0:
        raise ValueError(f"lamella_thickness_inviscid: D must be > 0, got {D!r}")
    return eta * D / (tau + tau0) ** 2


def centre_thickness(r, z, wall_level: float, dx: float, *, radius: float = 2.0,
                     gap: float = 2.5) -> float:
    """Thickness [m] of the wall-attached fluid at the impact axis: the fluid points
    (``r`` from the axis, ``z`` along the wall normal) within ``radius`` dx of the axis,
    climbed from the lowest (which must lie within 1.5 dx of ``wall_level``, the wall's
    surface) without a vertical gap wider than ``gap`` dx; the height of the topmost one
    above the wall plus dx / 2 (each point stands for a cell dx tall), so k rows on the
    wall read k dx.  0 when the axis is dry (no point there, or none on the wall): a
    hole.  Fluid thrown above a gap (drops over the film) is not counted."""
    r, z = _meridian(r, z, wall_level)
    zz = np.sort(z[np.abs(r) < radius * dx])
    if not len(zz) or zz[0] > 1.5 * dx:
        return 0.0
    jumps = np.flatnonzero(np.diff(zz) > gap * dx)
    top = zz[jumps[0]] if jumps.size else zz[-1]
    return float(top + 0.5 * dx)


# --------------------------------------------------------------------------------------
# correlations


def pasandideh_fard_1996(We, Re, theta_deg: float = 90.0):
    """beta_max = sqrt((We + 12) / (3 (1 - cos theta) + 4 We / sqrt(Re)))
    (Pasandideh-Fard et al. 1996, eq. 7)."""
    We, Re = np.asarray(We, float), np.asarray(Re, float)
    c = 1.0 - math.cos(math.radians(theta_deg))
    return np.sqrt((We + 12.0) / (3.0 * c + 4.0 * We / np.sqrt(Re)))


def ukiwe_kwok_2005(We, Re, theta_deg: float = 90.0):
    """Largest positive root beta of (We + 12) beta = 8 + beta^3 (3 (1 - cos theta)
    + 4 We / sqrt(Re)) (Ukiwe & Kwok 2005); NaN where the cubic has no positive root."""
    We, Re = np.broadcast_arrays(np.asarray(We, float), np.asarray(Re, float))
    c = 1.0 - math.cos(math.radians(theta_deg))
    out = np.full(We.shape, np.nan)
    for idx in np.ndindex(We.shape):
        a = 3.0 * c + 4.0 * We[idx] / math.sqrt(Re[idx])
        roots = np.roots([a, 0.0, -(We[idx] + 12.0), 8.0])
        real = roots[(abs(roots.imag) < 1e-9 * max(1.0, abs(roots).max())) & (roots.real > 0)]
        if real.size:
            out[idx] = real.real.max()
    return out if out.ndim else float(out)


def clanet_2004(We, Re):
    """beta_max = 0.9 We^(1/4) if P = We Re^(-4/5) < 1, else Re^(1/5) (Clanet et al. 2004)."""
    We, Re = np.asarray(We, float), np.asarray(Re, float)
    P = We * Re ** -0.8
    return np.where(P < 1.0, 0.9 * We**0.25, Re**0.2)


def roisman_2009(We, Re):
    """beta_max = 0.87 Re^(1/5) - 0.40 Re^(2/5) We^(-1/2) (Roisman 2009)."""
    We, Re = np.asarray(We, float), np.asarray(Re, float)
    return 0.87 * Re**0.2 - 0.40 * Re**0.4 / np.sqrt(We)


#: fitted constant of the Pade approximant of Laan et al. (2014)
LAAN_A = 1.24


def laan_2014(We, Re):
    """beta_max = Re^(1/5) sqrt(P) / (A + sqrt(P)), P = We Re^(-2/5), A = 1.24
    (Laan et al. 2014)."""
    We, Re = np.asarray(We, float), np.asarray(Re, float)
    sp = np.sqrt(We * Re**-0.4)
    return Re**0.2 * sp / (LAAN_A + sp)


@dataclass(frozen=True)
class Correlation:
    """A published maximum-spreading correlation beta_max(We, Re[, theta])."""

    name: str
    citation: str
    formula: str
    validity: str
    func: Callable
    uses_theta: bool = False

    def __call__(self, We, Re, theta_deg: float = 90.0):
        if self.uses_theta:
            return self.func(We, Re, theta_deg)
        return self.func(We, Re)


CORRELATIONS: dict[str, Correlation] = {c.name: c for c in (
    Correlation("pasandideh-fard-1996",
                "Pasandideh-Fard, Qiao, Chandra & Mostaghimi (1996), Phys. Fluids 8, 650",
                "sqrt((We + 12) / (3 (1 - cos theta) + 4 We / sqrt(Re)))",
                "energy balance; Re >> 1 (boundary layer thinner than the splat), We >> 1",
                pasandideh_fard_1996, uses_theta=True),
    Correlation("ukiwe-kwok-2005", "Ukiwe & Kwok (2005), Langmuir 21, 666",
                "(We + 12) beta = 8 + beta^3 (3 (1 - cos theta) + 4 We / sqrt(Re))",
                "energy balance as Pasandideh-Fard et al., cylindrical splat surface",
                ukiwe_kwok_2005, uses_theta=True),
    Correlation("clanet-2004",
                "Clanet, Beguin, Richard & Quere (2004), J. Fluid Mech. 517, 199",
                "0.9 We^(1/4) for P = We Re^(-4/5) < 1, else Re^(1/5)",
                "scaling laws; capillary regime P < 1, viscous regime P > 1",
                clanet_2004),
    Correlation("roisman-2009", "Roisman (2009), Phys. Fluids 21, 052104",
                "0.87 Re^(1/5) - 0.40 Re^(2/5) We^(-1/2)",
                "semi-empirical; inertia-dominated impacts, Re >> 1 and We >> 1",
                roisman_2009),
    Correlation("laan-2014",
                "Laan, de Bruin, Bartolo, Josserand & Bonn (2014), Phys. Rev. Applied 2, "
                "044018",
                "Re^(1/5) sqrt(P) / (1.24 + sqrt(P)), P = We Re^(-2/5)",
                "interpolates the capillary (We^(1/2) / A, P << A^2) and viscous "
                "(Re^(1/5), P >> A^2) limits; A = 1.24 fitted to experiments",
                laan_2014),
)}


def correlation_table(We: float, Re: float, theta_deg: float = 90.0) -> dict[str, float]:
    """beta_max of every correlation at (We, Re, theta)."""
    return {name: float(c(We, Re, theta_deg)) for name, c in CORRELATIONS.items()}


# --------------------------------------------------------------------------------------
# measurement


def _contact_layer(x, wall_level, dx, kind, axis, within):
    """Lateral coordinates of the fluid rows with -dx/2 <= height < within dx."""
    x = np.asarray(x, float)
    if x.ndim != 2:
        raise ValueError(f"x: expected an (n, dim) array, got shape {x.shape}")
    axis = axis % x.shape[1]
    sel = np.ones(len(x), bool) if kind is None else (np.asarray(kind) == FLUID_KIND)
    height = x[:, axis] - wall_level
    sel &= (height >= -0.5 * dx) & (height < within * dx)
    return np.delete(x[sel], axis, axis=1)


def _largest_cluster(lateral, link):
    """Rows of the largest group of points joined by links shorter than ``link``
    (:func:`main_body` counting points)."""
    return lateral[main_body(lateral, link)]


def main_body(x, link: float, weights=None):
    """Mask of the main body of a fluid: the connected group of points (joined by links
    shorter than ``link``, in the units of ``x``) with the largest total weight (``weights``,
    e.g. the particles' or rings' masses; default 1 each).  What lies outside it has broken
    off: drops, spray, shed rings."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    x = np.asarray(x, float)
    n = len(x)
    if n == 0:
        return np.zeros(0, bool)
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    if w.shape != (n,):
        raise ValueError(f"weights: expected shape ({n},), got {w.shape}")
    pairs = cKDTree(x).query_pairs(link, output_type="ndarray")
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    return labels == np.argmax(np.bincount(labels, weights=w))


#: particles within this many spacings of each other belong to one body (main_body)
BODY_LINK = 2.0


def body_contact_diameter(r, z, wall_level: float, dx: float, mass=None, *,
                          link: float = BODY_LINK) -> tuple[float, float]:
    """The main body's wetted diameter [m] and the mass fraction broken off from it, of an
    axisymmetric fluid (``r`` from the impact axis, ``z`` along the wall normal, ``mass``
    the rings' masses): the body is :func:`main_body` with links of ``link`` dx; its
    diameter is 2 (r_e + dx / 2), r_e its outermost ring within 1.5 dx above
    ``wall_level`` (the wall's surface); (0, fraction) when the body does not touch the
    wall.  This is the maximum-spreading measure of experiments (the lamella's own rim,
    not satellite drops): rings shed from the rim and stray rings that slide out on the
    wall ahead of it do not count, whatever their spacing along the wall."""
    r, z = _meridian(r, z, wall_level)
    if not len(r):
        return 0.0, 0.0
    m = np.ones(len(r)) if mass is None else np.asarray(mass, float)
    body = main_body(np.c_[r, z], link * dx, m)
    detached = float(m[~body].sum() / m.sum())
    wet = body & (z < 1.5 * dx)
    if not wet.any():
        return 0.0, detached
    return float(2.0 * (r[wet].max() + 0.5 * dx)), detached


def contact_diameter(x, wall_level: float, dx: float, kind=None, *, axis: int = -1,
                     within: float = 1.0, center=None, link: float | None = None) -> float:
    """Wetted diameter of one frame [m]: 2 (max_i r_i + dx / 2) over the fluid particles i
    with -dx/2 <= (x_i[axis] - wall_level) < within dx, r_i their distance from the impact
    axis.

    ``x``: (n, dim) positions; ``kind``: particle kinds (only FLUID rows count; None: all
    rows are fluid); ``wall_level``: the wall surface along ``axis`` (the normal, pointing
    into the fluid); ``center``: the impact axis' position in the other coordinates
    (default: the mean of the counted particles).  ``link`` (in units of dx): count only
    the largest sheet of wall-layer particles joined by gaps shorter than link dx, which
    leaves out single particles and fingers that have broken off the lamella.  0 when no
    fluid particle touches the wall.  In 2D the "diameter" is the wetted length.
    """
    lateral = _contact_layer(x, wall_level, dx, kind, axis, within)
    if not len(lateral):
        return 0.0
    if link is not None and len(lateral) > 1:
        lateral = _largest_cluster(lateral, link * dx)
    c = lateral.mean(axis=0) if center is None else np.asarray(center, float)
    r = np.sqrt(((lateral - c) ** 2).sum(axis=1))
    return float(2.0 * (r.max() + 0.5 * dx))


def area_diameter(x, wall_level: float, dx: float, kind=None, *, axis: int = -1,
                  within: float = 1.0) -> float:
    """Diameter of the disc with the wetted area [m]: each fluid particle of the wall layer
    (as in :func:`contact_diameter`) wets dx^(d-1), so A = N dx^2 and D = 2 sqrt(A / pi)
    in 3D (in 2D the wetted length N dx).  Unlike the contact line it does not grow when
    the lamella breaks into scattered particles."""
    lateral = _contact_layer(x, wall_level, dx, kind, axis, within)
    n = len(lateral)
    if lateral.shape[1] == 1:
        return float(n * dx)
    return float(2.0 * math.sqrt(n * dx * dx / math.pi))


def lamella_root_radius(r, z, wall_level: float, dx: float, min_thickness: float, *,
                        bin_width: float = 2.0, gap: float = 2.5) -> float:
    """Radius of the lamella's root [m]: where the droplet's body ends and the thin sheet
    ejected along the wall begins (the turnover point of Wagner's theory, whose radius is
    sqrt(3 R V t) early in the impact; Riboux & Josserand 2014, Phys. Rev. Lett. 113,
    024507, measured this root, not the sheet's tip).

    The fluid points (``r`` from the impact axis, ``z`` along the wall normal) are binned
    in r over ``bin_width`` dx; a bin's wall-attached thickness is the height of the
    topmost point reached from its lowest point (which must lie within 1.5 dx of
    ``wall_level``) without a vertical gap wider than ``gap`` dx.  The root is the
    outermost point (+ dx / 2) of the last bin, walking out from the axis, whose thickness
    is at least ``min_thickness`` [m] (a length between the lamella's thickness and the
    body's height, e.g. R / 10 early in the impact); 0 when the first bin is already
    thinner.  Where the body overhangs the sheet in a wedge of air (a sphere meeting the
    wall), the root is found where the wedge is wider than ``gap`` dx: it converges to the
    contact point as dx -> 0.
    """
    r, z = _meridian(r, z, wall_level)
    if not len(r):
        return 0.0
    w = bin_width * dx
    b = np.floor(r / w).astype(np.int64)
    order = np.lexsort((z, b))  # by bin, then by height
    b, z, r = b[order], z[order], r[order]
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    ends = np.r_[starts[1:], len(b)]
    edge = 0.0
    for k, (s, e) in enumerate(zip(starts, ends, strict=True)):
        if b[s] != k:  # an empty bin: the body has ended
            break
        zz = z[s:e]
        if zz[0] > 1.5 * dx:  # nothing on the wall here
            break
        jumps = np.flatnonzero(np.diff(zz) > gap * dx)
        top = zz[jumps[0]] if jumps.size else zz[-1]
        if top < min_thickness:
            break
        edge = float(r[s:e].max()) + 0.5 * dx  # each point stands for a cell dx wide
    return float(edge)


def wendland_c2_2d(d, R: float):
    """Planar Wendland C2 kernel with support radius R (Wendland 1995):
    W = 7 / (pi R^2) (1 - q)^4 (1 + 4 q), q = d / R < 1; it integrates to 1 over the plane."""
    q = np.minimum(np.asarray(d, float) / R, 1.0)
    return 7.0 / (math.pi * R * R) * (1.0 - q) ** 4 * (1.0 + 4.0 * q)


def wall_colour(rs, r, z, area, wall_level: float, R: float, axis_mirror: bool = True):
    """Colour of the fluid on the wall line at radii ``rs``: with the fluid mirrored in the
    wall plane (and, if ``axis_mirror``, in the axis r = 0), c(s) = 2 sum_j A_j W(|(s - r_j,
    z_j - z_w)|) (+ the axis images), A_j the meridian area of ring j (planar: its area).
    c = 1 under fluid at least R thick, 1/2 where a straight edge normal to the wall meets it."""
    rs = np.atleast_1d(np.asarray(rs, float))
    dz2 = (np.asarray(z, float) - wall_level) ** 2
    r = np.asarray(r, float)
    area = np.broadcast_to(np.asarray(area, float), r.shape)
    out = np.empty(rs.shape)
    for k in range(0, len(rs), 256):
        s = rs[k:k + 256, None]
        w = wendland_c2_2d(np.sqrt((s - r) ** 2 + dz2), R)
        if axis_mirror:
            w = w + wendland_c2_2d(np.sqrt((s + r) ** 2 + dz2), R)
        out[k:k + 256] = 2.0 * (w * area).sum(axis=1)
    return out


def colour_contact_radius(r, z, area, wall_level: float, R: float, *,
                          axis_mirror: bool = True, level: float = 0.5) -> float:
    """Contact-line radius [m]: the outermost s where the wall colour c(s)
    (:func:`wall_colour`) falls through ``level`` = 1/2; 0 if it never reaches it.

    ``r``, ``z``: the fluid's meridian (or planar: lateral, normal) coordinates; ``area``:
    A_j = M_j / (2 pi r_j rho_j) (planar: the particle areas); ``R``: the measuring kernel's
    support radius (e.g. 3 dx).  For fluid meeting the wall at 90 degrees c(edge) = 1/2 up
    to the lattice-sum error of the kernel, so the radius carries no O(dx) offset (unlike
    max r_i + dx / 2 of the wall row, which depends on where the last particle sits); at a
    contact angle theta the wedge and its mirror cover theta / pi of the support at the tip,
    which moves the crossing by O(R) (inwards for theta < 90 degrees).  A film thinner than
    about R / 5 reads as dry (c < 1/2)."""
    r = np.asarray(r, float)
    z = np.asarray(z, float)
    near = np.abs(z - wall_level) < R
    if not near.any():
        return 0.0
    r, z = r[near], z[near]
    area = np.broadcast_to(np.asarray(area, float), near.shape)[near]
    ds = R / 16.0
    grid = np.arange(0.0, r.max() + R + ds, ds)
    c = wall_colour(grid, r, z, area, wall_level, R, axis_mirror) - level
    down = np.flatnonzero((c[:-1] >= 0.0) & (c[1:] < 0.0))
    if not len(down):
        return 0.0
    from scipy.optimize import brentq

    i = down[-1]
    return float(brentq(lambda s: wall_colour(s, r, z, area, wall_level, R, axis_mirror)[0]
                        - level, grid[i], grid[i + 1], xtol=1e-12 * R))


@dataclass(frozen=True)
class Spreading:
    """Wetted diameter history and its maximum."""

    times: np.ndarray      # s
    diameters: np.ndarray  # m
    D: float               # droplet diameter [m]

    @property
    def index(self) -> int:
        return int(np.argmax(self.diameters))

    @property
    def d_max(self) -> float:
        return float(self.diameters[self.index])

    @property
    def beta_max(self) -> float:
        """D_max / D."""
        return self.d_max / self.D

    @property
    def t_max(self) -> float:
        """Time of the maximum [s]."""
        return float(self.times[self.index])

    @property
    def at_end(self) -> bool:
        """The maximum is the last frame (the run may have stopped before it)."""
        return self.index == len(self.diameters) - 1


def max_spreading(frames: Iterable, D: float, wall_level: float, dx: float,
                  **kw) -> Spreading:
    """Wetted diameter of each frame ``(t, x, kind)`` and its maximum over time
    (keywords as :func:`contact_diameter`)."""
    ts, ds = [], []
    for t, x, kind in frames:
        ts.append(float(t))
        ds.append(contact_diameter(x, wall_level, dx, kind, **kw))
    if not ts:
        raise ValueError("max_spreading: no frames")
    return Spreading(np.asarray(ts), np.asarray(ds), float(D))


def read_frames(folder, name: str = "particles", dim: int = 3):
    """Yield ``(t, x, kind)`` of each frame of a particle series (``folder/name.pvd``, as
    :class:`sphfem.output.ParticleSeries` writes it; ``kind`` must be among the written
    fields); positions are cut to the scene's dimension ``dim``."""
    import meshio

    from sphfem.output import pvd_frames

    for t, path in pvd_frames(Path(folder) / f"{name}.pvd"):
        mesh = meshio.read(path)
        if "kind" not in mesh.point_data:
            raise ValueError(f"{path.name}: no 'kind' field (add \"kind\" to [output] "
                             f"fields)")
        x = np.asarray(mesh.points, float)[:, :dim]
        yield t, x, np.asarray(mesh.point_data["kind"]).ravel().astype(int)
