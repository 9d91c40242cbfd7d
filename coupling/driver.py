"""One-way staggered SPH -> substrate coupling and the ``coupling`` physics module.

Park (2019) sec. 2.4.4 (figure 2.3): the SPH side (fluid + heat) advances with its own
explicit step; the substrate is quasi-static (its acoustic time step would be ~1000x
smaller), so every ``k`` SPH steps the driver

1. reads the sensor particles (:class:`coupling.sensors.SensorSet`): the force the fluid
   exerts on the substrate's surface layers and the SPH solid region's temperatures;
2. hands them to the substrate backend (:mod:`coupling.backends`; FEM: f = P^T F on the
   coupled surface, temperatures mapped to the nodes, :mod:`coupling.transfer`);
3. solves once (FEM: one back-substitution with the factorised K) and records the stress at
   the probe points, the peak von Mises stress (value, place, time), the volume-averaged
   stress and the bookkeeping of the hand-over (force and moment before / after the
   transfer, heat given to the solid).

Nothing flows back (one-way): the substrate's deformation does not move the wall particles.

Default k (:func:`default_every_k`): the loads change on two time scales, the time the
fluid needs to move half a particle spacing, 0.5 dx / U (U = the largest of the fluid's
initial speed and c0 / 10, the speed the weakly compressible model is designed for), and
the time heat needs to diffuse half a spacing into the substrate, dx^2 / (4 kappa_s);
k = max(1, floor(min of the two / dt)) with dt the first SPH step.  The last step of a run
is always coupled.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import math
import pickle
import time
from pathlib import Path

import numpy as np

from coupling.sensors import SensorSet, Surface
from sphfem.particles import FLUID, GHOST
from sphfem.physics import PhysicsModule

logger = logging.getLogger(__name__)

_COMPONENTS = (("xx", 0, 0), ("yy", 1, 1), ("zz", 2, 2), ("xy", 0, 1), ("yz", 1, 2),
               ("xz", 0, 2))


def default_every_k(dx: float, dt: float, U: float | None = None,
                    kappa: float | None = None) -> int:
    """k = max(1, floor(min(0.5 dx / U, dx^2 / (4 kappa)) / dt)) (module docstring)."""
    scales = []
    if U is not None and U > 0:
        scales.append(0.5 * dx / U)
    if kappa is not None and kappa > 0:
        scales.append(0.25 * dx * dx / kappa)
    if not scales or not dt > 0:
        return 1
    return max(1, int(math.floor(min(scales) / dt * (1 + 1e-12))))


class HeatLedger:
    """Heat given to the SPH solid region against the heat the fluid lost.

    Q_solid = sum_region m c (T - T_init),  Q_fluid = -sum_fluid m c (T - T_init);
    with a conservative conduction operator (Cleary) in an insulated box the two agree to
    round-off: ``residual_rel`` = (Q_solid - Q_fluid) / max(|Q_fluid|, |Q_solid|).
    """

    def __init__(self, ps, region: np.ndarray):
        self.e_region0 = self._energy(ps, region)
        self.e_fluid0 = self._energy(ps, ps.kind == FLUID)
        self.e_other0 = self._energy(ps, ~region & (ps.kind != FLUID) & (ps.kind != GHOST))

    @staticmethod
    def _energy(ps, mask) -> float:
        return float(np.sum(ps.m[mask] * ps.c_heat[mask] * ps.T[mask]))

    def figures(self, ps, region: np.ndarray) -> dict:
        q_s = self._energy(ps, region) - self.e_region0
        q_f = self.e_fluid0 - self._energy(ps, ps.kind == FLUID)
        q_o = self._energy(ps, ~region & (ps.kind != FLUID) & (ps.kind != GHOST)) - self.e_other0
        scale = max(abs(q_s), abs(q_f), 1e-300)
        return {"heat_to_solid_J": q_s, "heat_lost_by_fluid_J": q_f,
                "heat_to_other_particles_J": q_o,
                "residual_rel": (q_s + q_o - q_f) / scale}


class PickledRecords:
    """A checkpoint's copy of a record list: the records' pickles (``blobs``, a tuple of
    bytes); :meth:`records` unpickles them into new dicts equal to the originals."""

    def __init__(self, blobs: tuple):
        self.blobs = tuple(blobs)

    def records(self) -> list:
        return [pickle.loads(b) for b in self.blobs]

    def __len__(self) -> int:
        return len(self.blobs)


class RecordPickles:
    """The pickles of a record list that only grows (records recognised by identity and
    never changed once appended: the coupling's ``history`` lists), each record pickled
    once: :meth:`snapshot` pickles the records appended since the last call and returns
    all as :class:`PickledRecords`; a list replaced or cut (a restored history) is
    pickled again from the first record that is not the one pickled."""

    def __init__(self):
        self._done: list[tuple[dict, bytes]] = []

    def snapshot(self, records: list) -> PickledRecords:
        n = 0
        for (rec, _), r in zip(self._done, records, strict=False):
            if rec is not r:
                break
            n += 1
        del self._done[n:]
        for r in records[n:]:
            self._done.append((r, pickle.dumps(r, protocol=5)))
        return PickledRecords(b for _, b in self._done)


class CouplingDriver:
    """Sensors -> backend every ``every_k`` steps, with the records (no SPH knowledge).

    ``probes`` (n, dim) [m]; ``every_k`` None: decided by the caller before the first
    :meth:`maybe_couple` (see :func:`default_every_k`).
    """

    #: at most this many wall seconds between two writes of the history files
    HISTORY_FLUSH_S = 30.0

    def __init__(self, sensors: SensorSet, backend, probes=None, every_k: int | None = None,
                 vtu_every: int = 10):
        self.sensors = sensors
        self.backend = backend
        self.probes = None if probes is None else np.atleast_2d(np.asarray(probes, float))
        self.every_k = every_k
        self.vtu_every = int(vtu_every)
        self.history: list[dict] = []
        self.peak = {"von_mises": -1.0, "location": None, "t": None}
        self.max_force_residual = 0.0
        self.max_moment_residual = 0.0
        self.timings = {"sensors": 0.0, "backend": 0.0, "records": 0.0}
        self.last = None
        self.n_written = 0
        #: [coupling.heat] fem-contact (coupling.substrate_heat.SubstrateHeat) or None
        self.thermal = None
        #: wall time of the last history write, and the folder of records not yet written
        self._flushed, self._dirty = -math.inf, None
        #: (record, its history.json text, its probes.csv line) of the records written
        self._texts: list[tuple[dict, str, str]] = []

    def maybe_couple(self, ps, t: float, step: int, last: bool = False, folder=None):
        """Couple when ``step`` is a multiple of ``every_k`` or ``last``; return the record."""
        k = self.every_k or 1
        if step % k == 0 or last:
            return self.couple(ps, t, step, folder, last=last)
        return None

    def couple(self, ps, t: float, step: int = 0, folder=None, last: bool = False) -> dict:
        t0 = time.perf_counter()
        r = self.sensors.read(ps, t)
        if self.thermal is not None:  # contact exchange; the FEM heat field's temperatures
            self.thermal.exchange(ps, t)
            r = self.thermal.reading(r, self.backend.temperature_targets)
        t1 = time.perf_counter()
        book = self.backend.apply(r.x, r.force, r.x_region, r.T_region, r.vol_region)
        res = self.backend.solve(t)
        self.last = res
        t2 = time.perf_counter()
        rec = self._record(r, book, res, t, step)
        self.history.append(rec)
        if folder is not None:
            folder = Path(folder)
            n = len(self.history) - 1
            vtu = last or (self.vtu_every and n % self.vtu_every == 0)
            if vtu:
                self.backend.write(t, folder)
                self.n_written += 1
            # the whole history is rewritten atomically: at every VTU, at the end and at
            # most every HISTORY_FLUSH_S wall seconds in between (rewriting it at every
            # solve made the records cost quadratic in the number of solves: 460 of 558 s
            # of a 50 m/s axisymmetric run at c0 = 1480 m/s)
            if vtu or time.perf_counter() - self._flushed >= self.HISTORY_FLUSH_S:
                self.write_history(folder)
            else:
                self._dirty = folder
        self.timings["sensors"] += t1 - t0
        self.timings["backend"] += t2 - t1
        self.timings["records"] += time.perf_counter() - t2
        return rec

    def _record(self, r, book, res, t, step) -> dict:
        scale_f = max(float(np.abs(r.force).sum()), 1e-300)
        fres = float(np.abs(book["force_out"] - book["force_in"]).max()) / scale_f
        lever = max(float(np.ptp(r.x, axis=0).max()) if len(r.x) else 0.0, 1e-300)
        mres = float(np.abs(book["moment_out"] - book["moment_in"]).max()) / (scale_f * lever)
        self.max_force_residual = max(self.max_force_residual, fres)
        self.max_moment_residual = max(self.max_moment_residual, mres)
        vm, where = res.peak_von_mises()
        if vm > self.peak["von_mises"]:
            self.peak = {"von_mises": vm, "location": where.tolist(), "t": t}
        S = res.mean_stress()
        rec = {"t": t, "step": step, "sensors": int(len(r.x)),
               "force_sensors": r.total_force.tolist(),
               "force_load": np.asarray(book["force_out"]).tolist(),
               "force_residual_rel": fres, "moment_residual_rel": mres,
               "unassigned_force": r.unassigned_force.tolist(),
               "clipped_sensors": book["clipped"],
               "peak_von_mises": vm, "peak_location": where.tolist(),
               "mean_stress": {c: float(S[i, j]) for c, i, j in _COMPONENTS}}
        if r.T_region is not None and r.T_region.size:
            rec["T_region_max"] = float(r.T_region.max())
        if self.probes is not None:
            p = res.probe(self.probes)
            rec["probes"] = [{**{c: float(p["stress"][k, i, j]) for c, i, j in _COMPONENTS},
                              "von_mises": float(p["von_mises"][k]), "T": float(p["T"][k])}
                             for k in range(len(self.probes))]
        return rec

    # -- outputs -----------------------------------------------------------------------
    @staticmethod
    def _csv_line(row) -> str:
        buf = io.StringIO()
        csv.writer(buf).writerow(row)
        return buf.getvalue()

    def _record_texts(self) -> list[tuple[dict, str, str]]:
        """Each record's history.json text (``json.dumps(_plain(rec), indent=2)`` indented
        to its depth in the file) and probes.csv line, made once per record: rewriting the
        files made every record again at every write, a cost quadratic in the number of
        solves.  Records are recognised by identity (a restored history is new)."""
        from sphfem.output import _plain

        n = 0
        for (rec, _, _), h in zip(self._texts, self.history, strict=False):
            if rec is not h:
                break
            n += 1
        del self._texts[n:]
        for h in self.history[n:]:
            text = json.dumps(_plain(h), indent=2, allow_nan=False).replace("\n", "\n    ")
            row = [repr(h["t"]), h["step"], repr(h["peak_von_mises"])]
            row += [repr(h["mean_stress"][c]) for c, _, _ in _COMPONENTS]
            for p in h.get("probes", []):
                row += [repr(p[c]) for c, _, _ in _COMPONENTS] + [repr(p["von_mises"]),
                                                                 repr(p["T"])]
            self._texts.append((h, text, self._csv_line(row)))
        return self._texts

    def csv_text(self) -> str:
        npb = 0 if self.probes is None else len(self.probes)
        head = ["t", "step", "peak_von_mises"] + [f"mean_s{c}" for c, _, _ in _COMPONENTS]
        for k in range(npb):
            head += [f"p{k}_s{c}" for c, _, _ in _COMPONENTS] + [f"p{k}_von_mises", f"p{k}_T"]
        return self._csv_line(head) + "".join(c for _, _, c in self._record_texts())

    def history_text(self) -> str:
        """history.json: the bytes of ``write_json`` of {"probes", "every_k_steps",
        "history"}, the records' texts cached (:meth:`_record_texts`)."""
        from sphfem.output import _plain

        head = json.dumps(_plain({"probes": None if self.probes is None
                                  else self.probes.tolist(), "every_k_steps": self.every_k}),
                          indent=2, allow_nan=False)
        texts = [t for _, t, _ in self._record_texts()]
        body = "[\n    " + ",\n    ".join(texts) + "\n  ]" if texts else "[]"
        return head[:-2] + ',\n  "history": ' + body + "\n}"

    def flush(self) -> None:
        """Write the records not yet written (see :meth:`couple`)."""
        if self._dirty is not None:
            self.write_history(self._dirty)

    def write_history(self, folder) -> None:
        from sphfem.output import atomic_write_text

        self._flushed, self._dirty = time.perf_counter(), None
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / "probes.csv", self.csv_text())
        atomic_write_text(folder / "history.json", self.history_text())

    def summary(self) -> dict:
        out = {"every_k_steps": self.every_k, "solves": len(self.history),
               "vtu_written": self.n_written,
               "peak_von_mises_Pa": self.peak["von_mises"] if self.history else None,
               "peak_von_mises_location_m": self.peak["location"],
               "peak_von_mises_t_s": self.peak["t"],
               "force_residual_rel_max": self.max_force_residual,
               "moment_residual_rel_max": self.max_moment_residual,
               "wall_s": dict(self.timings),
               "backend": self.backend.diagnostics()}
        if self.history:
            h0 = self.history[0]  # the state before the first step: no load if no contact
            out["start"] = {"t": h0["t"], "peak_von_mises_Pa": h0["peak_von_mises"],
                            "force_sensors": h0["force_sensors"]}
            # the largest wall-normal load (the last axis is the wall normal) and its time
            hp = max(self.history, key=lambda r: abs(r["force_sensors"][-1]))
            out["peak_normal_force_N"] = abs(hp["force_sensors"][-1])
            out["peak_normal_force_t_s"] = hp["t"]
            h = self.history[-1]
            out["last"] = {k: h[k] for k in ("t", "force_sensors", "force_load",
                                             "unassigned_force", "mean_stress") if k in h}
            if "probes" in h:
                out["probes_m"] = self.probes.tolist()
                out["last"]["probes"] = h["probes"]
        return out


