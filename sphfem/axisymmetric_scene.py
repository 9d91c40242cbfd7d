"""Axisymmetric scenes (``[scene] geometry = "axisymmetric"``): the fluid and heat modules.

A scene with ``geometry = "axisymmetric"`` and ``dim = 2`` is a body of revolution about the
z axis in the meridian half-plane (r, z), r >= 0 (:mod:`sphfem.axisymmetric`).  The driver
is the ordinary one (:mod:`sphfem.simulation`); the geometry flag changes three things:

* particles (:func:`build_ring_particles`): each lattice point of a block with r > 0 is a
  ring of meridian area A = dx^2 (the block's spacing); its ``vol`` = 2 pi r A [m^3] and
  ``m`` = rho0 2 pi r A [kg] (the ring mass; Petschek & Libersky 1993, Garcia-Senz &
  Relano-Pastor 2012), so the summary's masses, the coupling's heat ledger and the
  fem-contact interface (which take ``m`` and ``vol``) see the whole ring;
* the registry (:func:`sphfem.physics.build_modules`) builds the axisymmetric class of a
  module where one is registered for the geometry: ``fluid`` ->
  :class:`AxisymmetricFluidModule`, ``heat`` -> :class:`AxisymmetricHeatModule`;
* the ``coupling`` module takes ``backend = "fem-axisymmetric"``
  (:mod:`coupling.axisymmetric_scene`).

Both modules keep their own neighbour lists: the planar sums need the mirror particles
across the axis (and the fluid's per-particle support radii), which the driver's list does
not hold; they therefore set ``moves_particles = False`` (the driver neither rebuilds nor
sorts its list; nothing reads it in such a scene).

Fluid (:class:`AxisymmetricFluidModule`): :class:`sphfem.fluid.axisymmetric.AxisymmetricFluid`
with the scene's wall particles as its Adami walls (free-slip ghost of the wall plane in the
continuity, normals from the nearest face of each wall box; Shepard-averaged hoop term;
h ~ sqrt(A) as in ``examples/axisymmetric/droplet_crosscheck.py``); the kinematic
no-penetration correction of :mod:`sphfem.fluid.no_penetration` (rings that crossed the
wall surface are put back on it and lose their inward normal velocity) is on
(``AxisymmetricFluidModule.no_penetration``: without it the droplet job fails at
D/dx >= 32).  The force of the fluid
on each wall particle (``f_fluid``, the coupling's sensors) is the ring force

    F_w = - sum_i M_i a_(i<-w)                                                           (1)

over the fluid rings i (and their axis mirrors, which carry the same ring mass) of the
pressure, viscous and artificial-viscosity pair accelerations a_(i<-w) that wall particle w
gives fluid i in the last force evaluation (the one of the step's velocity update); M_i the
ring mass, so F_w is the total force on the ring of w [N] (the backend's "ring" convention)
and sum_w F_w,z is the net axial force on the substrate, minus the rate of change of the
fluid's axial momentum through the walls.  The no-penetration correction's normal momentum
goes to the wall too: a ring whose velocity the correction changed by dv (the step's end
velocity minus v_n + dt a) gives the wall particle nearest to it - M_i (dv . n) n / dt, n
the wall normal there, so the walls' impulse still balances the fluid's axial momentum.

Heat (:class:`AxisymmetricHeatModule`): eq. (1) of :mod:`sphfem.heat.axisymmetric`,

    M_i c_i dT_i/dt = sum_j 2 pi A_i A_j k_ij (r_i + r_j) F_ij (T_j - T_i),

Cleary's harmonic k_ij, over fluid and wall rings and the even axis ghosts, with
A_i = m_i / (2 pi r_i rho_i); pairwise symmetric, so sum_i m_i c_i T_i is conserved to
round-off (``energy_residual_J``).  Explicit Heun at ``[heat] cfl`` times the Gershgorin
limit; the list holds the rings with k > 0 only (a ring with k = 0, such as the wall of
``[coupling.heat] model = "fem-contact"``, has k_ij = 0 with every neighbour) and is kept
with a Verlet skin as the fluid's (``AxisymmetricFluidModule.SKIN``; the same rates to the
bit).
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from sphfem import kernels
from sphfem.fluid.axisymmetric import MIRROR_FLUID
from sphfem.fluid.spreading import MIN_FILM_PARTICLES, residual_film
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID, GHOST, WALL, ParticleSet
from sphfem.physics import PhysicsModule

logger = logging.getLogger(__name__)

__all__ = ["AxisymmetricFluidModule", "AxisymmetricHeatModule", "build_ring_particles",
           "ring_areas", "wall_ring_forces"]

TWO_PI = 2.0 * math.pi


#: the guards' domain box in (r, z): none (a ring outside the scene's box is counted, not
#: stopped), no periodic axis
_NO_BOX_LO, _NO_BOX_HI, _NO_PERIOD = np.full(2, -np.inf), np.full(2, np.inf), np.zeros(2)


def is_axisymmetric(scene) -> bool:
    return getattr(scene, "geometry", "cartesian") == "axisymmetric"


def build_ring_particles(scene) -> ParticleSet:
    """The blocks of an axisymmetric ``scene`` as rings (module docstring): the points of
    each block (:func:`sphfem.geometry.build_particles`) with r > 0, with ``vol`` = 2 pi r A
    and ``m`` = rho0 ``vol``; the meridian area A is dx_b^2 for a lattice (dx_b: the
    block's spacing) and the point's share of its circle's annulus for ``sampling =
    "shells"`` (:func:`sphfem.geometry.shell_areas`; the areas sum to the half-disc's)."""
    from sphfem.geometry import Shape, block_points, build_particles, shell_areas

    ps = build_particles(scene)
    areas = []
    for i, b in enumerate(scene.blocks):
        xb = block_points(scene, i)
        dxb = b.dx if b.dx is not None else scene.sph.dx
        if b.sampling == "shells":
            areas.append(shell_areas(xb, Shape.from_block(b, 2), dxb))
        else:
            areas.append(np.full(xb.shape[0], dxb * dxb))
    area = np.concatenate(areas)
    keep = ps.x[:, 0] > 0.0
    out = ps.select(keep)
    ring = TWO_PI * out.x[:, 0] * area[keep]
    out.vol[:] = ring
    out.m[:] = out.rho * ring
    return out


def ring_areas(ps) -> np.ndarray:
    """Meridian areas A = m / (2 pi r rho) [m^2] of the rings of ``ps``."""
    return ps.m / (TWO_PI * ps.x[:, 0] * ps.rho)


@njit(cache=True, parallel=True)
def wall_ring_forces(x, v, vg, rho, p, mt, mu, kind, offsets, indices, Rp, s2, kcode, eps,
                     alpha_c, fw, wall_art, out):
    """Eq. (1) of the module docstring for the real WALL rows of the fluid's augmented set
    (``kind`` WALL = real wall, fluid-like = FLUID or its mirrors MIRROR_FLUID): ``out[w]`` the
    ring force [N] of wall w; the pair terms are those of
    :func:`sphfem.fluid.axisymmetric.forces` seen from the fluid particle (its wall-layer
    factor ``fw[i]`` on the viscous term, ``wall_art`` on the artificial viscosity)."""
    for w in prange(x.shape[0]):
        out[w, 0] = 0.0
        out[w, 1] = 0.0
        if kind[w] != WALL:
            continue
        f0 = 0.0
        f1 = 0.0
        for jj in range(offsets[w], offsets[w + 1]):
            i = indices[jj]
            if kind[i] != FLUID and kind[i] != MIRROR_FLUID:
                continue
            r0 = x[w, 0] - x[i, 0]  # x_j - x_i with j = the wall
            r1 = x[w, 1] - x[i, 1]
            d2 = r0 * r0 + r1 * r1
            R = 0.5 * (Rp[i] + Rp[w])
            if d2 >= R * R or d2 == 0.0:
                continue
            hij = 0.5 * R
            d = math.sqrt(d2)
            F = -s2 / (R * R * R) * kernels.kernel_dfdq(d / R, kcode) / d
            ri = rho[i]
            rw = rho[w]
            mj = mt[w]
            cp = -mj * (p[i] / (ri * ri) + p[w] / (rw * rw)) * F
            rs = ri + rw
            inv = 1.0 / ((d2 + eps * hij * hij) * rs * rs)
            cv = 4.0 * (mu[i] + mu[i]) * mj * F * d2 * inv * fw[i]
            u0 = vg[w, 0] - v[i, 0]
            u1 = vg[w, 1] - v[i, 1]
            cp += 2.0 * wall_art * alpha_c * hij * mj * F * (u0 * r0 + u1 * r1) * rs * inv
            M = TWO_PI * abs(x[i, 0]) * mt[i]
            f0 -= M * (cp * r0 + cv * u0)
            f1 -= M * (cp * r1 + cv * u1)
        out[w, 0] = f0
        out[w, 1] = f1


def _max_move(x, x0) -> float:
    """max_i |x_i - x0_i|."""
    d = x - x0
    return math.sqrt(float(np.max(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1], initial=0.0)))


def box_wall_normals(scene, x, kind) -> np.ndarray | None:
    """Outward unit normals (n, 2) of the wall particles: the normal of the nearest
    *exposed* face of the wall box block holding the particle, a face being exposed when
    the half-plane outside it meets the bounding box of a fluid block (so every layer of a
    layered wall takes the normal of the face the fluid sees; faces on the axis r = 0 are
    never exposed); zero rows for other kinds.  None when a wall particle lies in no box
    block or its block has no exposed face."""
    from sphfem.geometry import Shape

    fluid = [Shape.from_block(b, 2).bounds() for b in scene.blocks if b.kind == "fluid"]
    table = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])
    nrm = np.zeros_like(x)
    w = np.flatnonzero(kind == WALL)
    done = np.zeros(w.size, bool)
    for b in scene.blocks:
        if b.kind != "wall" or b.shape != "box":
            continue
        lo, hi = np.asarray(b.lo, float), np.asarray(b.hi, float)
        # faces r = lo, r = hi, z = lo, z = hi: exposed if some fluid box lies beyond them
        exposed = np.array([lo[0] > 0 and any(flo[0] < lo[0] for flo, _ in fluid),
                            any(fhi[0] > hi[0] for _, fhi in fluid),
                            any(flo[1] < lo[1] for flo, _ in fluid),
                            any(fhi[1] > hi[1] for _, fhi in fluid)])
        xs = x[w]
        inside = np.all((xs >= lo - 1e-12) & (xs <= hi + 1e-12), axis=1) & ~done
        if not inside.any() or not exposed.any():
            continue
        xs = xs[inside]
        dist = np.column_stack([xs[:, 0] - lo[0], hi[0] - xs[:, 0], xs[:, 1] - lo[1],
                                hi[1] - xs[:, 1]])
        dist[:, ~exposed] = np.inf
        nrm[w[inside]] = table[np.argmin(dist, axis=1)]
        done[inside] = True
    return nrm if done.all() else None


