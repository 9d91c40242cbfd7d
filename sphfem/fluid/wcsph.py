"""Weakly compressible delta-SPH fluid: parameters, the solver and the physics module.

Equations (Park 2019 sec. 2.4.3.1; Antuono et al. 2010; Marrone et al. 2011):

    Du_i/Dt  = -sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2) grad_i W_ij                    (2.85)
               + sum_j 4 m_j (mu_i + mu_j) (x_ij . grad_i W_ij) / ((rho_i + rho_j)^2
                 (r_ij^2 + 0.01 h^2)) u_ij + g                                      (2.86)
    Drho_i/Dt = rho_i sum_j V_j (u_i - u_j) . grad_i W_ij + delta h c0 D_i          (2.87-2.91)
    p = rho0 c0^2 / gamma ((rho/rho0)^gamma - 1)                                    (2.73)

with h = R / 2 (half the support radius, as in Antuono/Marrone) and D_i the diffusive term
with the renormalised density gradient (fluid-fluid pairs).  Walls: Adami, Hu & Adams
(2012), see :mod:`sphfem.fluid.walls_adami2012`.  Each wall particle's ``f_fluid`` holds the
force [N] it receives from the fluid (pressure + viscous pair forces), the exact negative of
what the fluid feels from it.

Methods are chosen by name from the registries of :mod:`sphfem.fluid` (``[fluid]`` keys):
``pressure`` (:mod:`~sphfem.fluid.pressure`; "wcsph", the above, owns the step),
``integrator`` (:mod:`~sphfem.fluid.integrators`; "symplectic": position Verlet in the
predictor-corrector form of DualSPHysics, one force evaluation per step, second order),
``walls`` (:mod:`~sphfem.fluid.walls`; "adami2012"), ``viscosity``
(:mod:`~sphfem.fluid.viscosity`; "laminar": the term above, fused into the force pass) and
``surface_tension`` (:mod:`~sphfem.fluid.surface_tension`).

Time-step limits (h = R/2), each reported by name: acoustic ``cfl h / (c0 + |v|max)`` (a
pressure projection, IISPH / DFSPH: ``cfl h / |v|max`` instead, named cfl),
viscous ``visc_cfl h^2 min(rho/mu)`` (not with an implicit viscosity model: it asks the
model's ``implicit``), force ``force_cfl sqrt(h / |a|max)``, density ``density_cfl
min(rho / |D rho / D t|)`` (``[fluid] density_cfl``; off by default).

Neighbours: the context's list (:class:`~sphfem.context.StepContext`), asked for after every
drift; stand-alone, the Verlet list of :mod:`sphfem.fluid.standalone` (radius R (1 + skin),
rebuilt when some fluid particle moved more than skin R / 2 since the last build, cell sort
every ``sort_every`` builds, all fields of the ParticleSet permuted together).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numba
import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.context import StepContext
from sphfem.fluid import (
    integrators,
    passes,
    pressure,
    rheology,
    surface,
    surface_tension,
    viscosity,
    walls,
)
from sphfem.fluid.eos import tait_B
from sphfem.fluid.guards import check_fluid
from sphfem.fluid.scene_section import FLUID as FLUID_SECTION
from sphfem.fluid.scene_section import REGISTRIES
from sphfem.fluid.standalone import standalone_context
from sphfem.neighbors import NeighborList, work_buffer
from sphfem.particles import FLUID, WALL, ParticleSet
from sphfem.physics import PhysicsModule, register_physics
from sphfem.schema.params import check_declared, section_dataclass

logger = logging.getLogger(__name__)


#: below this many particles the automatic thread choice runs the passes on one thread
SERIAL_BELOW = 20_000


class _threads:
    """Context manager setting numba's thread count (0: leave it) and restoring it."""

    def __init__(self, k: int):
        self.k = k

    def __enter__(self):
        if self.k:
            self.old = numba.get_num_threads()
            numba.set_num_threads(min(self.k, numba.config.NUMBA_NUM_THREADS))

    def __exit__(self, *exc):
        if self.k:
            numba.set_num_threads(self.old)


#: the parameters of :class:`FluidParams` that are not ``[fluid]`` keys: the fluid
#: materials' properties and the ``[time]`` / ``[sph]`` settings (name -> (default, doc);
#: :func:`params_from_scene` fills them from the scene)
RUN_FIELDS = {
    "rho0": (1000.0, "reference density [kg/m^3] (the fluid materials' rho0)"),
    "c0": (10.0, "numerical speed of sound [m/s] (>= 10 |v|max and >= 10 sqrt(g H))"),
    "mu": (1.0e-3, "dynamic viscosity [Pa s] given to fluid particles whose mu field is 0"),
    "sigma": (0.0, "physical surface tension [N/m] (calibrates the model's constant)"),
    "cfl": (0.25, "coefficient of the acoustic time-step limit ([time] cfl)"),
    "skin": (0.15, "Verlet-list skin as a fraction of R ([sph] skin)"),
    "sort_every": (10, "cell-sort the particles every this many list builds ([sph] "
                       "sort_every)"),
}


