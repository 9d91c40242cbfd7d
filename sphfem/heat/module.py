"""``HeatConduction``: the ``heat`` physics module (protocol of :mod:`sphfem.physics`).

On ``init`` it reads c and k per material and places ghost particles for the scene's
boundaries (algorithm 2.5; none across the domain's periodic axes), which it returns as
kind GHOST for the driver to append (the driver rebuilds the neighbour list once); then, in
``appended``, it builds the conduction system and its stepper: explicit Heun at ``cfl``
times the stable step, or the theta method at ``dt`` or ``implicit_dt_factor`` times it.
``diagnostics`` reports the explicit limit, the fallbacks of the corrected operator, the
ghost counts and the energy ledger (drift and balance).

Moving particles (another module has ``moves_particles``, ``ctx.moving``): the driver keeps
a Verlet-skin list (pairs within (1 + skin) R, rebuilt only when a particle moved more
than skin R / 2), so conductances computed once per list would use stale distances
(pairs that came within R after the build would exchange no heat, pairs that separated
would keep theirs).  Therefore every step the system is rebuilt when the list changed and
otherwise refreshed from the current positions and volumes
(:meth:`~sphfem.heat.system.HeatSystem.refresh`: one numba pass for the Cleary form, the
corrected form's renormalisation and limiter per particle for ``fatehi_manzari``) along
with the explicit limit (an O(pairs) Gershgorin pass).  The ghosts are placed once:
their sources, types and mirror ratios stay; ghosts of fluid particles stay in place, those
of solid particles move with their source (:meth:`HeatConduction._move_ghosts`).  What
stays as built until the next neighbour rebuild: the free-surface plain rows of the
corrected form (:func:`~sphfem.heat.problem.free_surface_rows`) and the particle set.  The explicit
limit the driver sees is that of the last refresh (the positions at the end of the
previous step); the step's own positions may allow a slightly smaller one
(``dt_over_fresh_limit_max`` in ``diagnostics``: the largest dt over cfl x the limit of
the positions the step used).  The implicit theta method reassembles and refactorises its
matrix every step in a moving scene (one sparse LU per step, ``factorisations``): correct
but costly; where the mover's step is far below the thermal limit (fluids) use
``heat.time_integration = "explicit"``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sphfem.errors import SimulationStopped
from sphfem.heat.params import HeatParams, params_from_scene
from sphfem.particles import GHOST, SOLID, ParticleSet
from sphfem.physics import PhysicsModule


class HeatConduction(PhysicsModule):
    name = "heat"

    def __init__(self, scene, params: HeatParams | None = None):
        super().__init__(scene)
        self.params = params if params is not None else params_from_scene(scene)
        self.system = None

    def fields(self):
        return {"T": (np.float64, 1), "c_heat": (np.float64, 1), "k_heat": (np.float64, 1)}

    # -- set-up --------------------------------------------------------------------------
    def init(self, ctx) -> ParticleSet | None:
        """Material properties, initial temperature and the ghost particles to append (a
        resumed run comes without ghosts: the driver drops them, they are placed anew)."""
        from sphfem.heat.ghosts import place_ghosts
        from sphfem.heat.problem import faces_of

        prm = self.params
        ps = ctx.particles
        for mid, mat in prm.materials.items():
            sel = ps.material == mid
            ps.c_heat[sel] = mat.c
            ps.k_heat[sel] = mat.k
        if np.any(ps.c_heat <= 0):
            raise ValueError("heat: every material needs a positive specific heat c")
        if prm.initial_temperature is not None:
            ps.T[:] = prm.initial_temperature
        faces = faces_of(prm.boundaries)
        dx = float(np.median(ps.vol)) ** (1.0 / ps.dim)
        gh = place_ghosts(ps.x, ps.vol, dx, ctx.R, faces, eta_place=prm.eta_place,
                          eta_trim=prm.eta_trim, neumann_source=prm.insulated_source,
                          kernel=ctx.kernel, period=ctx.period, lo=ctx.lo)
        self.ghosts = gh
        self.faces = faces
        # ghosts of solid particles follow their source's displacement (see _move_ghosts)
        self._follow = ps.kind[gh.source] == SOLID
        self._ghost_x0 = gh.x.copy()
        self._source_x0 = ps.x[gh.source].copy()
        self._ghost_source = gh.source.copy()
        if not gh.n:
            self.appended(ctx, np.arange(ps.n, ps.n))
            return None
        s = gh.source
        g = ParticleSet.from_arrays(gh.x, m=ps.m[s], rho=ps.rho[s], kind=GHOST,
                                    material=ps.material[s])
        for f in ("T", "c_heat", "k_heat"):
            g.fields[f] = ps.fields[f][s].copy()
        return g

    def appended(self, ctx, index: np.ndarray) -> None:
        """The ghosts are at ``index`` of the particle set: build the system on the list."""
        prm, ps, gh = self.params, ctx.particles, self.ghosts
        self.refreshes = 0
        self.dt_over_limit = 0.0
        self._ghost_index = np.asarray(index, np.int64)
        self._build(ctx)
        from sphfem.heat.energy import EnergyLedger

        self.ledger = EnergyLedger(self.system.energy(ps.T, ps.m, ps.c_heat))
        self.stable_dt_explicit = self.system.stable_dt()
        real = ps.T[ps.kind != GHOST]
        walls = gh.t_wall[np.isfinite(gh.t_wall)] if gh.n else np.zeros(0)
        lo = min(float(real.min()), float(walls.min()) if walls.size else np.inf)
        hi = max(float(real.max()), float(walls.max()) if walls.size else -np.inf)
        if getattr(self, "bounds", None) is None:  # a resumed run keeps the original range
            width = max(hi - lo, 1e-12 * max(abs(lo), abs(hi), 1.0))
            m = prm.bound_margin * width
            self.bounds = (lo - m, hi + m)
        self.T_range = [float(real.min()), float(real.max())]

    def _build(self, ctx) -> None:
        from sphfem.heat.problem import free_surface_rows
        from sphfem.heat.stepping import ExplicitStepper, ThetaStepper
        from sphfem.heat.system import HeatSystem

        prm, ps = self.params, ctx.particles
        args = ctx.kernel_args
        active = ps.kind != GHOST
        plain = (free_surface_rows(args, prm.free_surface_plain, self.faces)
                 if prm.laplacian != "cleary" else None)
        gh = self.ghosts
        self.system = HeatSystem(args, ps.m * ps.c_heat / ps.vol, ps.k_heat, active,
                                 self._ghost_index, gh.type, self._ghost_source, gh.t_wall,
                                 laplacian=prm.laplacian, dirichlet_mode=prm.dirichlet_ghosts,
                                 plain_rows=plain, ghost_ratio=gh.ratio,
                                 limiter=prm.positivity_limiter)
        self.system.apply_ghosts(ps.T)
        old = getattr(self, "stepper", None)
        if prm.time_integration == "explicit":
            self.stepper = ExplicitStepper(self.system)
        else:
            self.stepper = ThetaStepper(self.system, prm.theta, prm.startup)
            if isinstance(old, ThetaStepper):  # a rebuild: Rannacher start-up only once
                self.stepper.steps = old.steps
                self.stepper.factorisations = old.factorisations
        self._nbrs_version = ctx.nbrs_version
        self.builds = getattr(self, "builds", 0) + 1
        self.dt_min_explicit = min(getattr(self, "dt_min_explicit", np.inf),
                                   self.system.stable_dt())

    def _refresh(self, ctx) -> None:
        """Conductances, boundary conductances and explicit limit from the current
        positions and volumes on the unchanged neighbour list (moving particles)."""
        ps = ctx.particles
        self.system.refresh(ctx.kernel_args, ps.m * ps.c_heat / ps.vol)
        if self.params.time_integration != "explicit":
            self.stepper.refresh()
        self.refreshes += 1
        self.dt_min_explicit = min(self.dt_min_explicit, self.system.stable_dt())

    # -- stepping ------------------------------------------------------------------------
    def dt_limits(self, ctx) -> dict[str, float]:
        prm = self.params
        dt0 = self.system.stable_dt()
        if prm.time_integration == "explicit":
            return {"thermal": prm.cfl * dt0}
        if prm.dt is not None:
            return {"thermal_implicit": prm.dt}
        if prm.implicit_dt_factor is not None:
            return {"thermal_implicit": prm.implicit_dt_factor * dt0}
        return {}

    def _move_ghosts(self, ctx) -> None:
        """Ghosts of solid particles move with their source: x_g = x_g0 + (x_s - x_s0)
        (minimum image), placement-time positions x_g0, x_s0.  A deforming solid carries
        its faces along (a heated bar's end moves by the thermal expansion), and ghosts
        left at their placement would change the gap to the real particles next to them,
        by u / dx of the spacing, an error that grows with resolution.  Ghosts of fluid
        particles stay (a wall does not move with the fluid).  The list is then checked
        again, as the driver checks it before the step, since the ghosts moved after it."""
        ps = ctx.particles
        f = self._follow
        d = ps.x[self._ghost_source[f]] - self._source_x0[f]
        per = ctx.period
        d -= np.where(per > 0, per * np.floor(d / np.where(per > 0, per, 1.0) + 0.5), 0.0)
        ps.x[self._ghost_index[f]] = self._ghost_x0[f] + d
        ctx.neighbors()

    def step(self, ctx, dt: float) -> None:
        if ctx.moving and self._follow.any():
            self._move_ghosts(ctx)
        if ctx.nbrs_version != self._nbrs_version:  # a new list (or a re-sort): build on it
            self._build(ctx)
        elif ctx.moving:  # same list, moved particles: conductances from the positions
            self._refresh(ctx)
        if ctx.moving and self.params.time_integration == "explicit":
            lim = self.params.cfl * self.system.stable_dt()
            self.dt_over_limit = max(self.dt_over_limit, dt / lim)
        ps = ctx.particles
        heat = self.stepper.step(ps.T, dt)
        self.ledger.record(self.system.energy(ps.T, ps.m, ps.c_heat), heat)
        self._check_bounds(ctx)

    def _check_bounds(self, ctx) -> None:
        """Stop the run when a temperature leaves the maximum-principle range (or is NaN)."""
        lo, hi = _min_max(ctx.particles.T, self.system.active)
        self.T_range = [lo, hi]
        b_lo, b_hi = self.bounds
        if lo >= b_lo and hi <= b_hi:  # False for NaN
            return
        T = ctx.particles.T[self.system.active]
        bad = ~((T >= b_lo) & (T <= b_hi))
        raise SimulationStopped(
            f"heat stopped at step {ctx.step + 1}, t = {ctx.t:.6g} s: {int(bad.sum())} "
            f"particle(s) with temperature outside [{b_lo:.6g}, {b_hi:.6g}] K (min "
            f"{lo:.6g}, max {hi:.6g}), the initial/wall range widened by heat.bound_margin = "
            f"{self.params.bound_margin:g}; conduction cannot create extremes, so the "
            "explicit step is above its stable limit (keep [time] cap_dt = true, or use "
            "heat.time_integration = \"implicit\")")

    def reorder(self, ctx, perm) -> None:
        """Remap the cached ghost indices after the driver's cell sort."""
        new_of_old = np.empty_like(perm)
        new_of_old[perm] = np.arange(perm.shape[0])
        self._ghost_index = new_of_old[self._ghost_index]
        self._ghost_source = new_of_old[self._ghost_source]
        self._nbrs_version = -1  # conductances are rebuilt from the new list on the next step

    def diagnostics(self, ctx) -> dict:
        s = self.system
        ps = ctx.particles
        a = s.active
        dx2 = (ps.vol[a] ** (2.0 / ps.dim))
        rows = np.repeat(np.arange(s.n), np.diff(s.offsets))
        gsum = np.bincount(rows, weights=np.abs(s.g), minlength=s.n)[a]
        with np.errstate(divide="ignore", invalid="ignore"):
            C = np.where(gsum > 0, s.k[a] / (gsum * dx2), np.inf)
        return {
            "laplacian": s.laplacian,
            "time_integration": self.params.time_integration,
            "explicit_stable_dt_s": self.stable_dt_explicit,
            "explicit_dt_constant_C": float(C.min()) if C.size else None,
            "fallbacks": s.fallbacks,
            "limited_rows": s.limited,
            "free_surface_plain_rows": int(s.plain_rows.sum()),
            "system_builds": self.builds,
            "conductance_refreshes": self.refreshes,
            "explicit_stable_dt_min_s": self.dt_min_explicit,
            "dt_over_fresh_limit_max": (self.dt_over_limit if ctx.moving and
                                        self.params.time_integration == "explicit" else None),
            "factorisations": getattr(self.stepper, "factorisations", None),
            "ghosts": dict(self.ghosts.stats),
            "T_range_K": list(self.T_range),
            "T_bounds_K": list(self.bounds),
            **self.ledger.to_dict(),
        }


@njit(cache=True)
def _min_max(a, mask):
    """(min, max) of ``a`` where ``mask`` (no copy in the step); NaN when one is NaN."""
    lo, hi = np.inf, -np.inf
    for i in range(a.shape[0]):
        if not mask[i]:
            continue
        v = a[i]
        if v != v:
            return np.nan, np.nan
        lo = min(lo, v)
        hi = max(hi, v)
    return lo, hi