class AxisymmetricFluidModule(PhysicsModule):
    """The ``fluid`` module of an axisymmetric scene (module docstring).

    Parameters from ``[fluid]`` (:func:`sphfem.fluid.wcsph.params_from_scene`): rho0, c0,
    gamma, mu, delta, alpha, gravity (g_r, g_z: g_r must be 0), cfl, eps_visc, cond_max.
    Surface tension: ``surface_tension = "csf"`` is the CSF force with the hoop curvature
    (:mod:`sphfem.fluid.axisymmetric_surface_tension`, sigma from the material); the other
    models are refused.
    Writes ``x``, ``v``, ``rho``, ``p``, ``vol`` (= m / rho, ring volume) of the fluid and
    ``f_fluid`` (ring forces, eq. 1) of the walls after every step.
    """

    name = "fluid"
    #: the records a resumed run continues (the spread history, the walls' impulse since
    #: t = 0, the deepest ring, the breach time; the solver state is in the particles)
    checkpoint_attrs = ("spread", "mom0", "impulse", "t0", "max_depth", "t_breach",
                        "correction_impulse", "_next_spread", "spread_every", "t_escape",
                        "rho_ratio_extremes")
    moves_particles = False  # it moves the fluid, but with its own list (module docstring)
    #: a ring deeper than this [dx] below the wall top has entered the second wall layer:
    #: its time is reported (``t_wall_breach_s``); one below the wall stops the run
    BREACH_DX = 2.0
    #: the kinematic no-penetration correction of the position update (module docstring).
    #: Droplet job (50 m/s, 4 tc) without it: rings sink into the wall layers, a ring more
    #: than 2 dx deep at 3.75 / 0.74 / 0.35 tc for dx = 6.25 / 3.125 / 1.5625 um and through
    #: the wall soon after; with it at 3.125 um: to 4 tc, no ring below the wall top, the
    #: axial momentum budget closed to 0.6 %
    no_penetration = True
    #: the free-surface and wall treatment of the (r, z) fluid (AxisymmetricFluid's keywords;
    #: examples/axisymmetric/robustness_results.md): fixed h (h from the ring's own area
    #: threw first-column rings out at D/dx = 32), surface rings held at rho >= rho0.  With
    #: ``[fluid] shifting`` the impact at 50 m/s, D/dx = 32 runs calm to 4 tc.
    #: The wall's extrapolated pressure keeps its sign (``wall_tension=True``): clipping it
    #: at 0 (2026-12-02, before the surface hold existed, when tension copied from the
    #: lamella's tip pulled rings into the wall) left nothing holding the axis-wall corner
    #: down; its rings lifted 1-2 dx off the wall at 0.8-1.1 t_c (10 m/s, D/dx 181), the
    #: corner "boiled" and the coarse levels spread too far.  With the sign kept, the 10 m/s
    #: levels D/dx 64 / 90 / 128 give heat 51.7 / 52.5 / 50.1 uJ, rise 18.70 / 18.42 / 18.46
    #: K, peak von Mises 54.9 / 53.9 / 54.8 MPa, D_max/D 3.67 / 3.61 / 3.41 (clipped: 61.8 /
    #: 49.4 / 49.7 uJ, 19.65 / 19.60 / 18.35 K, 59.6 / 61.8 / 61.9 MPa, 4.45 / 3.45 / 3.43;
    #: docs/validation/droplet_impact/README.md, session 26)
    #: Fragments (lambda_min < renorm_lambda_min: isolated rings, one-ring sheets) carry no
    #: hoop term in their continuity (``fragment_hoop=False``): a free ring has no
    #: neighbour to show the meridional spreading that balances -rho v_r / r, so with it
    #: rho r = const.  In the 10 m/s impact at D/dx 181 a spray ring bouncing near the axis
    #: reached 2.4 rho0 (p ~ 1e3 rho V^2), fell onto the lamella at ~1.9 t_c and blew its
    #: centre open (the impact point dried at 2.3 t_c; rings of 7e10 Pa by 2.4 t_c).
    #: The CSF's axis band takes its curvature from the band's edge (``csf_axis_curvature``;
    #: examples/axisymmetric/csf_axis_noise.py): without it the distorted colour gradient
    #: next to the axis pulled the lamella's centre inwards from ~2.1 t_c and opened a dry
    #: hole at the impact point by 2.7 t_c (10 m/s, D/dx 90; 3.2 t_c at 128); with it the
    #: impact point stayed wetted to 4 t_c at D/dx 90 (a gap opened next to it at 3.4 t_c),
    #: but at 128 it dried at 2.95 t_c: a partial fix (the interior rings next to the axis
    #: keep a spurious pull).  The CSF's curvature is averaged along the surface over two
    #: supports (``csf_curvature_smoothing``): its response to particle disorder grows as
    #: 1 / dx, and ring waves of that noise converge on the axis; without the average the
    #: centre of the 10 m/s lamella flowed inwards and broke up from 2.0-2.6 t_c at D/dx 90
    #: and 128 (and 181), with it the centre stays whole to 4 t_c at 128 (session 13,
    #: docs/validation/droplet_impact/README.md)
    fluid_options = {"adaptive_h": False, "wall_tension": "contact-line",
                     "free_surface_no_tension": True, "fragment_hoop": False,
                     "csf_axis_curvature": True, "csf_curvature_smoothing": 2.0,
                     "bulk_damping": 0.5, "debris_rings": 16}
    # bulk_damping: the acoustic damper (sphfem.fluid.axisymmetric.AxisymmetricFluid).  The
    # delta term leaves smooth fields alone, so the impact's acoustic waves rang through the
    # lamella undamped: +-1 rho V^2 at 1 t_c in the 10 m/s impact at D/dx 181 (c0 = 10 V),
    # focused on the axis, where they threw surface rings off (debris at 1.5-2.25 t_c).
    # With 0.5 the field is the smooth stagnation flow's (docs/validation/droplet_impact,
    # session 27); its bulk stress is ~0.5 (h / c0) / T of the pressure of a flow changing
    # over T (0.4 % at D/dx 181 for T = 0.1 t_c), and it vanishes with h; the scene keys
    # fluid.bulk_damping (alpha_b, replaces this 0.5) and fluid.bulk_damping_length (a floor
    # l under h: nu_b = alpha_b c0 max(h, l)) change it per scene
    # wall_tension "contact-line": the walls keep the fluid's tension (the axis corner, a thin
    # film) except under a contact line, where the wall's suction held the foot back: with
    # the tension everywhere the 10 m/s contact line stalled at D/dx 181 from 0.8 t_c
    # (D_max/D 2.58); with it clipped there 3.61, and 3.70 / 3.52 / 3.24 at 64 / 90 / 128
    # (docs/validation/droplet_impact, session 28)
    # debris_rings: free-flying clusters of at most 16 rings (no ring of them with a full
    # support) become inert (sphfem.fluid.axisymmetric_debris): a two-ring torus thrown off
    # the rim of the 10 m/s impact at D/dx 181 reached the axis at 2.58 t_c and blew up
    # there (5 rho0, 1.7e4 m/s; docs/validation/droplet_impact, session 28).  Inert rings
    # also leave the heat (k_heat = 0, their temperature kept) and the contact interface
    #: the AxisymmetricFluid keywords this module sets itself, from scene keys (e.g.
    #: ``fluid.shifting``) and its class constants; the solver's other keywords come from
    #: ``fluid_options`` (tests/test_level_run_options.py holds the two sets to the call)
    SCENE_KEYWORDS = frozenset({
        "kernel", "wall_normals", "smooth_hoop", "no_penetration", "surface_tension",
        "shifting", "shift_surface", "shift_speed", "skin", "shift_surface_lambda",
        "shift_drift", "wall_friction", "film_tension", "axis_floor", "stress_plane",
        "contact_line_slip", "contact_line_slip_length", "wall_slip", "slip_length",
        "csf_meridian", "bulk_damping_length"})
    #: rings are kept at r >= AXIS_FLOOR_DX dx (the fluid's spacing; the lattice's first
    #: column sits at dx / 2): next to the axis a ring's meridian area grows as 1 / r and its
    #: mirror hardly repels it; without the floor the apex ring of the 10 m/s droplet at
    #: D/dx 181 reached r = 0.12 dx and the run blew up at 0.98 t_c
    #: (:mod:`sphfem.fluid.axisymmetric`, "Axis"; docs/validation/droplet_impact, session 21)
    AXIS_FLOOR_DX = 0.25
    #: Verlet skin of the fluid's (and the heat's) neighbour list, as a fraction of R: the
    #: list reaches R (1 + SKIN) and is rebuilt only when a ring has moved R SKIN / 2.
    #: Every pair kernel skips pairs beyond its support and list rows are sorted by index,
    #: so the figures are those of a list rebuilt at every step, to the bit
    SKIN = 0.15

    def __init__(self, scene):
        from sphfem.fluid.wcsph import params_from_scene

        super().__init__(scene)
        self.params = params_from_scene(scene)
        if self.params.pressure != "wcsph":
            raise ValueError(f'fluid: pressure = "{self.params.pressure}" is not available '
                             'with geometry = "axisymmetric" (only "wcsph")')
        if self.params.rheology != "newtonian":  # its force pass has no mu(gamma_dot)
            raise ValueError(f'fluid: rheology = "{self.params.rheology}" is not available '
                             'with geometry = "axisymmetric" (only "newtonian")')
        if self.params.surface_tension not in ("none", "csf"):
            raise ValueError(f'fluid: surface_tension = "{self.params.surface_tension}" is '
                             'not available with geometry = "axisymmetric"; set "csf" (with the '
                             'hoop curvature) or "none"')
        #: sigma of the axisymmetric CSF (0: off)
        self.sigma_st = (float(self.params.sigma) if self.params.surface_tension == "csf"
                         else 0.0)
        if abs(float(np.asarray(self.params.gravity, float).reshape(-1)[0])) > 0.0:
            raise ValueError("fluid: an axisymmetric scene takes gravity along z only "
                             "(gravity[0] = 0)")
        self.solver = None
        self.spread: list[list[float]] = []
        #: axial momentum at t = 0 and the walls' impulse since (a resumed run takes them,
        #: and the spread history, from the checkpoint: ``checkpoint_attrs``)
        self.mom0, self.impulse, self.t0 = None, 0.0, 0.0
        self.max_depth = -math.inf
        #: first time a fluid ring lay more than BREACH_DX below the wall top (None: never)
        self.t_breach = None
        #: the first time a fluid ring was outside the domain box (None: never)
        self.t_escape = None
        #: the active rings' lowest and highest rho / rho0 over the run and their times
        #: ([min, t_min, max, t_max]; None before the first step; reported, and bounded
        #: by the guard's band)
        self.rho_ratio_extremes = None
        #: the domain box's corners
        self._domain = (np.asarray(scene.domain.lo, float), np.asarray(scene.domain.hi, float))

    def _options(self) -> dict:
        """``fluid_options`` with the scene's ``csf_meridian``, ``bulk_damping`` (when
        set) and ``bulk_damping_length``."""
        fl = self.scene.fluid
        opts = {**self.fluid_options, "csf_meridian": fl.csf_meridian,
                "bulk_damping_length": fl.bulk_damping_length}
        if fl.bulk_damping is not None:
            opts["bulk_damping"] = fl.bulk_damping
        return opts

    def fields(self):
        f = np.float64
        return {"v": (f, 2), "p": (f, 1), "f_fluid": (f, 2)}

    @staticmethod
    def _wall_top(x, kind, A):
        """The z of the walls' top face (the top row plus half its spacing; None without
        walls): the symmetry plane of ``csf_meridian = "stress"``."""
        wl = kind == WALL
        if not wl.any():
            return None
        return float(x[wl, 1].max() + 0.5 * np.sqrt(np.median(A[wl])))

    def init(self, ctx) -> None:
        from sphfem.fluid.axisymmetric import AxisymmetricFluid

        ps = ctx.particles
        self.idx = idx = np.flatnonzero((ps.kind == FLUID) | (ps.kind == WALL))
        kind = ps.kind[idx]
        x = ps.x[idx]
        A = ring_areas(ps)[idx]
        nrm = box_wall_normals(self.scene, x, kind)
        dxf = [b.dx or self.scene.sph.dx for b in self.scene.blocks if b.kind == "fluid"]
        self.solver = AxisymmetricFluid(
            x, ps.v[idx], ps.rho[idx], kind, np.where(kind == FLUID, ps.m[idx], 0.0), A,
            ctx.R, self.params, kernel=self.scene.sph.kernel,
            wall_normals=nrm, smooth_hoop=True, no_penetration=self.no_penetration,
            surface_tension=self.sigma_st,
            shifting=(self.params.shifting_coef if self.params.shifting != "none" else 0.0),
            shift_surface=self.params.shifting == "all",
            shift_speed=self.params.shifting_speed, skin=self.SKIN,
            shift_surface_lambda=self.params.shifting_surface_lambda,
            shift_drift=self.params.shifting_drift,
            wall_friction=self.scene.fluid.wall_friction,
            film_tension=self.scene.fluid.film_tension,
            contact_line_slip=self.scene.fluid.contact_line == "slip",
            contact_line_slip_length=(self.scene.fluid.contact_line_slip_length
                                      if self.scene.fluid.contact_line == "cox-voinov"
                                      else 0.0),
            wall_slip=self.scene.fluid.wall_slip, slip_length=self.scene.fluid.slip_length,
            axis_floor=self.AXIS_FLOOR_DX * float(dxf[0]),
            stress_plane=self._wall_top(x, kind, A), **self._options())
        self.nrm = nrm
        wl = np.flatnonzero(kind == WALL)
        self._walls = wl
        self._wall_tree = cKDTree(x[wl]) if wl.size else None
        self.correction_impulse = 0.0
        # h_i ~ sqrt(A_i / a_ref): a_ref the lattice's meridian area dx^2 (the median of the
        # areas at t = 0), not the median at this init, so a resumed run takes the same
        self.solver.a_ref = float(dxf[0]) ** 2
        self.solver.evaluate()
        self.solver.t = ctx.t
        self.solver.step_count = ctx.step
        self.fl = kind == FLUID
        self._fl_rows = np.flatnonzero(self.fl)
        # the floor: the wall particles whose exposed face is a top face (normal +e_z)
        floor = np.zeros(len(x), bool) if nrm is None else (kind == WALL) & (nrm[:, 1] > 0.5)
        walls = x[floor]
        self.dx = float(self.scene.sph.dx)
        if self.sigma_st > 0.0:  # c0 against the capillary pressure at the kernel's scale
            from sphfem.sound_speed import capillary_warning

            text = capillary_warning(self.params.c0, self.sigma_st, self.params.rho0,
                                     0.5 * ctx.R)
            if text:
                logger.warning("axisymmetric fluid: %s", text)
        self.wall_top = float(walls[:, 1].max()) + 0.5 * self.dx if len(walls) else None
        #: the floor's outer radius [m] (the spread cannot be measured beyond it)
        self._wall_r_max = (float(walls[:, 0].max()) + 0.5 * self.dx if len(walls)
                            else math.inf)
        self.wall_depth = (float(walls[:, 1].max() - walls[:, 1].min()) / self.dx + 1.0
                           if len(walls) else None)
        self.D0 = 2.0 * max((b.radius for b in self.scene.blocks
                             if b.kind == "fluid" and b.shape == "sphere"), default=0.0)
        #: the spread diameter is sampled every 0.02 D0 / V0 (V0: the fastest ring now)
        v0 = float(np.sqrt((ps.v[ps.kind == FLUID] ** 2).sum(axis=1)).max(initial=0.0))
        self.spread_every = 0.02 * self.D0 / v0 if v0 > 0 else 0.0
        # the impact speed from the scene (a resumed run's rings are slower by now)
        v_imp = max((float(np.linalg.norm(b.velocity)) for b in self.scene.blocks
                     if b.kind == "fluid" and b.shape == "sphere" and b.velocity is not None),
                    default=0.0)
        self.film = self._residual_film(v_imp)
        if self.film is not None and ctx.step == 0 and (
                self.film["particles_across"] < MIN_FILM_PARTICLES):
            logger.warning(
                "axisymmetric fluid: the residual film of the spreading, h_res = 0.79 D "
                "Re^-0.4 = %.3g m (Roisman 2009), spans %.2f particles (< %g): the maximum "
                "spreading and the heat it carries are decided below the spacing (dx <= %.3g "
                "m resolves it)", self.film["h_res_m"], self.film["particles_across"],
                MIN_FILM_PARTICLES, self.film["h_res_m"] / MIN_FILM_PARTICLES)
        self._next_spread = ctx.t
        if ctx.step == 0:
            self.mom0, self.impulse, self.t0 = self.momentum(ps), 0.0, ctx.t
        self._write_back(ctx)

    def _residual_film(self, v0: float) -> dict | None:
        """The residual film of the spreading (:func:`sphfem.fluid.spreading.residual_film`)
        at impact speed ``v0`` and its particles across (None without a droplet, a speed or
        a viscosity)."""
        mu, rho0 = float(self.params.mu), float(self.params.rho0)
        if not (self.D0 > 0 and v0 > 0 and mu > 0):
            return None
        h = residual_film(self.D0, rho0 * v0 * self.D0 / mu)
        return {"h_res_m": h, "particles_across": h / self.dx,
                "definition": "h_res = 0.79 D Re^-0.4 (Roisman 2009), Re = rho v D / mu with "
                              "v the droplet block's speed"}

    def _write_back(self, ctx) -> None:
        from sphfem.fluid.axisymmetric import scatter_state

        s, ps, idx = self.solver, ctx.particles, self.idx
        aug = s.augmented
        out = np.zeros((aug["x"].shape[0], 2))
        nl = aug["nbrs"]
        pa = s.params
        wall_ring_forces(aug["x"], aug["v"], aug["vg"], aug["rho"], aug["p"], aug["mt"],
                         aug["mu"], aug["kind"], nl.offsets, nl.indices, aug["Rp"], s.s2,
                         s.kcode, pa.eps_visc, pa.alpha * pa.c0, aug["fw"], aug["wall_art"],
                         out)
        # ps.x[idx] = s.x, ... v, rho, p, f_fluid (0 on the fluid), vol = m / rho (fluid)
        scatter_state(idx, self.fl, s.x, s.v, s.rho, s.p, out, ps.x, ps.v, ps.rho, ps.p,
                      ps.m, ps.vol, ps.f_fluid)

    def dt_limits(self, ctx) -> dict[str, float]:
        return self.solver.dt_limits()

    def checkpoint_state(self, ctx) -> dict | None:
        """The records of ``checkpoint_attrs`` and the solver's wall-layer state (its
        thicknesses and friction factors, ``[fluid] wall_friction = "layer"``)."""
        st = super().checkpoint_state(ctx)
        st["_wall_layer"] = (self.solver.delta2.copy(), self.solver.fw.copy())
        st["_inert"] = np.flatnonzero(self.solver.inert)
        ev = self.solver.debris_events
        st["_debris_t_first"] = ev[0][0] if ev else None
        return st

    def restore_state(self, ctx, state: dict) -> None:
        state = dict(state)
        layer = state.pop("_wall_layer", None)
        inert = state.pop("_inert", None)
        t_first = state.pop("_debris_t_first", None)
        super().restore_state(ctx, state)
        if layer is not None:
            self.solver.delta2[:], self.solver.fw[:] = layer
        if inert is not None and len(inert):
            self.solver.make_inert(np.asarray(inert, np.int64))
            self._inert_heat(ctx, inert)
            # the debris found before the checkpoint, as one event at its first time
            self.solver.debris_events = [(ctx.t if t_first is None else float(t_first),
                                          np.asarray(inert, np.int64))]

    def _inert_heat(self, ctx, rows) -> None:
        """Inert rings (debris) leave the heat: k_heat = 0 (the heat module and the contact
        interface skip them; their temperature is kept)."""
        ps = ctx.particles
        if "k_heat" in ps:
            ps.k_heat[self.idx[np.asarray(rows, np.int64)]] = 0.0

    def step(self, ctx, dt: float) -> None:
        from sphfem.errors import SimulationStopped

        s = self.solver
        v_n = s.v.copy()
        try:
            s.step(dt)
        except (FloatingPointError, ValueError) as e:
            raise SimulationStopped(f"axisymmetric fluid at t = {ctx.t:.4g} s: {e} (lowest "
                                    f"fluid ring {self._depth(s):.2f} dx below the wall "
                                    "top)") from None
        self._write_back(ctx)
        if s.debris_new.size:  # found at this step
            rows = s.debris_new
            self._inert_heat(ctx, rows)
            logger.info("axisymmetric fluid: %d ring(s) of free-flying debris made inert at "
                        "t = %g s (counted in summary.json, fluid.debris)", rows.size, s.t)
        self._correction_forces(ctx, v_n, dt)
        self._guard(ctx.t + dt)
        depth = self._depth(s)
        self.max_depth = max(self.max_depth, depth)
        if depth > self.BREACH_DX and self.t_breach is None:
            self.t_breach = ctx.t + dt
            logger.warning("axisymmetric fluid: a ring %.2f dx below the wall top at t = %g s "
                           "(the figures after it are suspect)", depth, ctx.t + dt)
        if self.wall_depth is not None and depth > self.wall_depth:
            raise SimulationStopped(f"axisymmetric fluid at t = {ctx.t + dt:.4g} s: a ring "
                                    f"went through the wall ({depth:.2f} dx below its top, "
                                    f"the wall is {self.wall_depth:.2f} dx thick)")
        if self.t_escape is None:
            lo, hi = self._domain
            xf = s.x[s.fluid]
            if ((xf < lo) | (xf > hi)).any():
                self.t_escape = ctx.t + dt
                logger.warning("axisymmetric fluid: a ring left the domain box at t = %g s "
                               "(it flies on; counted in summary.json, fluid."
                               "rings_outside_domain)", ctx.t + dt)
        self.impulse += dt * float(ctx.particles.f_fluid[:, 1].sum())
        if self.wall_top is not None and self.D0 > 0 and ctx.t + dt >= self._next_spread:
            ps = ctx.particles
            self.spread.append([ctx.t + dt, self.contact_diameter(ps), self.root_diameter(ps),
                                self.centre_thickness(ps), *self.body_diameter(ps)])
            self._next_spread = ctx.t + dt + self.spread_every

    def _guard(self, t: float) -> None:
        """The fluid's stability guards (:mod:`sphfem.fluid.guards`: non-finite state, speed
        above ``max_speed_factor`` c0, density ratio outside ``rho_ratio_band``) on the
        active rings: the inert debris fly on unchecked and a ring outside the domain box
        is counted, not stopped (``rings_outside_domain``).  Before 2026-12-07 the
        axisymmetric fluid had none: a 3 m/s impact (We 12, D/dx 64) blew up to 3e5 m/s
        and 1e18 Pa at the wall and still reported ``completed``."""
        from sphfem.errors import SimulationStopped
        from sphfem.fluid.guards import check_fluid

        s, pa = self.solver, self.params
        if s.fluid.any():
            ratio = s.rho[s.fluid] / pa.rho0
            lo, hi = float(ratio.min()), float(ratio.max())
            if self.rho_ratio_extremes is None:
                self.rho_ratio_extremes = [lo, t, hi, t]
            ext = self.rho_ratio_extremes
            if lo < ext[0]:
                ext[0], ext[1] = lo, t
            if hi > ext[2]:
                ext[2], ext[3] = hi, t
        try:  # the solver's kind is FLUID on the active rings only (inert: INERT)
            check_fluid(s.x, s.v, s.rho, s.kind, _NO_BOX_LO, _NO_BOX_HI, _NO_PERIOD,
                        pa.c0, pa.rho0, pa.max_speed_factor, pa.rho_ratio_band,
                        s.step_count, t)
        except SimulationStopped as e:  # say where: the axis and the wall are the suspects
            rows = np.flatnonzero(s.fluid)
            ratio = s.rho[rows] / pa.rho0
            dev = np.maximum(ratio / pa.rho_ratio_band[1], pa.rho_ratio_band[0] / ratio)
            speed = np.sqrt((s.v[rows] ** 2).sum(axis=1)) / (pa.max_speed_factor * pa.c0)
            bad = np.where(np.isfinite(dev) & np.isfinite(speed), np.maximum(dev, speed),
                           np.inf)
            i = rows[int(np.argmax(bad))]
            z0 = self.wall_top if self.wall_top is not None else 0.0
            raise SimulationStopped(
                f"{e} [the worst ring: r = {s.x[i, 0] / self.dx:.3g} dx from the axis, "
                f"z = {(s.x[i, 1] - z0) / self.dx:.3g} dx above the wall top, "
                f"rho/rho0 = {s.rho[i] / pa.rho0:.4g}, |v| = "
                f"{float(np.hypot(*s.v[i])):.4g} m/s]") from None

    def _depth(self, s) -> float:
        """How far the lowest fluid ring over the floor lies below the floor's top [dx]
        (<= 0: above; the floor: the wall particles whose exposed face is a top face).  A
        ring beyond the floor's outer radius has flown past its edge, not through it: it
        does not count (it is reported by the domain-box check)."""
        if self.wall_top is None:
            return 0.0
        x = s.x[self.fl & ~s.inert]
        z = x[x[:, 0] <= self._wall_r_max, 1]
        return float((self.wall_top - z.min()) / self.dx) if z.size else -math.inf

    def _correction_forces(self, ctx, v_n, dt: float) -> None:
        """The no-penetration correction's normal momentum, as ring forces on the nearest
        wall particles (module docstring)."""
        s = self.solver
        if s.no_penetration is None or self._wall_tree is None:
            return
        from sphfem.fluid.axisymmetric import changed_velocities

        fl = self._fl_rows
        hit = changed_velocities(fl, s.v, v_n, s.acc, dt)
        if hit.size == 0:
            return
        dv = s.v[fl[hit]] - (v_n[fl[hit]] + dt * s.acc[fl[hit]])
        _, j = self._wall_tree.query(s.x[fl[hit]])
        w = self._walls[j]
        n = self.nrm[w]
        dvn = (dv * n).sum(axis=1)
        F = -(s.M[fl[hit]] * dvn / dt)[:, None] * n
        ps = ctx.particles
        np.add.at(ps.f_fluid, self.idx[w], F)
        self.correction_impulse += dt * float(F[:, 1].sum())

    #: a gap wider than this [dx] along the wall ends the film (shed rings lie beyond it)
    FILM_GAP_DX = 2.0

    def contact_diameter(self, ps) -> float:
        """Diameter of the film on the wall: 2 r_e + dx, r_e the outermost ring of the wall
        row (rings within 1.5 dx above the wall top) reached from the axis without a gap
        wider than FILM_GAP_DX dx.  Rings shed from the rim that slide out on the wall lie
        beyond such a gap and do not count (2 max r + dx of the whole row did: a shed ring
        carried it to 6.2 D at D/dx = 16); a film thinner than the kernel does (the colour
        contact radius of :mod:`sphfem.fluid.spreading`, c = 1/2 with R = 3 dx, reads a film
        thinner than ~R/5 as dry: 3.3 D at D/dx = 32, 50 m/s, against a wetted area of 5.3 D
        equivalent diameter)."""
        fl = ps.kind == FLUID
        h = ps.x[fl, 1] - self.wall_top
        near = (h >= -0.5 * self.dx) & (h < 1.5 * self.dx)
        if not near.any():
            return 0.0
        r = np.sort(ps.x[fl][near, 0])
        gap = np.flatnonzero(np.diff(r) > self.FILM_GAP_DX * self.dx)
        r_edge = r[gap[0]] if gap.size else r[-1]
        return float(2.0 * r_edge + self.dx)

    #: the lamella's root is where the wall-attached fluid is thinner than this [D0]
    ROOT_THICKNESS_D = 0.05

    def root_diameter(self, ps) -> float:
        """Diameter of the lamella's root [m] (:func:`sphfem.fluid.spreading.
        lamella_root_radius` with the thickness threshold ROOT_THICKNESS_D D0 = R0 / 10):
        where the droplet's body ends and the sheet along the wall begins (Wagner's
        turnover point; the contact diameter is the sheet's tip)."""
        from sphfem.fluid.spreading import lamella_root_radius

        fl = ps.kind == FLUID
        return 2.0 * lamella_root_radius(ps.x[fl, 0], ps.x[fl, 1], self.wall_top, self.dx,
                                         self.ROOT_THICKNESS_D * self.D0)

    def body_diameter(self, ps) -> tuple[float, float]:
        """The fluid's main body's wetted diameter [m] and the mass fraction broken off
        from it (:func:`sphfem.fluid.spreading.body_contact_diameter`): the spreading
        figure, which shed rings and stray rings on the wall ahead of the rim do not
        move."""
        from sphfem.fluid.spreading import body_contact_diameter

        fl = ps.kind == FLUID
        return body_contact_diameter(ps.x[fl, 0], ps.x[fl, 1], self.wall_top, self.dx,
                                     ps.m[fl])

    def centre_thickness(self, ps) -> float:
        """Thickness of the fluid on the wall at the impact axis [m]
        (:func:`sphfem.fluid.spreading.centre_thickness`: the rings within 2 dx of the
        axis; 0 when the axis is dry), to compare with the inviscid lamella
        (:func:`sphfem.fluid.spreading.lamella_thickness_inviscid`)."""
        from sphfem.fluid.spreading import centre_thickness

        fl = ps.kind == FLUID
        return centre_thickness(ps.x[fl, 0], ps.x[fl, 1], self.wall_top, self.dx)

    def momentum(self, ps) -> float:
        """Axial momentum sum_i M_i v_z,i of the fluid rings [kg m/s]."""
        fl = ps.kind == FLUID
        return float(np.sum(ps.m[fl] * ps.v[fl, 1]))

    def momentum_residual(self, ps) -> float | None:
        """Axial momentum budget of the fluid since the start, (P - P0 + J_walls - M g_z
        (t - t0)) / max(|P0|, M |g_z| (t - t0)): J_walls the impulse the walls took (eq. 1),
        so what is left is what the pair forces do not conserve (the planar pair forces
        times ring masses are antisymmetric only for rings of equal radius)."""
        if self.mom0 is None:
            return None
        fl = ps.kind == FLUID
        M = float(ps.m[fl].sum())
        g = float(np.asarray(self.params.gravity, float).reshape(-1)[-1])
        tt = self.solver.t - self.t0
        res = self.momentum(ps) - self.mom0 + self.impulse - M * g * tt
        return res / max(abs(self.mom0), abs(M * g * tt), 1e-300)

    def diagnostics(self, ctx) -> dict:
        ps, s = ctx.particles, self.solver
        fl = ps.kind == FLUID
        # (rows of a run resumed from an older checkpoint lack the later columns: nan)
        sp = (np.array([list(row) + [math.nan] * (6 - len(row)) for row in self.spread])
              if self.spread else np.zeros((0, 6)))
        # thin the history to ~400 rows for summary.json
        keep = sp[:: max(1, len(sp) // 400)] if len(sp) else sp
        d = {"geometry": "axisymmetric", "fluid_rings": int(fl.sum()),
             "wall_rings": int((ps.kind == WALL).sum()),
             "mass_kg": float(ps.m[fl].sum()),
             "axial_momentum_kg_m_s": self.momentum(ps),
             "axial_momentum_initial_kg_m_s": self.mom0,
             "wall_axial_impulse_N_s": self.impulse,
             "no_penetration_axial_impulse_N_s": self.correction_impulse,
             "no_penetration_corrections": int(s.penetration_corrections),
             "max_ring_depth_below_wall_top_dx": self.max_depth,
             "t_wall_breach_s": self.t_breach,
             "axial_momentum_residual_rel": self.momentum_residual(ps),
             "wall_s": dict(s.wall_s), "steps": s.step_count,
             "neighbor_lists": {"built": s.list_builds, "reused": s.list_reuses}}
        # rings outside the domain box fly on (no outflow boundary): their number, mass
        # fraction and the first time, so a splash that left the region is visible
        lo, hi = self._domain
        out = fl & ((ps.x < lo) | (ps.x > hi)).any(axis=1)
        ext = self.rho_ratio_extremes or [None] * 4
        d["density_ratio"] = {"min": ext[0], "t_min_s": ext[1], "max": ext[2],
                              "t_max_s": ext[3], "guard_band": list(self.params.rho_ratio_band)}
        d["rings_outside_domain"] = {"count": int(out.sum()),
                                     "mass_fraction": float(ps.m[out].sum() / ps.m[fl].sum()),
                                     "t_first_s": self.t_escape}
        # free-flying debris made inert (fluid_options["debris_rings"])
        inert = s.inert
        d["debris"] = {"max_rings": s.debris_rings, "count": int(inert.sum()),
                       "mass_fraction": float(s.M[inert].sum() / max(s.total_mass(), 1e-300)),
                       "t_first_s": s.debris_events[0][0] if s.debris_events else None}
        d["wall_friction"] = {"model": s.wall_friction}
        if s.wall_friction == "layer":
            band = s.delta2 >= 0.0
            d["wall_friction"].update(
                rows_in_band=int(band.sum()),
                factor_mean=float(s.fw[band].mean()) if band.any() else 1.0,
                factor_max=float(s.fw[band].max()) if band.any() else 1.0,
                shear_thickness_median_m=(float(np.sqrt(np.median(s.delta2[band])))
                                          if band.any() else None))
        if self.film is not None:
            d["residual_film"] = self.film
        if self.D0 > 0 and len(sp):
            from sphfem.fluid.spreading import BODY_LINK

            # the main body's diameter (column 4); the wall row's (column 1) where a run
            # resumed from an older checkpoint has none
            col = 4 if np.isfinite(sp[:, 4]).any() else 1
            k = int(np.nanargmax(sp[:, col]))
            kw = int(np.argmax(sp[:, 1]))
            d["spreading"] = {
                "D0_m": self.D0, "definition": (
                    "2 r_e + dx, r_e the outermost ring within 1.5 dx of the wall of the "
                    f"fluid's main body (rings joined by links < {BODY_LINK:g} dx, the "
                    "heaviest group)" if col == 4 else
                    "2 r_e + dx, r_e the outermost ring within 1.5 dx of the wall reached "
                    f"from the axis without a gap over {self.FILM_GAP_DX:g} dx"),
                "max_diameter_m": float(sp[k, col]),
                "max_ratio": float(sp[k, col] / self.D0), "max_t_s": float(sp[k, 0]),
                # the film reached the end of the wall: the spreading is cut by the scene
                "wall_end_reached": bool(0.5 * sp[k, col] >= self._wall_r_max - ctx.R),
                # the wall row reached from the axis with gaps < FILM_GAP_DX dx (before
                # session 16 the figure): stray rings on the wall ahead of the rim count
                "max_ratio_wall_row": float(sp[kw, 1] / self.D0),
                "max_t_wall_row_s": float(sp[kw, 0]),
                "detached_mass_fraction_max": (float(np.nanmax(sp[:, 5]))
                                               if np.isfinite(sp[:, 5]).any() else None),
                "detached_mass_fraction_at_max": float(sp[k, 5]),
                "history_t_s": keep[:, 0].tolist(),
                "history_ratio": (keep[:, col] / self.D0).tolist(),
                "history_wall_row_ratio": (keep[:, 1] / self.D0).tolist(),
                "history_detached_mass_fraction": keep[:, 5].tolist(),
                # the lamella's root (Wagner's turnover point), R0 / 10 thickness threshold
                "history_root_ratio": (keep[:, 2] / self.D0).tolist(),
                # the fluid's thickness on the wall at the axis (0: dry there)
                "history_centre_thickness_m": keep[:, 3].tolist()}
        return d


class AxisymmetricHeatModule(PhysicsModule):
    """The ``heat`` module of an axisymmetric scene (module docstring): conduction among
    the fluid and wall rings with axis ghosts; c and k per material from the scene
    (``k_heat`` is read every step, so the coupling's fem-contact model can set it to 0 on
    the substrate).  ``[heat]``: ``laplacian = "cleary"`` and ``time_integration =
    "explicit"`` only; ``cfl``; boundaries other than the axis are insulated (free)."""

    name = "heat"
    #: the energy budget a resumed run continues (initial energy, residual, steps)
    checkpoint_attrs = ("e0", "residual", "steps", "wall_s")
    moves_particles = False

    def __init__(self, scene):
        super().__init__(scene)
        cfg = scene.heat
        if cfg is not None:
            if cfg.laplacian != "cleary" or cfg.time_integration != "explicit":
                raise ValueError('heat: geometry = "axisymmetric" takes laplacian = "cleary" '
                                 'and time_integration = "explicit"')
            if cfg.boundaries:
                raise ValueError('heat: geometry = "axisymmetric" has no [[heat.boundaries]] '
                                 "yet (every boundary but the axis is insulated)")
        self.cfl = cfg.cfl if cfg is not None else 1.0
        self.residual = 0.0
        self.steps = 0
        self.wall_s = 0.0
        self._limit = math.inf
        #: Verlet skin of the heat list (as the fluid's, AxisymmetricFluidModule.SKIN)
        self.skin = AxisymmetricFluidModule.SKIN
        self._list = None
        self.list_builds = 0
        self.list_reuses = 0

    def fields(self):
        f = np.float64
        return {"T": (f, 1), "c_heat": (f, 1), "k_heat": (f, 1)}

    def init(self, ctx) -> None:
        ps = ctx.particles
        for mid, (name, mat) in enumerate(ctx.materials.items()):
            sel = ps.material == mid
            if sel.any() and not (mat.c and mat.k is not None):
                raise ValueError(f"heat: material {name!r} needs c and k")
            ps.c_heat[sel] = mat.c or 0.0
            ps.k_heat[sel] = mat.k or 0.0
        self.kcode = kernels.kernel_code(ctx.kernel)
        self.sigma = kernels.kernel_sigma(self.kcode, 2, ctx.R)
        self.e0 = self.energy(ps)
        self._rates(ctx, ps.T)

    def energy(self, ps) -> float:
        """sum_i m_i c_i T_i [J] over the real rings (the whole bodies of revolution)."""
        real = ps.kind != GHOST
        return float(np.sum(ps.m[real] * ps.c_heat[real] * ps.T[real]))

    def _system(self, ctx):
        from sphfem.heat.axisymmetric import axis_ghosts, heat_conductances, ring_system

        ps = ctx.particles
        # rings with k = 0 (the substrate of model = "fem-contact") take part in no pair:
        # every pair term with them is exactly 0 and their own rate is 0, so they are left
        # out of the list (neighbour rows are sorted by index, so the remaining sums run in
        # the same order: the same rates to the bit)
        real = np.flatnonzero((ps.kind != GHOST) & (ps.k_heat != 0.0))
        x = np.ascontiguousarray(ps.x[real])
        n = x.shape[0]
        c = self._list
        if (c is not None and np.array_equal(c[1], real)
                and ctx.R + 2.0 * _max_move(x, c[4]) <= c[0]):
            src, nl = c[2], c[3]  # the list (and axis ghosts) of the last build still hold
            self.list_reuses += 1
        else:  # ghosts and list out to R (1 + skin)
            radius = ctx.R * (1.0 + self.skin)
            g = axis_ghosts(x, radius)
            src = g.src
            xa = np.ascontiguousarray(np.vstack([x, g.x]))
            kind = np.concatenate([np.full(n, FLUID, np.int8), np.full(g.n, GHOST, np.int8)])
            keep = [0] * (GHOST + 1)
            keep[FLUID] = (1 << FLUID) | (1 << GHOST)
            lo = xa.min(axis=0) - radius if n else np.zeros(2)
            hi = xa.max(axis=0) + radius if n else np.ones(2)
            nl = build_neighbor_list(xa, radius, lo, hi, np.zeros(2), kind=kind,
                                     keep=tuple(keep))
            m = nl.indices.shape[0]  # packed pair rows (heat_conductances), per build
            pairs = (np.zeros(n, np.int64), np.zeros(m, np.int64), np.zeros(m))
            self._list = (radius, real, src, nl, x.copy(), pairs)
            self.list_builds += 1
        # positions, A = ring_areas, k, radii of the rows and their ghosts, 1 / (r rho c)
        na = n + src.shape[0]
        s = dict(real=real, xa=np.empty((na, 2)), src=src, n=n, nl=nl, A=np.empty(na),
                 k=np.empty(na), rc=np.empty(na), inv=np.empty(n), mom=np.ones(na))
        ring_system(ps.x, ps.m, ps.rho, ps.c_heat, ps.k_heat, real, src, s["xa"], s["A"],
                    s["k"], s["rc"], s["inv"])
        xa, inv = s["xa"], s["inv"]
        # the pair weights once per step (both Heun stages use them; heat_rates' sums)
        pairs = self._list[5]
        g = heat_conductances(xa, s["A"], s["k"], s["rc"], inv, s["mom"], n, nl.offsets,
                              nl.indices, ctx.R, self.sigma, self.kcode, np.zeros(2),
                              *pairs)
        self._limit = self.cfl * 2.0 / g if g > 0 else math.inf
        s["pairs"] = pairs
        return s

    def _rates(self, ctx, T_all, sysd=None, k1=None, dt=0.0):
        """dT/dt of the rows ``s["real"]`` at T_all (with ``k1`` and ``dt``: at T_all + dt k1
        on those rows, Heun's predictor) and the system."""
        from sphfem.heat.axisymmetric import heat_rates_packed, ring_temperatures

        s = sysd if sysd is not None else self._system(ctx)
        Ta = np.empty(s["xa"].shape[0])
        ring_temperatures(T_all, s["real"], s["src"], s["inv"] if k1 is None else k1,
                          dt if k1 is not None else 0.0, Ta)
        out = np.zeros(s["n"])
        heat_rates_packed(Ta, s["inv"], s["n"], s["nl"].offsets, *s["pairs"], out)
        return out, s

    def dt_limits(self, ctx) -> dict[str, float]:
        return {"thermal": self._limit} if math.isfinite(self._limit) else {}

    def step(self, ctx, dt: float) -> None:
        t0 = time.perf_counter()
        ps = ctx.particles
        e_before = self.energy(ps)
        k1, s = self._rates(ctx, ps.T)
        k2, _ = self._rates(ctx, ps.T, s, k1, dt)  # at T + dt k1
        ps.T[s["real"]] += 0.5 * dt * (k1 + k2)
        self.residual += self.energy(ps) - e_before
        self.steps += 1
        self.wall_s += time.perf_counter() - t0

    def diagnostics(self, ctx) -> dict:
        return {"geometry": "axisymmetric", "steps": self.steps,
                "energy_J": self.energy(ctx.particles), "energy_initial_J": self.e0,
                "energy_residual_J": self.residual,
                "energy_residual_rel": self.residual / max(abs(self.e0), 1e-300),
                "explicit_limit_s": self._limit, "wall_s": self.wall_s,
                "neighbor_lists": {"built": self.list_builds, "reused": self.list_reuses}}
