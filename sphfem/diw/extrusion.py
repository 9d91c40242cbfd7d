"""Nozzle extrusion of direct ink writing: a moving nozzle lays ink onto a substrate.

The physics behind :func:`simulate_deposit` (issue 18; Park 2019 ch. 3, whose deposition
runs use DFSPH with Weiler et al.'s implicit viscosity in SPlisHSPlasH):

* **Ink**: the scene's fluid (``[fluid]``: pressure solver, viscosity model and rheology,
  e.g. ``pressure = "dfsph"``, ``viscosity = "weiler-implicit"``, ``rheology =
  "herschel-bulkley"``), stepped by :class:`sphfem.fluid.wcsph.FluidSolver`.
* **Nozzle**: a tube of wall particles (``wall_layers`` rings of radius
  D/2 + (k + 1/2) dx around the bore of diameter D, rings dx apart along the axis) whose
  outlet is ``standoff`` above the substrate's top face z0.  Its particles keep their
  offsets from the nozzle point P(t) = (path.position(t), z0): each step they are moved to
  P(t^{n+1}) + offset and carry the velocity (path.velocity(t^n + dt/2), 0), so the Adami
  walls see the displacement they make.  The motion is applied right after the ink's drift,
  through the context's list service (:class:`_NozzleService`), so the evaluation at
  x^{n+1} sees the nozzle where it is.
* **Inflow** (an inflow buffer, as in the open-boundary SPH of Federico et al. 2012,
  Eur. J. Mech. B 34, 35): ``wall_layers`` rigid layers of the bore's lattice (N_b points,
  spacing dx) move down the bore as a piston at speed U_b; a layer whose centre passes the
  buffer's lower plane z_r becomes ink and a new layer enters dx above the top one.  One
  layer (N_b dx^3 of ink) is released each time the piston moves dx, so the volume flux is

      Q = N_b dx^2 U_b   =>   U_b = Q / (N_b dx^2)

  exactly for the lattice, whatever the staircase of the disc (N_b dx^2 vs pi D^2 / 4 is
  reported as ``bore_area_ratio``).  Layers are dx apart by construction, so emission
  never overlaps particles.  The bore below z_r is full of ink at t = 0 (``fill_length``).
* **Substrate**: the scene's box wall block, kept within ``substrate_margin`` of the path.

With ``start_dwell`` the nozzle first extrudes at the path's start for that long (priming:
the ink reaches the substrate before the nozzle moves).  With ``coast_distance`` c the piston
stops when the nozzle is c (along its path, at ``nozzle_speed``) from the end, and the nozzle
coasts on to the end without extruding: a slicer's "coasting" (e.g. Cura's), which lays
down the ink already between the outlet and the substrate instead of heaping it at the end
point.  With ``end_ramp`` l the nozzle decelerates uniformly to rest over the last l of its
path (taking 2 l / v instead of l / v) and the flux follows its speed, Q v(t) / v, so the
bead keeps its cross-section while the ink leaving the outlet slows down with the nozzle:
the forward speed that ink still in the air carries past the end point goes to zero (a
printer's deceleration with its flow tied to the feed rate).  After the path the nozzle
stops and the run goes on for ``settle_time``.  The deposit is the ink below the outlet
plane at the end.  Measured (:attr:`DepositResult.info`): the emitted volume against
Q t, the ink that left the outlet, the least pair distance at emission, the step sizes
and the controlling limits.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from sphfem.diw import scene_section  # noqa: F401  (registers [extrusion])
from sphfem.errors import SceneError, SimulationStopped
from sphfem.fluid.setup import lattice
from sphfem.fluid.wcsph import FluidSolver, fluid_materials, params_from_scene
from sphfem.particles import FLUID, WALL, ParticleSet
from sphfem.physics import PhysicsModule

logger = logging.getLogger(__name__)

#: values of the particle field ``role``
INK, TUBE, BUFFER, SUBSTRATE = 0, 1, 2, 3


@dataclass
class DepositResult:
    """What one extrusion run deposited (the contract of :mod:`sphfem.diw`).

    ``positions`` (n, 3) of the ink below the nozzle outlet at the end [m]; ``h`` the
    smoothing length R/2 [m]; ``nozzle_diameter`` [m]; ``info`` (``steps``, ``wall_s``,
    ``stopped_reason`` (None when the run finished) and the measurements of the module
    docstring); ``vtu`` the deposit's VTU file or None.
    """

    positions: np.ndarray
    h: float
    nozzle_diameter: float
    info: dict = field(default_factory=dict)
    vtu: str | None = None


# --------------------------------------------------------------------------------------
# geometry


def bore_lattice(D: float, dx: float) -> np.ndarray:
    """Points (m, 2) of the square lattice of spacing dx, symmetric about the axis, whose
    centres lie inside the disc of diameter D (|r| < D/2): one layer of the bore."""
    k = int(math.ceil(0.5 * D / dx)) + 1
    if round(D / dx) % 2 == 0:  # even D/dx: the axis between four points
        c = (np.arange(-k, k) + 0.5) * dx
    else:  # odd: a point on the axis
        c = np.arange(-k, k + 1) * dx
    X, Y = np.meshgrid(c, c, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], 1)
    r = np.hypot(pts[:, 0], pts[:, 1])
    return np.ascontiguousarray(pts[r < 0.5 * D * (1 - 1e-12)])


def tube_rings(D: float, dx: float, layers: int, z_lo: float, n_axial: int) -> np.ndarray:
    """Wall particles (n, 3) of the nozzle tube: ``layers`` rings at radius
    D/2 + (k + 1/2) dx (round(2 pi r / dx) points each), ``n_axial`` ring heights
    z_lo + (j + 1/2) dx; every other height turned by half a spacing."""
    out = []
    for k in range(layers):
        r = 0.5 * D + (k + 0.5) * dx
        n = max(3, int(round(2 * math.pi * r / dx)))
        for j in range(n_axial):
            th = (np.arange(n) + 0.5 * (j % 2)) * 2 * math.pi / n
            z = np.full(n, z_lo + (j + 0.5) * dx)
            out.append(np.stack([r * np.cos(th), r * np.sin(th), z], 1))
    return np.ascontiguousarray(np.concatenate(out))


def path_samples(path, spacing: float) -> np.ndarray:
    """Points (n, 2) along ``path`` no farther apart than about ``spacing``."""
    T = float(path.duration)
    coarse = np.array([path.position(t) for t in np.linspace(0.0, T, 65)])
    length = float(np.linalg.norm(np.diff(coarse, axis=0), axis=1).sum())
    n = max(2, int(math.ceil(4 * length / spacing)) + 1)
    return np.array([path.position(t) for t in np.linspace(0.0, T, n)], dtype=float)


# --------------------------------------------------------------------------------------
# the nozzle


class Nozzle:
    """The moving nozzle and its inflow buffer on a :class:`ParticleSet` (fields ``role``
    and ``offset``: a tube or buffer particle sits at P(t) + offset, P = (path xy, z0))."""

    def __init__(self, scene, path, z0: float, rho0: float):
        ex = scene.extrusion
        self.path = path
        self.dx = scene.sph.dx
        self.D = ex.nozzle_diameter
        self.z0 = z0
        self.rho0 = rho0
        self.z_out = z0 + ex.standoff
        self.layers = ex.wall_layers or int(math.ceil(scene.sph.support_factor))
        fill = ex.fill_length if ex.fill_length is not None else self.D
        self.n_fill = max(1, int(round(fill / self.dx)))
        self.z_r = self.z_out + self.n_fill * self.dx  # the buffer's lower plane
        self.disc = bore_lattice(self.D, self.dx)
        self.area_bore = self.disc.shape[0] * self.dx**2
        self.Q = ex.flow_rate if ex.flow_rate is not None else (
            ex.extrusion_speed * math.pi * self.D**2 / 4)
        self.U_b = self.Q / self.area_bore  # piston speed: Q exactly for the lattice
        self.dwell = float(ex.start_dwell)  # extruding at the start before moving
        # path time tau (the path's own clock, constant speed v0) against run time t:
        # tau = t - dwell up to tau_r, then the nozzle decelerates uniformly to rest over
        # the last end_ramp of the path, which takes T_r = 2 end_ramp / v0 (module docstring)
        v0 = float(ex.nozzle_speed)
        self.T_path = float(path.duration)
        ramp = min(float(ex.end_ramp), v0 * self.T_path)
        self.tau_r = self.T_path - ramp / v0
        self.T_r = 2.0 * ramp / v0
        self.duration = self.dwell + self.tau_r + self.T_r  # the nozzle stops here
        #: extrusion stops here: when the nozzle is coast_distance from the path's end
        self.t_stop = self.t_of_tau(max(self.T_path - float(ex.coast_distance) / v0, 0.0))
        self.ink_material = 0
        self.buffer_material = 0
        self.released = 0  # buffer particles turned into ink
        self.emissions = 0
        self.min_gap = math.inf  # least pair distance among bore particles at emission
        self.target_t = None  # time the nozzle moves to at the next drift
        self.t_pos = 0.0  # time of the tube's and buffer's current positions
        self.drift_fraction = 1.0  # of a step, where the ink's drift leaves it (set_velocities)
        self.emit_in_drift = True  # emit inside the drift (projection) or between steps
        self.mu_ink = None  # a Newtonian ink's mu for released particles (else the rheology's)
        self.gravity = np.zeros(3)  # acceleration of a released particle until evaluated

    # -- kinematics ----------------------------------------------------------------------
    def tau(self, t: float) -> tuple[float, float]:
        """Path time tau(t) and its rate dtau/dt: 0 during the dwell, t - dwell until
        tau_r, then w - w^2 / (2 T_r) past tau_r (w = t - dwell - tau_r: the speed falls
        linearly to 0 at ``duration``), T_path after."""
        u = t - self.dwell
        if u <= 0.0:
            return 0.0, 0.0
        if u <= self.tau_r:
            return u, 1.0
        w = u - self.tau_r
        if w >= self.T_r:
            return self.T_path, 0.0
        return self.tau_r + w - w * w / (2.0 * self.T_r), 1.0 - w / self.T_r

    def t_of_tau(self, tau: float) -> float:
        """Run time at which the nozzle reaches path time ``tau`` (inverse of :meth:`tau`)."""
        if tau <= self.tau_r or self.T_r == 0.0:
            return self.dwell + min(tau, self.tau_r)
        r = max(self.T_path - tau, 0.0) / (0.5 * self.T_r)  # share of the ramp still ahead
        return self.duration - self.T_r * math.sqrt(r)

    def P(self, t: float) -> np.ndarray:
        """Nozzle point (x, y, z0) at ``t``: path.position(tau(t))."""
        xy = np.asarray(self.path.position(self.tau(t)[0]), float)
        return np.array([xy[0], xy[1], self.z0])

    def V(self, t: float) -> np.ndarray:
        """Nozzle velocity at ``t``: path.velocity(tau) dtau/dt (zero during the dwell and
        after ``duration``)."""
        tau, rate = self.tau(t)
        if rate == 0.0:
            return np.zeros(3)
        v = np.asarray(self.path.velocity(tau), float) * rate
        return np.array([v[0], v[1], 0.0])

    def flux_factor(self, t: float) -> float:
        """Q(t) / Q: 1 during the dwell, dtau/dt while moving (the flux follows the nozzle's
        speed, so the bead keeps its cross-section through the ramp), 0 from ``t_stop``."""
        if t >= self.t_stop:
            return 0.0
        return 1.0 if t < self.dwell else self.tau(t)[1]

    def extruded_time(self, t: float) -> float:
        """Integral of the flux factor over [0, t] (emitted volume / Q)."""
        t = min(t, self.t_stop)
        return min(t, self.dwell) + self.tau(t)[0]

    def piston(self, t: float) -> float:
        """Speed of the buffer down the bore at ``t``: U_b Q(t) / Q."""
        return self.U_b * self.flux_factor(t)

    # -- set-up --------------------------------------------------------------------------
    def particles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Offsets of the tube walls, the buffer layers and the ink filling the bore."""
        n_axial = self.n_fill + self.layers + 1
        tube = tube_rings(self.D, self.dx, self.layers, self.z_out - self.z0, n_axial)
        buf = self._layers(self.z_r - self.z0, self.layers)
        fill = self._layers(self.z_out - self.z0, self.n_fill)
        return tube, buf, fill

    def _layers(self, z_lo: float, count: int) -> np.ndarray:
        m = self.disc.shape[0]
        out = np.zeros((m * count, 3))
        for j in range(count):
            out[j * m:(j + 1) * m, :2] = self.disc
            out[j * m:(j + 1) * m, 2] = z_lo + (j + 0.5) * self.dx
        return out

    # -- stepping ------------------------------------------------------------------------
    def set_velocities(self, ps: ParticleSet, t: float, dt: float) -> None:
        """Velocity of the tube and buffer particles over the step [t, t + dt] (midpoint),
        and the time of the ink's drifted positions (``drift_fraction`` of the step: 1 for
        a projection step, 1/2 for the symplectic predictor), where :meth:`move` puts the
        nozzle."""
        vm = self.V(t + 0.5 * dt)
        role = ps.role
        ps.v[role == TUBE] = vm
        vb = vm.copy()
        vb[2] -= self.piston(t + 0.5 * dt)
        ps.v[role == BUFFER] = vb
        self.target_t = t + self.drift_fraction * dt

    def travel(self, t0: float, t1: float) -> float:
        """Distance the piston moves down the bore between ``t0`` and ``t1``."""
        return self.U_b * (self.extruded_time(t1) - self.extruded_time(t0))

    def move(self, ps: ParticleSet, emit: bool = True) -> bool:
        """Move the nozzle to ``target_t`` (if set) and, with ``emit``, release the buffer
        layer that crossed z_r and add a layer on top; True when particles were appended."""
        if self.target_t is not None:
            t1 = self.target_t
            self.target_t = None
            buf = ps.role == BUFFER
            ps.offset[buf, 2] -= self.travel(self.t_pos, t1)
            moving = (ps.role == TUBE) | buf
            ps.x[moving] = self.P(t1) + ps.offset[moving]
            self.t_pos = t1
        return self.emit(ps) if emit else False

    def emit(self, ps: ParticleSet) -> bool:
        """Release the buffer layer whose centre passed z_r (it becomes ink) and add a new
        layer dx above the top one; True when particles were appended."""
        t1 = self.t_pos
        buf = ps.role == BUFFER
        zr = self.z_r - self.z0
        out = buf & (ps.offset[:, 2] < zr)
        if not out.any():
            return False
        # the crossing layer becomes ink; a new layer enters dx above the top one
        ps.kind[out] = FLUID
        ps.role[out] = INK
        ps.material[out] = self.ink_material
        ps.rho[out] = self.rho0
        ps.p[out] = 0.0
        if "mu" in ps and self.mu_ink is not None:
            ps.mu[out] = self.mu_ink
        ps.acc[out] = self.gravity
        self.released += int(out.sum())
        released_ids = ps.id[out].copy()
        top = float(ps.offset[buf & ~out, 2].max()) if (buf & ~out).any() else zr
        new = self._layers(top + 0.5 * self.dx, 1)
        add = ParticleSet.from_arrays(self.P(t1) + new, m=self.rho0 * self.dx**3,
                                      rho=self.rho0, kind=WALL,
                                      material=self.buffer_material)
        add.fields["role"] = np.full(add.n, BUFFER, np.int8)
        add.fields["offset"] = new
        add.fields["v"] = np.tile(ps.v[buf][0] if buf.any() else np.zeros(3), (add.n, 1))
        ps.append(add)
        self.emissions += 1
        new_ids = np.concatenate([released_ids, ps.id[-add.n:]])
        self._check_gap(ps, np.isin(ps.id, new_ids))
        return True

    def _check_gap(self, ps: ParticleSet, new: np.ndarray) -> None:
        """Least distance from the particles of this emission (the released layer and the
        layer added on top) to any other particle."""
        d, _ = cKDTree(ps.x).query(ps.x[new], k=2)
        self.min_gap = min(self.min_gap, float(d[:, 1].min()))