# --------------------------------------------------------------------------------------
# the physics module


def build_substrate(scene, cfg, region_lo, region_hi, T0: float):
    """The :class:`sphfem.fem.FEMSubstrate` of a ``[coupling]`` section.

    The mesh is read and its boundary groups checked against ``clamps``, ``rollers`` and
    ``surface`` before anything is assembled; a missing or unreadable ``mesh_file``, a mesh
    of the wrong dimension or an unknown group raises :class:`sphfem.schema.SceneError`
    naming the scene key (``coupling.mesh_file``, ``coupling.clamps[0]``, ...).
    """
    from sphfem.fem import FEMSubstrate, substrate_block, substrate_rect
    from sphfem.fem.substrate import load_mesh
    from sphfem.schema import SceneError

    mat = scene.materials[cfg.material]
    alpha = mat.alpha or 0.0
    dim = scene.dim
    source = scene.source or ""
    if cfg.mesh_file is not None:
        path = Path(cfg.mesh_file)
        if not path.is_absolute() and scene.source and not scene.source.startswith("<"):
            path = Path(scene.source).resolve().parent / path
        t0 = time.perf_counter()
        try:
            mesh = load_mesh(path)
        except Exception as e:  # whatever meshio / scikit-fem make of a user's file
            said = " ".join(str(e).split()) or type(e).__name__
            if not isinstance(e, (OSError, ValueError)) or str(path) not in said:
                said = f"mesh file {path} could not be read ({said})"
            raise SceneError(source, "coupling.mesh_file", said) from None
        what, key = f"mesh file {path}", "coupling.mesh_file"
    else:
        m = cfg["mesh"]
        lo = np.array(m.lo if m.lo is not None else region_lo, float)
        hi = np.array(m.hi if m.hi is not None else region_hi, float)
        h_fine = m.h_fine if m.h_fine is not None else 2.0 * scene.sph.dx
        h_coarse = m.h_coarse if m.h_coarse is not None else 8.0 * h_fine
        rc = np.array(region_lo, float) * 0.5 + np.array(region_hi, float) * 0.5
        rc[-1] = region_hi[-1]
        center = tuple(m.refine_center) if m.refine_center is not None else tuple(rc)
        lat = np.subtract(region_hi, region_lo)[:-1]
        radius = m.refine_radius if m.refine_radius is not None else 0.5 * float(lat.max())
        kw = dict(size=tuple(hi - lo), origin=tuple(lo), h_fine=h_fine,
                  h_coarse=max(h_coarse, h_fine), refine_center=center, refine_radius=radius,
                  growth=m.growth)
        if dim == 3:
            path = substrate_block(element=m.cells or "hex", **kw)
        else:
            path = substrate_rect(element=m.cells or "quad", **kw)
        t0 = time.perf_counter()
        mesh = load_mesh(path)
        what, key = "the [coupling.mesh] recipe's mesh", "coupling.mesh"
    t_load = time.perf_counter() - t0
    if mesh.p.shape[0] != dim:
        raise SceneError(source, key, f"{what} is {mesh.p.shape[0]}D but the scene is {dim}D")
    groups = sorted(mesh.boundaries or {})

    def need(k: str, group: str) -> None:
        if group not in groups:
            raise SceneError(source, k, f"{what} has no boundary group {group!r}; available: "
                                        f"{', '.join(groups) if groups else '(none)'}")

    for i, g in enumerate(cfg.clamps):
        need(f"coupling.clamps[{i}]", g)
    for g in cfg.rollers or {}:
        need(f"coupling.rollers.{g}", g)
    need("coupling.surface", cfg.surface)
    sub = FEMSubstrate(mesh, E=mat.E, nu=mat.nu, alpha=alpha, T0=T0, element=cfg.element,
                       clamps=list(cfg.clamps), rollers=dict(cfg.rollers or {}),
                       solver=cfg.solver)
    sub.mesh_path = Path(path)
    sub.timings["load_mesh"] = t_load
    return sub