def _check_params(self) -> None:
    """Check the values against the ``[fluid]`` declaration (bounds, choices, the method
    names of the registries) and the cross-key rules."""
    for k in ("rho0", "c0"):
        if not getattr(self, k) > 0:
            raise ValueError(f"fluid {k} must be positive, got {getattr(self, k)}")
    if self.mu < 0 or self.skin < 0:
        raise ValueError("fluid mu and skin must be non-negative")
    check_declared(self, FLUID_SECTION, "fluid", REGISTRIES)  # ValueError: unknown method
    lo, hi = self.rho_ratio_band
    if not 0 < lo < 1 < hi:
        raise ValueError(f"rho_ratio_band must satisfy 0 < lo < 1 < hi, got {(lo, hi)}")
    method = surface_tension.lookup(self.surface_tension)
    if method is not None:
        key = method.constant_key
        const = self.st_params.get(key, getattr(self, key, None)) if key else None
        if const is None and not self.sigma > 0:
            raise ValueError(f"surface_tension = {self.surface_tension!r} needs sigma > 0 "
                             "[N/m] or its calibration constant")


FluidParams = section_dataclass(
    "FluidParams", FLUID_SECTION,
    {**RUN_FIELDS, "st_params": (dict, "the surface-tension method's own keys not declared "
                                       "in [fluid] (name -> value)")},
    module=__name__,
    doc="Parameters of the WCSPH fluid (SI units): the ``[fluid]`` keys of the scene "
        "(declared in :mod:`sphfem.fluid.scene_section`, documented in docs/scenes.md) and "
        "the materials' and run settings.",
    namespace={
        "__post_init__": _check_params,
        "uses_free_surface": property(
            lambda self: self.detect_free_surface or self.shifting != "none",
            doc="the free surface is detected (flag or shifting)"),
    })


def _is_fluid_view(ctx) -> bool:
    """Whether the context's list was built as the fluid's view (pair filter
    :data:`passes.VIEW_KEEP`: the driver when the fluid is the list's only user, or the
    stand-alone context)."""
    return (getattr(ctx, "fluid_view", False)
            or getattr(ctx, "pair_filter", None) == passes.VIEW_KEEP)


#: per-particle fields of the fluid (name -> (dtype, components or "dim"))
FIELDS = {"v": "dim", "acc": "dim", "drho": 1, "p": 1, "mu": 1, "f_fluid": "dim"}
#: added when the free surface is detected (1.0 on free-surface particles)
FS_FIELDS = {"free_surface": 1}


def fluid_fields(params: FluidParams | None = None) -> dict:
    """The fluid's per-particle fields for ``params``: name -> components or "dim"."""
    out = dict(FIELDS)
    if params is not None and params.uses_free_surface:
        out.update(FS_FIELDS)
    if params is not None and params.rheology != "newtonian":
        out.update(rheology.FIELDS)
    return out


def add_fluid_fields(particles: ParticleSet, params: FluidParams | None = None) -> None:
    """Allocate the fluid's fields (zero-filled) if they are missing."""
    for name, nc in fluid_fields(params).items():
        particles.add_field(name, particles.dim if nc == "dim" else nc)


@njit(cache=True, parallel=True)
def _fluid_maxima(v, acc, rho, mu, kind):
    """max |v|, max |a| and min rho/mu over fluid particles (strict maths)."""
    n, dim = v.shape
    vm = np.zeros(n)
    am = np.zeros(n)
    rm = np.full(n, np.inf)
    for i in prange(n):
        if kind[i] != FLUID:
            continue
        s = 0.0
        a = 0.0
        for k in range(dim):
            s += v[i, k] * v[i, k]
            a += acc[i, k] * acc[i, k]
        vm[i] = s
        am[i] = a
        if mu[i] > 0.0:
            rm[i] = rho[i] / mu[i]
    if n == 0:
        return 0.0, 0.0, np.inf
    return np.sqrt(vm.max()), np.sqrt(am.max()), rm.min()