class _NozzleService:
    """The context's list service with the nozzle in it: moves the nozzle (and emits) right
    after the ink's drift, then asks the fluid's Verlet service for the list, rebuilt when
    particles were appended or the nozzle moved more than skin R / 2 since the last one."""

    def __init__(self, ctx, inner, nozzle: Nozzle, skin: float):
        self.ctx, self.inner, self.nozzle = ctx, inner, nozzle
        self.limit = 0.5 * skin * ctx.R
        self.version = -1
        self.ref = None
        self.forced = 0

    def __call__(self, rebuild: bool) -> None:
        ps = self.ctx.particles
        appended = self.nozzle.move(ps, emit=self.nozzle.emit_in_drift)
        moving = (ps.role == TUBE) | (ps.role == BUFFER)
        if not (rebuild or appended) and self.ref is not None and self.ref.shape[0] == int(
                moving.sum()):
            d = ps.x[moving] - self.ref
            if float(np.einsum("ij,ij->i", d, d).max(initial=0.0)) > self.limit**2:
                rebuild = True
        if appended:
            rebuild = True
        if rebuild:
            self.forced += 1
        self.inner(rebuild)
        if self.ctx.nbrs_version != self.version:  # a new list: new reference positions
            self.version = self.ctx.nbrs_version
            moving = (ps.role == TUBE) | (ps.role == BUFFER)
            self.ref = ps.x[moving].copy()