def fluid_region_distance(ps, region_of, period=None, limit: float = np.inf) -> float:
    """Smallest distance [m] between a fluid particle and a particle of the coupled region.

    ``region_of(sub)`` is the region test (``SensorSet.region_mask``) of a particle subset
    ``sub`` (attributes ``x``, ``kind``, ``material``, ``n``); ``period`` the periodic
    lengths per axis (0 = open; minimum image on the others); distances beyond ``limit``
    are reported as ``inf``.  Only particles within ``limit`` of the fluid's bounding box
    are tested, so the pre-contact check of every step costs one pass over the positions.
    """
    from types import SimpleNamespace

    from scipy.spatial import cKDTree

    fl = ps.kind == FLUID
    if not fl.any():
        return math.inf
    xf = ps.x[fl]
    periodic = period is not None and np.any(np.asarray(period) > 0)
    cand = ~fl
    if math.isfinite(limit) and not periodic:
        lo, hi = xf.min(axis=0) - limit, xf.max(axis=0) + limit
        cand &= np.all((ps.x >= lo) & (ps.x <= hi), axis=1)
    idx = np.nonzero(cand)[0]
    if idx.size == 0:
        return math.inf
    sub = SimpleNamespace(x=ps.x[idx], kind=ps.kind[idx], material=ps.material[idx],
                          n=int(idx.size))
    xr = sub.x[region_of(sub)]
    if xr.shape[0] == 0:
        return math.inf
    if periodic:  # torus on the periodic axes; open axes get a box no pair wraps around
        x_all = np.concatenate([xf, xr])
        base = x_all.min(axis=0)
        span = np.ptp(x_all, axis=0)
        box = np.where(np.asarray(period) > 0, period, 3.0 * span + 1.0)
        xf, xr = np.mod(xf - base, box), np.mod(xr - base, box)
        tree = cKDTree(xr, boxsize=box)
    else:
        tree = cKDTree(xr)
    d, _ = tree.query(xf, k=1, distance_upper_bound=limit)
    return float(d.min())


