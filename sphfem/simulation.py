"""The time-stepping driver: builds what a scene names and runs it to the end time.

One step: (re)build the neighbour list if a module moves particles, ask every module for its
stable-time-step limits, take the smallest (and the scene's fixed ``time.dt`` if smaller),
step every module in scene order, check the state for NaN/Inf, write outputs when due.
A run records wall seconds per module and for the neighbour search, dt statistics with the
controlling limit, and each module's diagnostics in ``summary.json``.

The modules never see this object: every hook gets the run's
:class:`~sphfem.context.StepContext`, whose list service (``ctx.neighbors()``) is
:meth:`Simulation.ensure_neighbors`; particles a module's ``init`` returns (ghosts) are
appended here, with one list rebuild (docs/architecture.md).  Only the driver layer
(``sphfem.api``, ``sphfem.cli``, validation cases) imports this module.
"""

from __future__ import annotations

import logging
import math
import platform
import sys
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np
from numba import njit

from sphfem import __version__, kernels
from sphfem.context import StepContext
from sphfem.errors import SimulationStopped
from sphfem.neighbors import build_neighbor_list, cell_sort_permutation, min_image
from sphfem.output import ParticleSeries, atomic_write_bytes, write_json
from sphfem.particles import GHOST
from sphfem.physics import build_modules
from sphfem.progress import StageLog, peak_rss_mb, process_s, say, stage
from sphfem.step_watch import StepCollapseWatch

logger = logging.getLogger(__name__)

CHECKPOINT = "checkpoint.npz"

#: what the timing and memory figures of ``summary.json`` cover
TIMING_SCOPE = (
    "setup_s: building the Simulation (particles, first neighbour list, every module's "
    "set-up: ghosts, meshing, assembly, factorisation, numba kernels they compile) and, "
    "after --resume, loading the checkpoint; wall_s: the stepping loop (with the outputs "
    "written during it and kernels compiled in the first steps); total_s: setup_s + run() "
    "to the final summary; process_s: the whole process so far (with the Python imports "
    "and reading the scene; Linux only); wall_s_per_module: inside the loop; peak_rss_mb: "
    "the largest resident memory of the process (getrusage). After --resume all of these "
    "cover this process only; 'resumed.accumulated' adds the earlier processes up to their "
    "last checkpoint (the time a killed process spent after it is not known).")


@njit(cache=True)
def _max_displacement(x, x0, period):
    """Largest |x - x0| over particles (minimum image on periodic axes)."""
    best = 0.0
    for i in range(x.shape[0]):
        s = 0.0
        for k in range(x.shape[1]):
            d = min_image(x[i, k] - x0[i, k], period[k])
            s += d * d
        best = max(best, s)
    return np.sqrt(best)


def _release_free_memory() -> None:
    """Hand the heap memory freed by the set-up back to the system (glibc ``malloc_trim``).

    Meshing, assembly, the factorisation and numba's compiler free hundreds of MB in
    blocks that glibc keeps in the process heap; the stepping loop then starts from that
    resident size and its own peaks add to it.  Results are unaffected; a no-op where
    glibc is not the C library.
    """
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.malloc_trim(0)
    except (OSError, AttributeError):
        pass


__all__ = ["Simulation", "SimulationStopped", "format_summary"]  # SimulationStopped: errors