# --------------------------------------------------------------------------------------
# the run


def _blocks(scene):
    ink = next(b for b in scene.blocks if b.kind == "fluid")
    sub = next(b for b in scene.blocks if b.kind == "wall")
    return ink, sub


def build(scene, path) -> tuple[ParticleSet, Nozzle]:
    """Particles of an extrusion run at t = 0: substrate, nozzle tube, buffer, filled bore."""
    if scene.extrusion is None:
        raise SceneError(scene.source, "physics.modules", "not an extrusion scene: list "
                                                          "\"extrusion\" in physics.modules")
    ink, sub = _blocks(scene)
    dx = scene.sph.dx
    rho0 = scene.materials[ink.material].rho0
    z0 = float(sub.hi[2])
    noz = Nozzle(scene, path, z0, rho0)
    names = list(scene.materials)
    noz.ink_material = names.index(ink.material)
    noz.buffer_material = names.index(ink.material)
    margin = scene.extrusion.substrate_margin or 4.0 * noz.D
    xs = lattice(sub.lo, sub.hi, dx)
    dist, _ = cKDTree(path_samples(path, dx)).query(xs[:, :2])
    xs = xs[dist <= margin]
    tube, buf, fill = noz.particles()
    P0 = noz.P(0.0)
    x = np.concatenate([fill + P0, xs, tube + P0, buf + P0])
    nf, ns, nt = fill.shape[0], xs.shape[0], tube.shape[0]
    kind = np.full(x.shape[0], WALL, np.int8)
    kind[:nf] = FLUID
    mat = np.full(x.shape[0], names.index(sub.material), np.int32)
    mat[:nf] = noz.ink_material
    mat[nf + ns + nt:] = noz.buffer_material
    ps = ParticleSet.from_arrays(x, m=rho0 * dx**3, rho=rho0, kind=kind, material=mat)
    ps.fields["vol"][:] = dx**3
    role = np.full(x.shape[0], SUBSTRATE, np.int8)
    role[:nf] = INK
    role[nf + ns:nf + ns + nt] = TUBE
    role[nf + ns + nt:] = BUFFER
    ps.fields["role"] = role
    off = np.zeros_like(x)
    off[nf + ns:] = np.concatenate([tube, buf])
    ps.fields["offset"] = off
    v = np.zeros_like(x)
    V0 = noz.V(0.0)
    v[:nf] = V0 + np.array([0.0, 0.0, -noz.piston(0.0)])
    ps.fields["v"] = v
    lo, hi = np.asarray(scene.domain.lo), np.asarray(scene.domain.hi)
    span = path_samples(path, dx)
    reach = 0.5 * noz.D + noz.layers * dx
    if (span.min(0) - reach < lo[:2]).any() or (span.max(0) + reach > hi[:2]).any() or (
            noz.z_r + (noz.layers + 1) * dx > hi[2]):
        raise SceneError(scene.source, "domain", "the nozzle leaves the domain along this "
                                                 "toolpath; enlarge [domain]")
    return ps, noz