@dataclass
class _Scratch:
    """Per-particle work arrays, recomputed at every force evaluation (never persistent
    state, so a cell sort between evaluations does not need to permute them).  Those of
    the free surface (``gc, nrm, lam, fs, near, shift``: 74 B per particle in 3D) exist
    only with ``surface`` (``FluidParams.uses_free_surface``), ``mu0`` only once a
    viscosity model with its own pass asks for it (:meth:`FluidSolver.evaluate`)."""

    n: int
    dim: int
    surface: bool = True
    pr: np.ndarray = field(init=False)
    V: np.ndarray = field(init=False)
    meff: np.ndarray = field(init=False)
    isf: np.ndarray = field(init=False)
    vg: np.ndarray = field(init=False)
    grad: np.ndarray = field(init=False)
    ok: np.ndarray = field(init=False)
    v_n: np.ndarray = field(init=False)
    rho_n: np.ndarray = field(init=False)
    P: np.ndarray = field(init=False)
    gc: np.ndarray = field(init=False)
    nrm: np.ndarray = field(init=False)
    lam: np.ndarray = field(init=False)
    fs: np.ndarray = field(init=False)
    near: np.ndarray = field(init=False)
    shift: np.ndarray = field(init=False)

    def __post_init__(self):
        n, d = self.n, self.dim
        self.pr, self.V, self.meff, self.isf = (np.zeros(n) for _ in range(4))
        self.vg, self.grad, self.v_n = (np.zeros((n, d)) for _ in range(3))
        self.rho_n = np.zeros(n)
        self.gc = self.nrm = self.lam = self.shift = self.fs = self.near = None
        if self.surface:
            self.gc, self.nrm = np.zeros((n, d)), np.zeros((n, d))
            self.lam, self.shift = np.ones(n), np.zeros(n)
            self.fs = np.zeros(n, dtype=np.int8)
            self.near = np.zeros(n, dtype=np.bool_)
        self.P = np.zeros((n, passes.NPACK))
        self.mu0 = None  # the fused pass's mu (zeros) when the viscosity model has its own
        self.cnt = np.zeros(n, dtype=np.int64)
        self.ok = np.ones(n, dtype=np.bool_)