class Simulation:
    """A scene's particles, kernel, neighbour list and physics modules.

    The modules see the run through ``ctx`` (:class:`~sphfem.context.StepContext`), never
    through this object; ``particles``, ``nbrs``, ``nbrs_version``, ``t`` and
    ``step_count`` read the context.  ``R`` (support radius), ``sigma``, ``kernel_code``,
    ``period`` (periodic lengths, 0 = open), ``lo``/``hi`` (domain), ``scene``.
    """

    def __init__(self, scene, source: str | None = None, particles=None):
        self._t_created = time.perf_counter()
        self.stage_log = StageLog()
        with self.stage_log:
            self._setup(scene, source, particles)
        _release_free_memory()
        self.setup_s = time.perf_counter() - self._t_created

    def _setup(self, scene, source, particles) -> None:
        from sphfem.geometry import build_particles

        self.scene = scene
        self.source = source
        self.dim = scene.dim
        self.R = scene.sph.support_factor * scene.sph.dx
        self.kernel_code = kernels.kernel_code(scene.sph.kernel)
        self.sigma = kernels.kernel_sigma(self.kernel_code, self.dim, self.R)
        self.lo = np.asarray(scene.domain.lo, dtype=np.float64)
        self.hi = np.asarray(scene.domain.hi, dtype=np.float64)
        self.period = np.where(scene.domain.periodic, self.hi - self.lo, 0.0)
        if particles is None:
            with stage("building particles"):
                if getattr(scene, "geometry", "cartesian") == "axisymmetric":
                    from sphfem.axisymmetric_scene import build_ring_particles

                    particles = build_ring_particles(scene)  # rings: m, vol of the ring
                else:
                    particles = build_particles(scene)
        self.modules = build_modules(scene)
        for mod in self.modules:
            for name, (dtype, ncomp) in mod.fields().items():
                particles.add_field(name, ncomp, dtype)
        self.moving = any(m.moves_particles for m in self.modules)
        self.ctx = StepContext(particles, self.R, self.sigma, self.kernel_code,
                               scene.sph.kernel, self.lo, self.hi, self.period,
                               scene.materials, moving=self.moving,
                               provide=self._provide_neighbors)
        # the list holds only the pairs its users read when they all name the same pair
        # filter (``neighbor_filter``: keep masks by kind, None: all pairs): the fluid alone
        # gets its view built by the search, without an unfiltered list and a filtered copy
        filters = {getattr(m, "neighbor_filter", None) for m in self.modules}
        self.ctx.pair_filter = filters.pop() if len(filters) == 1 else None
        self.steps_above_limit = 0
        self.step_watch = StepCollapseWatch()  # collapsed steps, reported (run)
        self._earlier = None  # a resumed run: step, time and seconds before this process
        skin = scene.sph.skin
        self.skin = (0.15 if self.moving else 0.0) if skin is None else skin
        self.sort_every = scene.sph.sort_every
        self.rebuilds = 0
        self._x_at_build = None
        self.wall = {"neighbors": 0.0, **{m.name: 0.0 for m in self.modules}}
        with stage(f"first neighbour list ({self.particles.n} particles)"):
            self._sort_by_cell()
            self.update_neighbors()
        self._init_modules(stages=True)
        logger.info("scene %s: %d particles, dim %d, kernel %s, R = %g m, modules %s",
                    getattr(scene, "name", "?"), self.particles.n, self.dim, scene.sph.kernel,
                    self.R, [m.name for m in self.modules])

    # -- the context's state -------------------------------------------------------------
    @property
    def particles(self):
        return self.ctx.particles

    @property
    def nbrs(self):
        return self.ctx.nbrs

    @property
    def nbrs_version(self) -> int:
        return self.ctx.nbrs_version

    @property
    def t(self) -> float:
        return self.ctx.t

    @t.setter
    def t(self, value: float) -> None:
        self.ctx.t = value

    @property
    def step_count(self) -> int:
        return self.ctx.step

    @step_count.setter
    def step_count(self, value: int) -> None:
        self.ctx.step = value

    def _init_modules(self, stages: bool = False) -> None:
        """``init`` every module in scene order; append the particles a module returns
        (kind GHOST), rebuild the list once and call its ``appended`` hook."""
        ctx = self.ctx
        for mod in self.modules:
            with stage(f"setting up {mod.name}") if stages else nullcontext():
                extra = mod.init(ctx)
                if extra is None or extra.n == 0:
                    continue
                if np.any(extra.kind != GHOST):
                    raise ValueError(f"{mod.name}: init returned particles that are not "
                                     "ghosts (kind GHOST); only derived particles can be "
                                     "appended, the scene's blocks make the others")
                start = ctx.particles.n
                ctx.particles.append(extra)
                self.update_neighbors()
                mod.appended(ctx, np.arange(start, start + extra.n))

    # -- neighbours -----------------------------------------------------------------------
    def _provide_neighbors(self, rebuild: bool) -> None:
        """The context's list service (:meth:`StepContext.neighbors`)."""
        if rebuild:
            self.update_neighbors()
        else:
            self.ensure_neighbors()

    def _sort_by_cell(self) -> np.ndarray:
        perm = cell_sort_permutation(self.particles.x, self.R, self.lo, self.hi, self.period)
        self.particles.reorder(perm)
        return perm

    def update_neighbors(self) -> None:
        """Rebuild the neighbour list now (listing pairs within (1 + skin) R)."""
        t0 = time.perf_counter()
        p = self.particles
        x = p.x
        keep = self.ctx.pair_filter
        self.ctx.nbrs = None  # the old list goes before the new one is built (peak memory)
        self.ctx.nbrs = build_neighbor_list(x, self.R * (1.0 + self.skin), self.lo,
                                            self.hi, self.period,
                                            kind=None if keep is None else p.kind, keep=keep)
        if self._x_at_build is not None and self._x_at_build.shape == x.shape:
            self._x_at_build[...] = x
        else:
            self._x_at_build = x.copy()
        self.rebuilds += 1
        self.ctx.nbrs_version += 1
        self.wall["neighbors"] += time.perf_counter() - t0

    def ensure_neighbors(self) -> bool:
        """Rebuild the list if some particle moved more than skin R / 2 since the last build
        (or the particle count changed); return True when it was rebuilt.

        Every pair closer than R is then still listed, because two particles approach each
        other by at most twice the largest displacement.
        """
        x = self.particles.x
        if self._x_at_build is None or x.shape != self._x_at_build.shape:
            self.update_neighbors()
            return True
        if _max_displacement(x, self._x_at_build, self.period) > 0.5 * self.skin * self.R:
            if self.sort_every and self.rebuilds % self.sort_every == 0:
                t0 = time.perf_counter()
                perm = self._sort_by_cell()
                self.wall["neighbors"] += time.perf_counter() - t0
                for mod in self.modules:
                    mod.reorder(self.ctx, perm)
            self.update_neighbors()
            return True
        return False

    @property
    def kernel_args(self) -> tuple:
        """(x, vol, offsets, indices, R, sigma, kernel_code, period): the operators' tail."""
        return self.ctx.kernel_args

    # -- time stepping --------------------------------------------------------------------
    def stable_dt(self) -> tuple[float, str]:
        """The step to take and the name of what sets it.

        The smallest time-step limit over all modules and the scene's fixed ``dt``; with
        ``[time] cap_dt = false`` the fixed ``dt`` is taken as given, and each step above the
        modules' smallest limit is counted in ``steps_above_stable_limit``.
        """
        limits = {}
        for mod in self.modules:
            for k, v in mod.dt_limits(self.ctx).items():
                limits[f"{mod.name}.{k}"] = v
        bad = {k: v for k, v in limits.items() if not (v > 0.0 and math.isfinite(v))}
        if bad:
            # a limit <= 0 or NaN comes from a broken state (a density <= 0, a NaN speed);
            # taking it would step backwards or never end
            k, v = next(iter(bad.items()))
            raise SimulationStopped(
                f"at t = {self.t:.6g} s, step {self.step_count}: the time-step limit {k} "
                f"is {v!r} (not a positive number): the state is broken (the last output "
                "and the checkpoint hold the state before it)")
        fixed = self.scene.time.dt
        if fixed is not None and not self.scene.time.cap_dt:
            if limits and fixed > min(limits.values()):
                self.steps_above_limit += 1
            return fixed, "time.dt"
        if fixed is not None:
            limits["time.dt"] = fixed
        if not limits:
            raise SimulationStopped("no module limits the time step and [time] dt is not set")
        name = min(limits, key=limits.get)
        return limits[name], name

    def step(self, dt: float) -> None:
        if self.moving:
            self.ensure_neighbors()
        for mod in self.modules:
            t0 = time.perf_counter()
            mod.step(self.ctx, dt)
            self.wall[mod.name] += time.perf_counter() - t0
        self.t += dt
        self.step_count += 1

    def check_state(self) -> None:
        """Stop with a clear message if any float field holds NaN or Inf."""
        bad = self.particles.check_finite()
        if bad:
            counts = {
                k: int((~np.isfinite(self.particles.fields[k])).reshape(self.particles.n, -1)
                       .any(axis=1).sum())
                for k in bad
            }
            raise SimulationStopped(
                f"step {self.step_count}, t = {self.t:.6g} s: non-finite values in "
                + ", ".join(f"{k} ({c} particles)" for k, c in counts.items())
                + "; likely cause: time step above the stable limit or an unresolved "
                "stiff material (try a smaller [time] cfl or the implicit option)"
            )

    def run(self, out, progress: bool = True, resume: bool = False,
            keep_checkpoint: bool = False) -> dict:
        """Run to ``scene.time.t_end``; write outputs into folder ``out``; return the summary.

        ``resume``: continue from ``out/checkpoint.npz`` when it exists.  The checkpoint
        (written at every output time) is deleted when the run completes, unless
        ``keep_checkpoint``; a stopped run or one that hit ``max_steps`` keeps it.
        """
        run0 = time.perf_counter()
        with self.stage_log:
            summary = self._run(Path(out), progress, resume, keep_checkpoint, run0)
        if summary["status"] == "stopped":
            raise SimulationStopped(summary["message"])
        return summary

    def _run(self, out: Path, progress, resume, keep_checkpoint, run0) -> dict:
        from tqdm import tqdm

        self.ctx.out = out  # modules that write their own files (the coupling) look here
        t_end = self.scene.time.t_end
        max_steps = self.scene.time.max_steps
        every = self.scene.output.every
        exact_times = self.scene.output.exact_times
        series = ParticleSeries(out)
        fields = self.scene.output.fields or None
        self._earlier = None
        if resume and (out / CHECKPOINT).exists():
            t0 = time.perf_counter()
            with stage(f"loading {CHECKPOINT}"):
                self.load_checkpoint(out / CHECKPOINT)
            self.setup_s += time.perf_counter() - t0
            series.entries = self._series_entries
        else:
            series.write(self.t, self.particles, fields)
        for mod in self.modules:
            mod.start(self.ctx)
        next_out = self.t + every if every else np.inf
        dts, limiter_counts = [], {}
        limit_min = np.inf  # smallest step the limits allowed (before output/end truncation)
        status, message = "completed", ""
        say(f"stepping from t = {self.t:.4g} s to {t_end:.4g} s ({self.particles.n} "
            f"particles; set-up took {self.setup_s:.1f} s)")
        self._wall0 = wall0 = time.perf_counter()
        self._run0 = run0
        bar = tqdm(total=t_end, unit="s", disable=not progress or None, leave=False,
                   bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
        bar.update(self.t)
        try:
            while self.t < t_end * (1 - 1e-12):
                if max_steps is not None and self.step_count >= max_steps:
                    status = "max_steps"
                    break
                dt, limiter = self.stable_dt()
                limit_min = min(limit_min, dt)
                ep = self.step_watch.observe(self.t, dt, limiter)
                if ep is not None:
                    logger.warning(
                        "the time step collapsed at t = %.6g s: %.3g s (set by %s) against "
                        "%.3g s before, for %d steps so far; the run will crawl (see "
                        "summary.json dt.collapses)", ep["t"], ep["dt"], ep["limiter"],
                        ep["reference_dt"], ep["steps"])
                dt = min(dt, t_end - self.t)
                if every and exact_times:
                    dt = min(dt, max(next_out - self.t, 1e-300))
                self.step(dt)
                self.check_state()
                dts.append(dt)
                limiter_counts[limiter] = limiter_counts.get(limiter, 0) + 1
                bar.update(dt)
                if self.t >= next_out * (1 - 1e-12):
                    series.write(self.t, self.particles, fields)
                    self.save_checkpoint(out / CHECKPOINT, series)
                    while next_out <= self.t * (1 + 1e-12):  # (several when not exact)
                        next_out += every
        except SimulationStopped as e:
            status, message = "stopped", str(e)
        finally:
            bar.close()
        wall = time.perf_counter() - wall0
        finite = not self.particles.check_finite()
        if finite and (not series.entries or series.entries[-1][0] != self.t):
            series.write(self.t, self.particles, fields)
        elif not finite:  # never write NaN/Inf: the last output is the last finite state
            message += (f" (the non-finite state was not written; the last output is "
                        f"t = {series.entries[-1][0]:.6g} s)")
        summary = self.summary(status, message, wall, dts, limiter_counts)
        summary["dt"]["min_allowed"] = float(limit_min) if np.isfinite(limit_min) else None
        if status == "completed" and not keep_checkpoint:
            (out / CHECKPOINT).unlink(missing_ok=True)
        summary["checkpoint"] = (str(out / CHECKPOINT) if (out / CHECKPOINT).exists()
                                 else None)
        summary["total_s"] = self.setup_s + (time.perf_counter() - run0)
        summary["process_s"] = process_s()
        if self._earlier is not None:
            e = self._earlier
            summary["resumed"]["accumulated"] = {
                "setup_s": e["setup_s"] + self.setup_s, "wall_s": e["wall_s"] + wall,
                "total_s": e["total_s"] + summary["total_s"]}
        write_json(out / "summary.json", summary)
        return summary

    # -- records --------------------------------------------------------------------------
    def summary(self, status, message, wall, dts, limiter_counts) -> dict:
        import numba

        n = self.particles.n
        dts_list = dts
        dts = np.asarray(dts) if dts else np.zeros(1)
        kinds = np.bincount(self.particles.kind.astype(np.int64), minlength=4)
        return {
            "status": status,
            "message": message,
            "scene_file": self.source,
            "scene": self.scene.to_dict(),
            "versions": {
                "sphfem": __version__, "python": sys.version.split()[0],
                "numpy": np.__version__, "numba": numba.__version__,
                "platform": platform.platform(),
            },
            "threads": numba.get_num_threads(),
            "particles": {"total": n, "fluid": int(kinds[0]), "wall": int(kinds[1]),
                          "solid": int(kinds[2]), "ghost": int(kinds[3])},
            "steps": self.step_count,
            "t": self.t,
            "setup_s": self.setup_s,
            "wall_s": wall,
            "total_s": None,  # set by run() once the last outputs are written
            "process_s": None,  # likewise
            "peak_rss_mb": peak_rss_mb(),
            "timing_scope": TIMING_SCOPE,
            "setup": self.stage_log.to_dict(),
            "resumed": None if self._earlier is None else {
                "from_t": self._earlier["t"], "from_step": self._earlier["step"],
                "processes_before": self._earlier["processes"],
                "steps_this_process": len(dts_list)},
            "wall_s_per_module": dict(self.wall),
            "particle_steps_per_s": n * len(dts_list) / wall if wall > 0 else None,
            "dt": {"min": float(dts.min()), "max": float(dts.max()), "mean": float(dts.mean()),
                   "controlling_limit_counts": limiter_counts,
                   "steps_above_stable_limit": self.steps_above_limit,
                   "collapses": list(self.step_watch.episodes)},
            "neighbors": {"pairs": self.nbrs.n_pairs, "mean_per_particle": self.nbrs.n_pairs / n
                          if n else 0.0},
            "diagnostics": {m.name: m.diagnostics(self.ctx) for m in self.modules},
        }

    def save_checkpoint(self, path: Path, series: ParticleSeries) -> None:
        """Atomically store the particle state, time, step count and output series."""
        import io

        buf = io.BytesIO()
        arrays = {f"f_{k}": v for k, v in self.particles.fields.items()}
        now = time.perf_counter()
        e = self._earlier or {"setup_s": 0.0, "wall_s": 0.0, "total_s": 0.0, "processes": 0}
        np.savez(buf, t=self.t, step=self.step_count,
                 acc_setup_s=e["setup_s"] + self.setup_s,
                 acc_wall_s=e["wall_s"] + (now - self._wall0),
                 acc_total_s=e["total_s"] + self.setup_s + (now - self._run0),
                 acc_processes=e["processes"] + 1,
                 series_t=np.array([e[0] for e in series.entries]),
                 series_f=np.array([e[1] for e in series.entries]), **arrays,
                 **self._module_states())
        atomic_write_bytes(path, buf.getvalue())

    def _module_states(self) -> dict:
        """``m_<name>``: each module's :meth:`PhysicsModule.checkpoint_state`, pickled into a
        byte array (the checkpoint stays a plain npz, loaded without allow_pickle)."""
        import pickle

        out = {}
        for mod in self.modules:
            st = mod.checkpoint_state(self.ctx)
            if st is not None:
                out[f"m_{mod.name}"] = np.frombuffer(pickle.dumps(st, protocol=5), np.uint8)
        return out

    def load_checkpoint(self, path: Path) -> None:
        import pickle

        with np.load(path) as z:
            states = {k[2:]: pickle.loads(z[k].tobytes()) for k in z.files
                      if k.startswith("m_")}
            self.t = float(z["t"])
            self.step_count = int(z["step"])
            for k in z.files:
                if k.startswith("f_"):
                    self.particles.fields[k[2:]] = np.ascontiguousarray(z[k])
            self._series_entries = list(zip(z["series_t"].tolist(), z["series_f"].tolist(),
                                            strict=True))
            acc = {k: float(z[f"acc_{k}"]) if f"acc_{k}" in z.files else 0.0
                   for k in ("setup_s", "wall_s", "total_s")}
            acc["processes"] = int(z["acc_processes"]) if "acc_processes" in z.files else 1
        self._earlier = {"t": self.t, "step": self.step_count, **acc}
        ps = self.particles
        if np.any(ps.kind == GHOST):  # derived particles: the modules place them anew
            self.ctx.particles = ps.select(ps.kind != GHOST)
        self.update_neighbors()
        self.ctx.resumed_states = states  # modules that cannot restart without theirs look
        self._init_modules()
        for mod in self.modules:
            if mod.name in states:
                mod.restore_state(self.ctx, states[mod.name])


def format_summary(summary: dict, out) -> str:
    """A few lines for a person: status, time and memory, the substrate's peak von Mises
    stress (value, place, time) and the heat handed over when the scene couples, and
    where the outputs are (``sphfem run`` prints this; ``--json`` prints figures instead).
    """
    out = Path(out)
    s = summary
    lines = [f"sphfem: run {s['status']}: {s['steps']} steps to t = {s['t']:.4g} s, "
             f"{s['particles']['total']} particles"]
    if s.get("message"):
        lines.append(f"  {s['message']}")
    rss = s.get("peak_rss_mb")
    proc = s.get("process_s")
    lines.append(f"  time: set-up {s['setup_s']:.1f} s, stepping {s['wall_s']:.1f} s, total "
                 f"{s['total_s']:.1f} s" + (f" ({proc:.1f} s with imports)" if proc else "")
                 + f"; peak memory {rss:.0f} MB"
                 + (" (this process; resumed)" if s.get("resumed") else ""))
    c = s.get("diagnostics", {}).get("coupling")
    if c and c.get("peak_von_mises_Pa") is not None:
        where = ", ".join(f"{v * 1e6:.4g}" for v in c["peak_von_mises_location_m"])
        lines.append(f"  substrate: peak von Mises {c['peak_von_mises_Pa'] / 1e6:.4g} MPa at "
                     f"({where}) um, t = {c['peak_von_mises_t_s']:.4g} s")
    if c and c.get("heat"):
        h = c["heat"]
        lines.append(f"  heat handed to the substrate: {h['heat_to_solid_J']:.4g} J (the "
                     f"fluid lost {h['heat_lost_by_fluid_J']:.4g} J)")
    names = sorted(p.name + ("/" if p.is_dir() else "") for p in out.iterdir()
                   if not p.name.startswith(".") and (p.is_dir() or p.suffix in (".pvd",
                                                                                ".json",
                                                                                ".npz")))
    lines.append(f"  outputs: {out}/ ({', '.join(names)})")
    return "\n".join(lines)