def simulate_deposit(scene, path, out_dir=None) -> DepositResult:
    """Extrude the scene's ink along ``path`` and return the deposit (module docstring).

    ``path``: ``position(t) -> (2,)`` [m], ``velocity(t) -> (2,)`` [m/s], ``duration`` [s];
    ``out_dir``: folder for ``deposit.vtu`` (and ``run.pvd`` snapshots at ``[output]
    every``), or None.  A guard stop does not raise: ``info["stopped_reason"]`` says why.
    """
    t_wall = time.perf_counter()
    t_cpu = time.process_time()
    ps, noz = build(scene, path)
    params = params_from_scene(scene)
    ink, _ = _blocks(scene)
    mat = scene.materials[ink.material]
    solver = FluidSolver(ps, scene.support_radius, scene.domain.lo, scene.domain.hi,
                         np.zeros(3), params, kernel=scene.sph.kernel)
    noz.mu_ink = (mat.mu or 0.0) if params.rheology == "newtonian" else None
    noz.gravity = solver.gravity.copy()
    # a projection step drifts once, to t + dt, and keeps no mid-step state: the nozzle
    # emits inside the drift, so the evaluation at x^{n+1} sees the new ink; the symplectic
    # WCSPH step drifts to t + dt/2 and keeps per-particle mid-step state (v_n, rho_n),
    # so there the nozzle emits between steps and the forces are evaluated again
    eos = solver.pressure_method.eos
    noz.drift_fraction = 0.5 if eos else 1.0
    noz.emit_in_drift = not eos
    ctx = solver.ctx
    service = _NozzleService(ctx, ctx.provide, noz, params.skin)
    ctx.provide = service
    names = fluid_materials(scene)
    assert names  # the scene check guarantees one fluid block
    t_end = min(noz.duration + scene.extrusion.settle_time, scene.time.t_end)
    max_steps = scene.time.max_steps
    cfl = scene.time.cfl
    series = None
    next_out = math.inf
    if out_dir is not None and scene.output.every:
        from sphfem.output import ParticleSeries

        series = ParticleSeries(Path(out_dir), "run")
        series.write(0.0, ps)
        next_out = scene.output.every
    counts: dict[str, int] = {}
    dts = []
    dx = scene.sph.dx
    history = {"t": [0.0], "emitted": [0.0], "outflow": [0.0]}
    stopped = None
    t = 0.0
    while t < t_end * (1 - 1e-12):
        if max_steps is not None and solver.step_count >= max_steps:
            stopped = f"max_steps = {max_steps} reached at t = {t:.6g} s of {t_end:.6g} s"
            break
        lim = solver.dt_limits()
        vn = float(np.linalg.norm(noz.V(t))) + noz.piston(t)
        if vn > 0:  # the nozzle moves by at most cfl h per step
            lim["nozzle"] = cfl * solver.h / vn
        name = min(lim, key=lim.get)
        dt = lim[name]
        if scene.time.dt is not None:
            dt = min(dt, scene.time.dt) if scene.time.cap_dt else scene.time.dt
        # steps end at each phase's end
        for edge in (noz.dwell, noz.dwell + noz.tau_r, noz.t_stop, noz.duration):
            if edge - t > 1e-6 * t_end:  # (a remainder this small is no phase)
                dt = min(dt, edge - t)
        dt = min(dt, t_end - t)
        noz.set_velocities(ctx.particles, t, dt)
        try:
            solver.step(dt)
            solver.check()
        except SimulationStopped as e:
            stopped = str(e)
            break
        t = solver.t
        if not noz.emit_in_drift and noz.emit(ctx.particles):
            solver.rebuild_neighbors()
            solver.evaluate(t)
        dts.append(dt)
        below = (ctx.particles.kind == FLUID) & (ctx.particles.x[:, 2] < noz.z_out)
        history["t"].append(t)
        history["emitted"].append(noz.released * dx**3)
        history["outflow"].append(float(below.sum()) * dx**3)
        counts[name] = counts.get(name, 0) + 1
        if series is not None and t >= next_out * (1 - 1e-12):
            series.write(t, ctx.particles)
            next_out += scene.output.every
    ps = ctx.particles
    fl = ps.kind == FLUID
    below = fl & (ps.x[:, 2] < noz.z_out)
    Pend = noz.P(t)
    r_axis = np.hypot(ps.x[:, 0] - Pend[0], ps.x[:, 1] - Pend[1])
    leaked = fl & (ps.x[:, 2] >= noz.z_out) & (r_axis > 0.5 * noz.D + 0.5 * scene.sph.dx)
    t_ext = noz.extruded_time(t)
    vol = dx**3
    n_fill = noz.n_fill * noz.disc.shape[0]
    diag = solver.diagnostics()
    psolve = diag.get("pressure_solve") or {}
    info = {
        "steps": solver.step_count,
        "wall_s": time.perf_counter() - t_wall,
        "cpu_s": time.process_time() - t_cpu,
        "stopped_reason": stopped,
        "t_end_s": t,
        "dx": dx,
        "particles": {"ink": int(fl.sum()), "deposited": int(below.sum()),
                      "walls": int((ps.kind == WALL).sum()), "total": int(ps.n),
                      "leaked": int(leaked.sum())},
        "flow_rate_m3_per_s": noz.Q,
        "piston_speed_m_per_s": noz.U_b,
        "bore_points": int(noz.disc.shape[0]),
        "bore_area_ratio": noz.area_bore / (math.pi * noz.D**2 / 4),
        "emitted_volume_m3": noz.released * vol,
        "expected_emitted_volume_m3": noz.Q * t_ext,
        "outflow_volume_m3": float(below.sum()) * vol,
        "fill_volume_m3": n_fill * vol,
        "emissions": noz.emissions,
        "emission_min_distance_over_dx": (noz.min_gap / dx if noz.emissions else None),
        "dt_s": {"min": float(min(dts)) if dts else None,
                 "mean": float(np.mean(dts)) if dts else None,
                 "max": float(max(dts)) if dts else None},
        "controlling_limit_counts": counts,
        "neighbor_builds": int(ctx.nbrs_version),
        "solver_wall_s": diag.get("wall_s"),
        "history": history,
        "pressure_solve": {k: psolve[k] for k in psolve
                           if not isinstance(psolve[k], (list, dict))},
    }
    vtu = None
    if out_dir is not None:
        from sphfem.output import ParticleSeries

        dep = ps.select(below)
        vtu = str(ParticleSeries(Path(out_dir), "deposit").write(t, dep))
    logger.info("extrusion: %d steps to t = %.4g s, %d ink particles deposited, %.1f s",
                solver.step_count, t, int(below.sum()), info["wall_s"])
    return DepositResult(positions=np.ascontiguousarray(ps.x[below]), h=solver.h,
                         nozzle_diameter=noz.D, info=info, vtu=vtu)


class ExtrusionModule(PhysicsModule):
    """``"extrusion"`` in ``[physics] modules``: the scene is an extrusion job.  The
    generic driver cannot run it (the nozzle appends ink particles); it says so."""

    name = "extrusion"

    def __init__(self, scene):
        raise SceneError(getattr(scene, "source", ""), "physics.modules",
                         "an extrusion scene runs through "
                         "sphfem.diw.extrusion.simulate_deposit(scene, path) or `sphfem "
                         "optimize`, not the generic driver")