class FluidSolver:
    """WCSPH delta-SPH fluid with Adami walls on a :class:`ParticleSet`.

    Fluid particles have kind FLUID, wall particles kind WALL (fixed positions, prescribed
    velocity ``v`` and acceleration ``acc``, fixed volume ``vol``).  Other kinds are ignored.

    Parameters: ``particles`` (fields ``v, acc, drho, p, mu, f_fluid`` are added), support
    radius ``R`` [m], domain box ``lo``/``hi`` and ``period`` (0 on open axes), ``params``.

    Context: the solver works on a :class:`~sphfem.context.StepContext` ``ctx`` (the
    driver's, when a :class:`~sphfem.simulation.Simulation` drives it).  After every drift
    it asks ``ctx.neighbors()`` for a list valid at the current positions and, whenever
    ``ctx.nbrs_version`` changed, derives its filtered view (:func:`passes.filter_rows`;
    nothing to filter, and no copy kept, when the list was built as the fluid's view:
    the context's ``pair_filter`` is :data:`passes.VIEW_KEEP`, or ``fluid_view``).
    Without ``ctx`` the solver builds the stand-alone one of
    :func:`sphfem.fluid.standalone.standalone_context` (its own Verlet list of radius
    R (1 + skin), cell sort every ``sort_every`` builds) and :meth:`run` is the stand-alone
    loop: one path of neighbours, forces and steps for both.
    """

    def __init__(self, particles: ParticleSet, R: float, lo, hi, period=None,
                 params: FluidParams | None = None, kernel: str = "wendland_c2",
                 ctx: StepContext | None = None):
        self.params = params or FluidParams()
        self.dim = particles.dim
        self.R = float(R)
        self.h = 0.5 * self.R
        self.kernel_code = kernels.kernel_code(kernel)
        self.sigma = kernels.kernel_sigma(self.kernel_code, self.dim, self.R)
        self.lo = np.asarray(lo, dtype=np.float64)
        self.hi = np.asarray(hi, dtype=np.float64)
        self.period = np.zeros(self.dim) if period is None else np.asarray(period, np.float64)
        g = np.zeros(self.dim)
        gp = np.asarray(self.params.gravity, dtype=np.float64).reshape(-1)
        g[: min(self.dim, gp.size)] = gp[: self.dim]
        self.gravity = g
        self.B = tait_B(self.params.rho0, self.params.c0, self.params.gamma)
        add_fluid_fields(particles, self.params)
        self.pressure_method = pressure.lookup(self.params.pressure)
        self.integrator = integrators.lookup(self.params.integrator)
        self.wall_method = walls.lookup(self.params.walls)
        self.visc_method = viscosity.lookup(self.params.viscosity)
        self._visc_state = None  # work arrays of a viscosity model with its own pass
        self.rheology = rheology.lookup(self.params.rheology)  # mu(gamma_dot) per particle
        self.step_dt = None  # length of the step being taken (None before the first)
        mu = particles.mu
        fl = particles.kind == FLUID
        if self.visc_method is None:  # inviscid
            mu[fl] = 0.0
        else:
            mu[fl & (mu == 0.0)] = self.params.mu
        self.m_bar = float(particles.m[fl].mean()) if fl.any() else 1.0
        self._surface_constants()
        self.max_shift = 0.0
        self.t = 0.0
        self.step_count = 0
        self._view = None  # the filtered copy (None: the context's list is the view)
        self._nbrs_version = -1
        self.n_rebuilds = 0
        self.wall = {"neighbors": 0.0, "forces": 0.0, "integrate": 0.0, "guards": 0.0}
        self.last_fallbacks = 0
        self.guard_message = ""
        self._scratch = None
        #: run the force pass over the in-range rows compacted by the density-gradient
        #: pass (False: over the full filtered Verlet list; same results, for tests)
        self.compact_rows = True
        self._st_state = None  # work arrays of the surface-tension method
        #: a pressure-projection method's state between steps (its ``solve`` returns it)
        self.pressure_state = None
        if ctx is None:  # stand-alone: the fluid's own context and list service
            ctx = standalone_context(particles, self.R, self.sigma, self.kernel_code, kernel,
                                     self.lo, self.hi, self.period, self.params, self.wall,
                                     self.reorder)
        self.ctx = ctx
        if self.params.threads:
            self.nthreads = self.params.threads
        else:
            self.nthreads = 1 if particles.n < SERIAL_BELOW else 0
        with _threads(self.nthreads):
            ctx.neighbors()
            self._sync_neighbors()
            self.evaluate()

    def _surface_constants(self) -> None:
        """Calibration constant of the surface-tension model and the sigma it represents."""
        pa = self.params
        self.st_method = surface_tension.lookup(pa.surface_tension)
        self.st_constant = None
        self.st_sigma = pa.sigma
        if self.st_method is not None:
            self.st_constant, self.st_sigma = self.st_method.calibrate(pa, self.m_bar, self.R,
                                                                       self.dim)
            from sphfem.sound_speed import capillary_warning

            text = capillary_warning(pa.c0, float(self.st_sigma or 0.0), pa.rho0, 0.5 * self.R)
            if text:
                logger.warning("fluid: %s", text)

    @property
    def p(self) -> ParticleSet:
        """The particle set (the context's current one)."""
        return self.ctx.particles

    # -- neighbours -----------------------------------------------------------------------
    @property
    def list_radius(self) -> float:
        return self.R * (1.0 + self.params.skin)

    @property
    def nbrs(self) -> NeighborList | None:
        """The fluid's view of the neighbour list: the context's list itself when it was
        built with the fluid's pair filter (no reference of its own is kept, so the driver
        can free the old list before building the next), else the filtered copy."""
        if self._view is None and _is_fluid_view(self.ctx):
            return self.ctx.nbrs
        return self._view

    def _set_view(self, nl: NeighborList) -> None:
        """Filtered view of ``nl`` for the passes (its work buffer: the thread's
        :func:`~sphfem.neighbors.work_buffer`, free until :meth:`evaluate`)."""
        m = nl.indices.shape[0]
        buf = work_buffer(m * nl.indices.itemsize).view(nl.indices.dtype)
        self._view = None  # the old copy goes first
        off, idx = passes.filter_rows(nl.offsets, nl.indices, self.p.kind, buf)
        self._view = NeighborList(off, idx, nl.radius, nl.period)
        self._new_list()

    def _new_list(self) -> None:
        """A new view: check its rows fit the position form of the compacted rows, count
        it, (re)size the per-particle scratch arrays."""
        off = self.nbrs.offsets
        longest = int(np.diff(off).max()) if off.shape[0] > 1 else 0
        if longest > passes.MAX_POS_ROW:
            raise ValueError(f"fluid: a neighbour-list row holds {longest} entries, more "
                             f"than the {passes.MAX_POS_ROW} the compacted "
                             "rows address (a resolution or skin far beyond the kernel's)")
        self.n_rebuilds += 1
        if self._scratch is None or self._scratch.n != self.p.n:
            self._scratch = _Scratch(self.p.n, self.dim, self.params.uses_free_surface)

    def rebuild_neighbors(self) -> None:
        """Build the list anew now (through the context) and take its view."""
        self.ctx.neighbors(rebuild=True)
        self._sync_neighbors()

    def _sync_neighbors(self) -> None:
        """Take the context's list if it changed since the last view."""
        ctx = self.ctx
        if ctx.nbrs_version != self._nbrs_version or self.nbrs is None:
            t0 = time.perf_counter()
            if _is_fluid_view(ctx):  # built as the fluid's view: nothing to copy
                self._view = None
                self._new_list()
            else:
                self._set_view(ctx.nbrs)
            self._nbrs_version = ctx.nbrs_version
            self.wall["neighbors"] += time.perf_counter() - t0
        elif self._scratch is None or self._scratch.n != self.p.n:
            self._scratch = _Scratch(self.p.n, self.dim, self.params.uses_free_surface)

    def after_drift(self) -> None:
        """Make the list valid for the current (drifted) positions."""
        self.ctx.neighbors()
        self._sync_neighbors()

    def reorder(self, perm: np.ndarray) -> None:
        """The particle fields were permuted by ``perm``: permute the mid-step state."""
        s = self._scratch
        if s is not None and s.n == perm.shape[0]:
            s.v_n = np.ascontiguousarray(s.v_n[perm])
            s.rho_n = np.ascontiguousarray(s.rho_n[perm])

    # -- forces ---------------------------------------------------------------------------
    def body_force(self, t: float) -> np.ndarray:
        """Body force per unit mass at time ``t`` (with the optional smooth ramp)."""
        tr = self.params.gravity_ramp
        if tr > 0 and t < tr:
            return self.gravity * 0.5 * (1.0 - math.cos(math.pi * t / tr))
        return self.gravity

    def evaluate(self, t: float | None = None) -> None:
        """Pressures, wall states, density gradient, accelerations and density rates at the
        current positions (``t``: time of the evaluation, for the body-force ramp).  Under a
        pressure-projection method (:mod:`sphfem.fluid.pressure`, ``eos`` False) the forces
        are those without pressure and ``p`` keeps the method's values."""
        t0 = time.perf_counter()
        p, s, pa, nl = self.p, self._scratch, self.params, self.nbrs
        g = self.body_force(self.t if t is None else t)
        eos = self.pressure_method.eos  # False: a projection method owns p (no pressure here)
        p_own = None if eos else p.p.copy()
        passes.prepare_fluid(p.rho, p.m, p.v, p.kind, pa.rho0, self.B, pa.gamma, p.p, s.vg)
        self.wall_method.wall_state(self, g)  # the registered wall model
        passes.prepare_all(p.rho, p.p, p.m, p.vol, p.kind, s.pr, s.V, s.meff, s.isf)
        rheology.update_viscosity(self)  # apparent viscosity mu_i (Newtonian: nothing)
        if not eos:  # forces without pressure: p / rho^2 = 0 in the pass, p stays the method's
            s.pr[:] = 0.0
            p.p[:] = p_own
        # the delta-SPH term only feeds drho, which a projection method does not use (it sums
        # the density itself): no diffusive term, so no density gradient unless shifting needs it
        delta_coef = pa.delta * self.h * pa.c0 if eos else 0.0
        # in-range rows as positions in the list rows (uint16, 2 B per listed pair; the
        # passes' position form) in the thread's work buffer (free between two list builds;
        # the list itself is left untouched), a view dropped at the end of the evaluation
        m = nl.indices.shape[0]
        nb = (work_buffer(2 * m).view(np.uint16), nl.indices)
        cnt = s.cnt
        if delta_coef > 0 or pa.shifting != "none":
            passes.density_gradient(p.x, p.rho, s.V, p.kind, nl.offsets, nl.indices, self.R,
                                    self.sigma, self.kernel_code, self.period, pa.cond_max, s.grad,
                                    s.ok, nb, cnt)
            self.last_fallbacks = int(np.count_nonzero(~s.ok))
        else:
            passes.compact_rows(p.x, p.kind, nl.offsets, nl.indices, self.R, self.period, nb,
                                cnt)
        if not self.compact_rows:  # reference path: the full view (tests, profiling)
            nb, cnt = nl.indices, np.diff(nl.offsets)
        if self.visc_method is None or self.visc_method.fused:
            fused_mu = p.mu
        else:  # the model's own pass adds the viscous term: none in the fused pass
            if s.mu0 is None:
                s.mu0 = np.zeros(p.n)
            fused_mu = s.mu0
        passes.pack_rows(p.x, p.v, s.vg, p.rho, s.pr, s.V, s.meff, s.isf, fused_mu, s.grad,
                         s.P)
        passes.fluid_forces(s.P, p.kind, nl.offsets, cnt, nb, self.R, self.sigma,
                            self.kernel_code, self.period, g, pa.eps_visc * self.h * self.h,
                            delta_coef, pa.alpha * self.h * pa.c0, p.acc, p.drho, p.f_fluid)
        if self.visc_method is not None and not self.visc_method.fused:  # its own pass
            self._visc_state = self.visc_method.accelerate(self, self._visc_state)
        if self.st_method is not None:  # the registered method (sphfem.fluid.surface_tension)
            self._st_state = self.st_method.accelerate(self, self._st_state)
        if pa.uses_free_surface:
            surface.free_surface(p.x, s.V, p.kind, nl.offsets, nl.indices, self.R,
                                 self.sigma, self.kernel_code, self.period, pa.cond_max, s.gc,
                                 s.nrm, s.lam, s.fs)
            surface.near_surface(p.kind, nl.offsets, nl.indices, s.fs, p.x, self.R,
                                 self.period, s.near)
            p.free_surface[:] = s.fs
        self.wall["forces"] += time.perf_counter() - t0

    # -- time stepping --------------------------------------------------------------------
    def dt_limits(self) -> dict[str, float]:
        """Acoustic, viscous and force limits [s] (see the module docstring)."""
        p, pa = self.p, self.params
        with _threads(self.nthreads):
            vmax, amax, rho_mu = _fluid_maxima(p.v, p.acc, p.rho, p.mu, p.kind)
        if self.pressure_method.eos:
            lim = {"acoustic": pa.cfl * self.h / (pa.c0 + vmax)}
        else:  # a pressure projection: the CFL condition of the flow, no speed of sound
            lim = {"cfl": pa.cfl * self.h / vmax} if vmax > 0 else {}
            amax = max(amax, float(np.linalg.norm(self.gravity)))  # a ramp starts at g = 0
        if np.isfinite(rho_mu) and not getattr(self.visc_method, "implicit", False):
            lim["viscous"] = pa.visc_cfl * self.h * self.h * rho_mu
        if amax > 0:
            lim["force"] = pa.force_cfl * math.sqrt(self.h / amax)
        if pa.density_cfl > 0.0:  # [fluid] density_cfl
            fl = p.kind == FLUID
            if fl.any():
                rate = float(np.max(np.abs(p.drho[fl]) / p.rho[fl]))
                if rate > 0.0:
                    lim["density"] = pa.density_cfl / rate
        if pa.surface_tension != "none" and self.st_sigma > 0:  # Brackbill et al. (1992)
            lim["capillary"] = 0.25 * math.sqrt(pa.rho0 * self.h**3
                                                / (2 * math.pi * self.st_sigma))
        return lim

    def stable_dt(self) -> tuple[float, str]:
        lim = self.dt_limits()
        name = min(lim, key=lim.get)
        return lim[name], name

    def step(self, dt: float) -> None:
        """One step of length ``dt`` of the pressure model (``[fluid] pressure``; for
    "wcsph" the ``[fluid] integrator``), then particle shifting."""
        with _threads(self.nthreads):
            self._step(dt)

    def _step(self, dt: float) -> None:
        self._sync_neighbors()
        self.step_dt = dt
        self.pressure_method.advance(self, dt)
        p, s = self.p, self._scratch
        t0 = time.perf_counter()
        pa = self.params
        if pa.shifting != "none":
            dr = np.zeros_like(p.x)
            surface.shift_displacement(p.x, p.v, p.kind, s.gc, s.nrm, s.near,
                                       pa.shifting_coef * self.h, dt, 0.1 * self.h,
                                       pa.shifting == "all",
                                       surface.shift_floor_speed(p.v, p.kind,
                                                                 pa.shifting_speed),
                                       surface.OWN_SPEED, dr)
            if pa.shifting_drift == "removed":
                nl = self.nbrs
                dr0, dr = dr, np.empty_like(dr)
                surface.remove_local_mean(dr0, p.x, p.kind == FLUID, nl.offsets, nl.indices,
                                          np.full(p.n, self.R), self.kernel_code,
                                          self.period, p.n, dr)
            surface.apply_shift(p.x, p.rho, s.grad, dr, 0.1 * self.h, s.shift)
            self.max_shift = max(self.max_shift, float(s.shift.max()))
        self.wall["integrate"] += time.perf_counter() - t0
        self.t += dt
        self.step_count += 1

    def check(self) -> None:
        """Stability guards (raise ``SimulationStopped`` with a clear message)."""
        t0 = time.perf_counter()
        try:
            with _threads(self.nthreads):
                self._check()
        except Exception as e:
            self.guard_message = str(e)
            raise
        finally:
            self.wall["guards"] += time.perf_counter() - t0

    def _check(self) -> None:
        p, pa = self.p, self.params
        check_fluid(p.x, p.v, p.rho, p.kind, self.lo, self.hi, self.period, pa.c0, pa.rho0,
                    pa.max_speed_factor, pa.rho_ratio_band, self.step_count, self.t)

    def run(self, t_end: float, callback=None, every: float | None = None,
            max_steps: int | None = None) -> dict:
        """Step to ``t_end`` with the adaptive dt; call ``callback(self)`` every ``every`` s.

        Returns counts of the controlling dt limit and the step count.
        """
        counts: dict[str, int] = {}
        next_cb = self.t + every if every else math.inf
        while self.t < t_end * (1 - 1e-12):
            if max_steps is not None and self.step_count >= max_steps:
                break
            dt, name = self.stable_dt()
            dt = min(dt, t_end - self.t, max(next_cb - self.t, 1e-300))
            self.step(dt)
            self.check()
            counts[name] = counts.get(name, 0) + 1
            if callback is not None and self.t >= next_cb * (1 - 1e-12):
                callback(self)
                next_cb += every
        return {"steps": self.step_count, "controlling_limit_counts": counts}

    def total_fluid_force_on_walls(self) -> np.ndarray:
        """Sum of ``f_fluid`` over wall particles [N] (the fluid's force on the walls)."""
        return self.p.f_fluid.sum(axis=0)

    def diagnostics(self) -> dict:
        p, pa = self.p, self.params
        fl = p.kind == FLUID
        speed = np.sqrt((p.v[fl] ** 2).sum(axis=1)) if fl.any() else np.zeros(1)
        ratio = p.rho[fl] / pa.rho0 if fl.any() else np.ones(1)
        finite = bool(np.isfinite(speed).all() and np.isfinite(ratio).all())
        lims = self.dt_limits() if finite else {}
        return {
            "fluid_particles": int(fl.sum()),
            "steps": self.step_count,
            "neighbor_rebuilds": self.n_rebuilds,
            "renormalisation_fallbacks": self.last_fallbacks,
            "max_speed": float(np.nanmax(speed)) if finite else None,
            "max_speed_over_c0": float(np.nanmax(speed)) / pa.c0 if finite else None,
            "rho_ratio_range": [float(np.nanmin(ratio)), float(np.nanmax(ratio))],
            "dt_limits_s": {k: float(v) for k, v in lims.items()},
            "surface_tension": {
                "model": pa.surface_tension, "sigma_N_per_m": pa.sigma,
                "constant": self.st_constant,
                "sigma_of_constant_N_per_m": self.st_sigma if self.st_constant else None,
            },
            "free_surface_particles": (int(np.count_nonzero(self._scratch.fs))
                                       if pa.uses_free_surface else None),
            "shifting": {"mode": pa.shifting, "max_shift_over_h": self.max_shift / self.h},
            "guards": {
                "status": "tripped" if self.guard_message else "ok",
                "message": self.guard_message,
                "max_speed_factor": pa.max_speed_factor,
                "rho_ratio_band": list(pa.rho_ratio_band),
            },
            "wall_s": dict(self.wall),
            "viscosity_solve": (self._visc_state.to_dict()
                                if hasattr(self._visc_state, "to_dict") else None),
            "pressure_solve": (self.pressure_state.to_dict()
                               if hasattr(self.pressure_state, "to_dict") else None),
        }