def fluid_c0(scene, materials) -> float | None:
    """The speed of sound c0 [m/s] of the scene's fluid: that of the materials of its
    fluid blocks (the fluid module requires one shared value; the largest is taken),
    otherwise the largest c0 any material declares; None if none does."""
    fluid = {b.material for b in scene.blocks if b.kind == "fluid"}
    c0s = [m.c0 for name, m in materials.items() if name in fluid and m.c0]
    c0s = c0s or [m.c0 for m in materials.values() if m.c0]
    return max(c0s) if c0s else None


class CouplingModule(PhysicsModule):
    """The ``coupling`` physics module: reads ``scene.coupling`` (see
    :mod:`coupling.scene_section`); list it after ``fluid`` and ``heat``."""

    name = "coupling"

    def __init__(self, scene):
        super().__init__(scene)
        self.cfg = scene.coupling
        self.driver = None
        self.steps = 0
        self.ledger = None
        #: first contact: the end of the first step at which a fluid particle is closer than
        #: the support radius R to a particle of the coupled region (the fluid's forces on
        #: the substrate start there); None until then
        self.contact = None
        self.clearance0 = None
        #: the record lists' pickles per state key (:meth:`checkpoint_state`)
        self._record_logs: dict = {}

    def init(self, ctx) -> None:
        from coupling.backends import FEMBackend, TLSPHBackend
        from coupling.sensors import coupled_region

        sc, cfg = self.scene, self.cfg
        reg = coupled_region(sc, cfg)
        names, shapes, lo, hi, T0 = reg.names, reg.shapes, reg.lo, reg.hi, reg.T0
        ps = ctx.particles
        mats = [sc.material_index(cfg.material)]
        region_sel = SensorSet(shapes, mats, tol=1e-9 * float(np.max(hi - lo)))
        if cfg.backend == "fem":
            backend = FEMBackend(build_substrate(sc, cfg, lo, hi, T0), cfg.surface,
                                 cfg.temperature_map, R=ctx.R, kernel=ctx.kernel)
        elif cfg.backend == "fem-dynamic":
            from coupling.backend_fem_dynamic import DynamicFEMBackend

            if ctx.t > 0.0:
                raise ValueError('coupling.backend = "fem-dynamic" cannot resume from a '
                                 "checkpoint: the substrate's velocity and acceleration are "
                                 "not checkpointed; rerun from t = 0")

            rho = sc.materials[cfg.material].rho0
            backend = DynamicFEMBackend(build_substrate(sc, cfg, lo, hi, T0), rho,
                                        cfg.surface, cfg.temperature_map, R=ctx.R,
                                        kernel=ctx.kernel, hht_alpha=cfg.hht_alpha,
                                        mass=cfg.mass, t0=float(ctx.t))
        elif cfg.backend == "fem-axisymmetric":
            from coupling.axisymmetric_scene import build_axisymmetric_backend

            backend = build_axisymmetric_backend(sc, cfg, lo, hi, T0, ctx)
        else:
            backend = TLSPHBackend.from_scene(sc, cfg, reg)
        plane = getattr(backend, "surface_plane", None)
        surface = None
        if plane is not None:
            ax, value, inward = plane
            surface = Surface(ax, value, inward)
        depth = cfg.sensor_depth if cfg.sensor_depth is not None else ctx.R
        sensors = SensorSet(shapes, mats, surface=surface, depth=depth,
                            tol=region_sel.tol)
        probes = cfg.probes
        fem = isinstance(backend, FEMBackend)  # every FEM backend has a mesh to probe
        if probes is None and plane is not None and fem:
            # under the centre of the coupled surface (axisymmetric: on the axis, r = 0)
            plo = np.r_[-hi[0], lo[1:]] if getattr(backend, "axisymmetric", False) else lo
            probes = default_probes(backend.sub.mesh, plane, plo, hi)
        if probes is not None and fem:
            backend.sub.probe_matrix(np.asarray(probes, float))  # raises if outside the mesh
        self.driver = CouplingDriver(sensors, backend, probes, cfg.every_k_steps,
                                     cfg.vtu_every)
        from coupling.substrate_heat import build_substrate_heat

        self.driver.thermal = build_substrate_heat(sc, cfg, ctx, reg)
        if self.driver.thermal is not None and backend.temperature_map != "off":
            backend.temperature_map = "nodes"  # the heat field at the nodes, copied
        region = sensors.region_mask(ps)
        if not region.any():
            raise ValueError(f"coupling: no particle of material {cfg.material!r} in blocks "
                             f"{names}")
        self.region_count = int(region.sum())
        self.sensor_count = int(sensors.sensor_mask(ps).sum())
        if "c_heat" in ps and np.all(ps.c_heat[region] > 0) and self.driver.thermal is None:
            self.ledger = HeatLedger(ps, region)
        self._U, self._kappa = self._scales(ctx, ps)
        self._t_init = float(ctx.t)
        d0 = fluid_region_distance(ps, sensors.region_mask, ctx.period)
        self.clearance0 = d0 - ctx.R if math.isfinite(d0) else None
        if d0 < ctx.R and ctx.t > 0.0:  # resumed from a checkpoint past contact
            self.contact = self._resumed_in_contact(ctx.t)
        elif d0 < ctx.R:
            self.contact = {"t_s": float(ctx.t), "step": int(ctx.step)}
            logger.warning("coupling: fluid within the support radius of the substrate at the "
                           "start (t = %g s): the substrate is loaded before impact; place "
                           "the fluid with [[blocks]] above/gap", ctx.t)
        self.driver.couple(ps, ctx.t, ctx.step, self._folder(ctx))
        logger.info("coupling: %d region particles, %d sensors, backend %s", self.region_count,
                    self.sensor_count, cfg.backend)

    def _scales(self, ctx, ps):
        """(U, kappa) of :func:`default_every_k`: U the largest of the fluid's initial speed
        and c0 / 10 (None without fluid), kappa = k / (rho0 c) of the coupled material."""
        fl = ps.kind == FLUID
        U = float(np.sqrt((ps.v[fl] ** 2).sum(axis=1)).max()) if fl.any() and "v" in ps else 0.0
        c0 = fluid_c0(self.scene, ctx.materials)
        if fl.any() and c0:
            U = max(U, c0 / 10.0)
        mat = ctx.materials[self.cfg.material]
        kappa = mat.k / (mat.rho0 * mat.c) if (mat.k and mat.c) else None
        return (U if fl.any() else None), kappa

    def _folder(self, ctx):
        return None if ctx.out is None else Path(ctx.out) / self.cfg.output

    def start(self, ctx) -> None:
        """A fresh run starts: write the record of the state before the first step (the
        solve of ``init``) into the output folder; a resumed run writes at its first solve."""
        if ctx.step == 0 and self.driver.history and ctx.out is not None:
            self.driver.write_history(self._folder(ctx))

    def step(self, ctx, dt: float) -> None:
        if self.driver.every_k is None:
            self.driver.every_k = default_every_k(self.scene.sph.dx, dt, self._U, self._kappa)
            logger.info("coupling: one substrate solve every %d steps", self.driver.every_k)
        self.steps += 1
        t_new = ctx.t + dt
        if self.contact is None and self.clearance0 is not None:
            d = fluid_region_distance(ctx.particles, self.driver.sensors.region_mask,
                                      ctx.period, limit=ctx.R)
            if d < ctx.R and self.steps == 1 and ctx.t > self._t_init:
                self.contact = self._resumed_in_contact(ctx.t)
            elif d < ctx.R:
                self.contact = {"t_s": float(t_new), "step": int(ctx.step + 1)}
                logger.info("coupling: first contact at t = %g s", t_new)
        tm = self.scene.time
        last = t_new >= tm.t_end * (1 - 1e-12) or (
            tm.max_steps is not None and ctx.step + 1 >= tm.max_steps)
        self.driver.maybe_couple(ctx.particles, t_new, self.steps, last, self._folder(ctx))

    def diagnostics(self, ctx) -> dict:
        self.driver.flush()  # the summary is written: so is every record (a stopped run too)
        d = {"region_particles": self.region_count, "sensors": self.sensor_count,
             **self.driver.summary()}
        d["contact"] = self.contact_record()
        d["t_contact_s"] = d["contact"]["t_s"]
        tp, tc = d.get("peak_von_mises_t_s"), d["t_contact_s"]
        d["peak_von_mises_t_after_contact_s"] = (tp - tc if tp is not None and tc is not None
                                                 else None)
        if "last" in d and tc is not None:
            d["last"]["t_after_contact_s"] = d["last"]["t"] - tc
        if self.ledger is not None:
            region = self.driver.sensors.region_mask(ctx.particles)
            d["heat"] = self.ledger.figures(ctx.particles, region)
        if self.driver.thermal is not None:
            d["substrate_heat"] = self.driver.thermal.diagnostics(ctx.particles)
        return d


    # -- checkpoint ---------------------------------------------------------------------
    #: attributes saved in a checkpoint, per object (the rest is rebuilt by ``init``)
    _STATE = {"module": ("steps", "contact", "clearance0", "ledger"),
              "driver": ("history", "peak", "max_force_residual", "max_moment_residual",
                         "n_written", "every_k"),
              "thermal": ("t_last", "q_ideal", "history", "T_impact_max", "T_impact_max_t",
                          "uncovered_max", "fluid_e0", "T_fluid", "T_s0", "impact_point"),
              "heat": ("T", "t", "steps", "factorisations", "H0", "_h0_key", "heat_in",
                       "heat_dirichlet"),
              "interface": ("t", "t_wet", "s2", "strain", "heat_to_substrate",
                            "heat_from_fluid", "steps", "held", "held_excess_max")}

    def _stateful(self) -> dict:
        th = self.driver.thermal
        objs = {"module": self, "driver": self.driver}
        if th is not None:
            objs.update(thermal=th, heat=th.heat, interface=th.itf)
        return objs

    #: the attributes of _STATE that are record lists (appended to, a record never changed
    #: once appended): checkpointed as :class:`PickledRecords`, not deep-copied
    _RECORDS = {"driver": "history", "thermal": "history"}

    def checkpoint_state(self, ctx) -> dict:
        """The records, running peaks, contact time and, with ``[coupling.heat] model =
        "fem-contact"``, the substrate's temperature field and the contact interface's
        layer state (module docstring of :mod:`coupling.heat_interface`).  The record
        lists go in as :class:`PickledRecords` (each record pickled once, at the first
        checkpoint after it was appended: deep-copying the whole history at every
        checkpoint made the checkpoints' cost quadratic in the run's length), the rest
        as deep copies."""
        from sphfem.physics import snapshot_attrs

        logs = self._record_logs
        out = {}
        for key, obj in self._stateful().items():
            names = self._STATE[key]
            rec = self._RECORDS.get(key)
            st = snapshot_attrs(obj, [a for a in names if a != rec])
            if rec in names:
                st[rec] = logs.setdefault(key, RecordPickles()).snapshot(getattr(obj, rec))
            out[key] = {a: st[a] for a in names}
        return out

    def restore_state(self, ctx, state: dict) -> None:
        objs = self._stateful()
        if set(state) != set(objs):
            raise ValueError(f"coupling: the checkpoint holds the states of {sorted(state)}, "
                             f"this scene needs {sorted(objs)}: rerun from t = 0")
        for key, obj in objs.items():
            for a, v in state[key].items():
                setattr(obj, a, v.records() if isinstance(v, PickledRecords) else v)
        if self.driver.thermal is not None:
            self.driver.thermal.heat._lu = {}  # factorised again for the restored H0
            if "T_fluid" in state["thermal"]:  # (checkpoints before 2026-12-03 lack it)
                self.driver.thermal.reference_from_initial_state()

    @staticmethod
    def _resumed_in_contact(t: float) -> dict:
        """A run resumed from a checkpoint already past contact: its time is not known here."""
        return {"t_s": None, "step": None,
                "note": f"in contact when resumed at t = {t:g} s; the contact time is in the "
                        f"summary.json of the earlier process"}

    def contact_record(self) -> dict:
        """First contact (``t_s``, ``step``; None if the fluid never came within R) with
        the clearance at the start, the particle distance beyond R the fluid had to travel."""
        c = self.contact or {"t_s": None, "step": None}
        return {**c, "clearance_at_start_m": self.clearance0,
                "criterion": "end of the first step at which a fluid particle is closer than "
                             "the support radius R to a particle of the coupled region"}


def default_probes(mesh, plane, region_lo, region_hi, fractions=(0.0, 0.125, 0.25, 0.5, 0.75)):
    """Points under the centre of the coupled surface at the given fractions of the
    substrate's thickness (the surface point a hair inside)."""
    ax, value, inward = plane
    c = 0.5 * (np.asarray(region_lo, float) + np.asarray(region_hi, float))
    thick = float(np.ptp(mesh.p[ax]))
    pts = []
    for f in fractions:
        p = c.copy()
        p[ax] = value + inward * max(f * thick, 1e-6 * thick)
        pts.append(p)
    return np.array(pts)