def fluid_materials(scene) -> list[str]:
    """Names of the materials of the scene's fluid blocks (in scene order, unique)."""
    return list(dict.fromkeys(b.material for b in scene.blocks if b.kind == "fluid"))


def params_from_scene(scene) -> FluidParams:
    """:class:`FluidParams` from the ``[fluid]`` section and the fluid materials.

    rho0, c0 and sigma are shared by all fluid materials (the Tait EOS and the surface
    tension use one value; the scene check enforces it); mu is per particle.
    """
    cfg = scene.fluid
    mats = [scene.materials[m] for m in fluid_materials(scene)]
    if not mats:
        raise ValueError("fluid: the scene has no fluid block")
    m0 = mats[0]
    kw = {}
    if cfg is not None:
        names = FluidParams.__dataclass_fields__
        kw = {k: cfg[k] for k in cfg if k in names}
        kw["rho_ratio_band"] = tuple(cfg.rho_ratio_band)
        kw["gravity"] = tuple(cfg.gravity)
        method = surface_tension.lookup(cfg.surface_tension)
        if method is not None:
            kw["st_params"] = {q.name: cfg[q.name] for q in method.params if q.name in cfg}
    kw["cfl"] = scene.time.cfl
    kw["skin"] = 0.15 if scene.sph.skin is None else scene.sph.skin
    kw["sort_every"] = scene.sph.sort_every
    kw["rho0"] = m0.rho0
    kw["c0"] = m0.c0
    kw["mu"] = 0.0 if (cfg is not None and cfg.viscosity == "none") else (m0.mu or 0.0)
    kw["sigma"] = m0.sigma or 0.0
    return FluidParams(**kw)


class FluidModule(PhysicsModule):
    """The ``fluid`` physics module: a :class:`FluidSolver` driven by the simulation.

    Parameters come from the ``[fluid]`` section and the fluid materials
    (:func:`params_from_scene`), or from ``scene.fluid`` when it is a
    :class:`FluidParams`.  The solver uses the driver's shared Verlet-skin list and
    permutes its mid-step state in :meth:`reorder` when the driver cell-sorts.
    """

    name = "fluid"
    moves_particles = True
    #: the pairs the fluid reads (its view): when no other module reads the list, the
    #: driver builds it with this filter (:class:`~sphfem.simulation.Simulation`)
    neighbor_filter = passes.VIEW_KEEP

    def __init__(self, scene):
        super().__init__(scene)
        cfg = getattr(scene, "fluid", None)
        self.params = cfg if isinstance(cfg, FluidParams) else params_from_scene(scene)
        self.solver = None
        #: :class:`~sphfem.fluid.packing.PackingReport` of ``[fluid.packing]`` (None: off)
        self.packing_report = None

    def fields(self):
        dim = self.scene.dim
        return {k: (np.float64, dim if nc == "dim" else nc)
                for k, nc in fluid_fields(self.params).items()}

    def init(self, ctx) -> None:
        ps = ctx.particles
        fl = ps.kind == FLUID
        names = list(self.scene.materials)
        if not isinstance(getattr(self.scene, "fluid", None), FluidParams):
            visc = self.scene.fluid is None or self.scene.fluid.viscosity != "none"
            for name in fluid_materials(self.scene):
                sel = fl & (ps.material == names.index(name))
                ps.mu[sel] = (self.scene.materials[name].mu or 0.0) if visc else 0.0
        if self.packing_report is None and ctx.step == 0 and ctx.t == 0.0:
            self._pack(ctx)
        self.solver = FluidSolver(ps, ctx.R, ctx.lo, ctx.hi, ctx.period, self.params,
                                  kernel=self.scene.sph.kernel, ctx=ctx)
        self.solver.t = ctx.t  # a resumed run keeps its body-force ramp
        self.solver.step_count = ctx.step

    def _pack(self, ctx) -> None:
        """``[fluid.packing]``: relax the fluid particles against the walls (once, before
        the first step; :func:`sphfem.fluid.packing.pack`), then rebuild the list."""
        cfg = getattr(self.scene, "fluid", None)
        pk = getattr(cfg, "packing", None) if not isinstance(cfg, FluidParams) else None
        if pk is None or pk.iterations <= 0:
            return
        from sphfem.fluid.packing import pack

        ps = ctx.particles
        fl = ps.kind == FLUID
        wall = ps.kind == WALL
        dx = self.scene.sph.dx
        x, rep = pack(ps.x[fl], ps.x[wall], dx, ctx.R, ctx.lo, ctx.hi, ctx.period,
                      vol_fixed=ps.vol[wall], iterations=pk.iterations, tol=pk.tolerance,
                      jitter=pk.jitter, seed=pk.seed, kernel=self.scene.sph.kernel)
        ps.x[fl] = x
        self.packing_report = rep
        logger.info("fluid packing: %d iterations, residual %.3g (tolerance %.3g), largest "
                    "shift %.3g dx", rep.iterations, rep.residual, pk.tolerance,
                    rep.max_shift_over_dx)
        ctx.neighbors(rebuild=True)  # the packed positions

    def dt_limits(self, ctx) -> dict[str, float]:
        return self.solver.dt_limits()

    def step(self, ctx, dt: float) -> None:
        self.solver.step(dt)
        self.solver.check()

    def reorder(self, ctx, perm) -> None:
        self.solver.reorder(perm)

    def diagnostics(self, ctx) -> dict:
        out = self.solver.diagnostics()
        if self.packing_report is not None:
            out["packing"] = self.packing_report.to_dict()
        return out


register_physics("fluid", "sphfem.fluid.wcsph:FluidModule")
