"""Substrate backends: what the staggered driver hands loads to and reads stresses from.

The driver (:mod:`coupling.driver`) talks to a substrate only through this protocol, so
the total-Lagrangian SPH solid can replace the FEM substrate without any change to the
driver.  Both backends live here and wrap a substrate of ``sphfem`` (which never imports
``coupling``): :class:`FEMBackend` a :class:`sphfem.fem.FEMSubstrate`, :class:`TLSPHBackend`
a :class:`sphfem.solid.backend.TLSPHSubstrate`; :data:`BACKENDS` names them.

``backend.apply(points, forces, T_points, T, vol) -> dict``
    This coupling step's loads: point forces ``forces`` (n, dim) [N] acting on the coupled
    surface at the sensor positions ``points`` (n, dim), and the SPH solid region's
    temperatures ``T`` (m,) [K] at ``T_points`` (m, dim) with particle volumes ``vol``
    (``T=None``: no thermal load).  The FEM backend maps them (:mod:`coupling.transfer`);
    the TL-SPH backend puts each force on the nearest particle of the coupled face and takes
    each particle's temperature from the nearest region particle.  Returns the bookkeeping
    of the hand-over: ``force_in`` / ``force_out`` (totals before and after the transfer),
    ``moment_in`` / ``moment_out``, ``clipped`` (sensors off the surface).
``backend.solve(t) -> CoupledResult``
    Quasi-static response to the loads (FEM: one back-substitution; TL-SPH: dynamic
    relaxation, warm-started), packaged as a :class:`CoupledResult` by either backend.
``backend.write(t, folder) -> path | None``
    One frame of the backend's own output series (FEM: VTU + PVD; TL-SPH: particle VTU).
``backend.diagnostics() -> dict``
    JSON figures for summary.json (size, set-up and solve seconds, map statistics).
Attributes: ``name``, ``dim``, ``T0`` (reference temperature [K]), ``sub`` (the substrate)
and ``surface_plane`` (``(axis, value, inward)`` of the coupled surface, or None).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
from scipy.spatial import cKDTree

from coupling.sensors import coupled_region
from coupling.transfer import ForceTransfer, TemperatureMap, group_plane, point_moment
from sphfem.solid.backend import TLSPHSubstrate, face_axes


@runtime_checkable
class SubstrateBackend(Protocol):
    name: str
    dim: int
    T0: float

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict: ...

    def solve(self, t: float) -> CoupledResult: ...

    def write(self, t: float, folder): ...

    def diagnostics(self) -> dict: ...


@dataclass
class CoupledResult:
    """A coupling step's substrate solution, the same type for every backend.

    ``result`` is the substrate's own result (:class:`sphfem.fem.FEMResult` or
    :class:`sphfem.solid.backend.TLSPHResult`): ``probe(points)`` -> ``u``, ``stress``,
    ``von_mises``, ``dT`` and ``von_mises_nodes`` at ``nodes``.  ``cell_stress`` and
    ``cell_volume`` are the stress and measure of the substrate's cells (FEM: element
    averages and element areas / volumes; TL-SPH: particles and their volumes), whose
    volume average is :meth:`mean_stress`.
    """

    result: object
    t: float
    T0: float  #: reference temperature [K]: probe T = T0 + dT
    nodes: np.ndarray  #: (n, dim) positions of ``result.von_mises_nodes`` [m]
    cell_stress: np.ndarray  #: (m, 3, 3) Cauchy stress per cell [Pa]
    cell_volume: np.ndarray  #: (m,) cell measures [m^dim]

    def probe(self, points) -> dict:
        """``stress`` (n, 3, 3), ``von_mises`` (n,), ``u`` (n, dim) and absolute ``T`` (n,)
        at ``points`` (n, dim) in the substrate."""
        r = self.result.probe(points)
        return {"stress": r["stress"], "von_mises": r["von_mises"], "u": r["u"],
                "T": r["dT"] + self.T0}

    def peak_von_mises(self) -> tuple[float, np.ndarray]:
        """Largest nodal von Mises stress [Pa] and its node's position."""
        vm = self.result.von_mises_nodes
        i = int(np.argmax(vm))
        return float(vm[i]), self.nodes[i].copy()

    def mean_stress(self) -> np.ndarray:
        """Volume average of the stress over the substrate, (3, 3): sum_c V_c sigma_c /
        sum_c V_c (Park 2019 eq. 2.110 divided by the volume)."""
        v = self.cell_volume
        return (self.cell_stress * v[:, None, None]).sum(axis=0) / v.sum()


class FEMBackend:
    """The FEM substrate (:class:`sphfem.fem.FEMSubstrate`, K factorised once) as a backend.

    ``surface``: facet group the sensor forces act on; ``temperature_map``: "mls",
    "shepard", "nearest" (:class:`coupling.transfer.TemperatureMap`), "nodes" (the
    temperatures come at :attr:`temperature_targets` themselves) or "off" (no thermal
    load); ``R``, ``kernel``: the SPH support radius and kernel of the map.  P1 meshes take
    temperatures at the vertices, P2 at every scalar dof.
    """

    name = "fem"

    def __init__(self, substrate, surface: str = "top", temperature_map: str = "mls",
                 R: float | None = None, kernel: str = "wendland_c2"):
        self.sub = substrate
        self.dim = substrate.dim
        self.T0 = substrate.T0
        self.surface = surface
        self.temperature_map = temperature_map
        if temperature_map != "off" and R is None:
            raise ValueError("FEMBackend: the temperature map needs the SPH support radius R")
        self.R = R
        self.kernel = kernel
        self.surface_plane = group_plane(substrate.mesh, surface)
        self._cell_volume = substrate.basis.dx.sum(axis=-1)  # element measures
        self._forces: ForceTransfer | None = None
        self._tmap: TemperatureMap | None = None
        self._tmap_key = None
        self._f = None
        self._T_nodes = None
        self.series = None
        self.timings = {"transfer_setup": 0.0, "transfer": 0.0, "solve": 0.0, "stress": 0.0,
                        "write": 0.0}
        self.n_solves = 0

    @property
    def temperature_targets(self) -> np.ndarray:
        s = self.sub
        return (s.mesh.p if s.element == "P1" else s.sbasis.doflocs).T

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict:
        t0 = time.perf_counter()
        points = np.atleast_2d(np.asarray(points, float)).reshape(-1, self.dim)
        forces = np.atleast_2d(np.asarray(forces, float)).reshape(-1, self.dim)
        if self._forces is None or not self._forces.matches(points):
            self._forces = ForceTransfer(self.sub, points, self.surface)
            self.timings["transfer_setup"] += time.perf_counter() - t0
        t1 = time.perf_counter()
        ft = self._forces
        self._f = ft.loads(forces)
        # moments about the snapped points: f = P^T F conserves them exactly
        book = _bookkeeping(forces, ft.points, ft.total(self._f), ft.moment(self._f),
                            int(ft.clipped.sum()))
        self.timings["transfer"] += time.perf_counter() - t1
        self._T_nodes = None
        if T is not None and self.temperature_map == "nodes":
            # the temperatures are already at the targets (a substrate heat field on the
            # same nodes, coupling.substrate_heat): copied, no particle map to build
            T = np.asarray(T, float)
            if T.shape != (len(self.temperature_targets),):
                raise ValueError(f"temperature_map = 'nodes' takes one temperature per "
                                 f"substrate node ({len(self.temperature_targets)}), got "
                                 f"{T.shape}")
            self._T_nodes = T.copy()
        elif T is not None and self.temperature_map != "off":
            t2 = time.perf_counter()
            Tp = np.atleast_2d(np.asarray(T_points, float))
            key = (Tp.shape, Tp.tobytes())
            if self._tmap is None or self._tmap_key != key:
                self._tmap = TemperatureMap(self.temperature_targets, Tp, vol, self.R,
                                            self.temperature_map, self.kernel)
                self._tmap_key = key
                self.timings["transfer_setup"] += time.perf_counter() - t2
            t3 = time.perf_counter()
            self._T_nodes = self._tmap(T, self.T0)
            self.timings["transfer"] += time.perf_counter() - t3
        return book

    def solve(self, t: float) -> CoupledResult:
        t0 = time.perf_counter()
        dT = None if self._T_nodes is None else self._T_nodes - self.T0
        res = self.sub.solve(dT_nodal=dT, load=self._f)
        self.timings["solve"] += time.perf_counter() - t0
        t1 = time.perf_counter()
        _ = res.von_mises_nodes  # stress recovery, timed here (cached on the result)
        out = CoupledResult(res, t, self.T0, self.sub.mesh.p.T, res.stress_elem,
                            self._cell_volume)
        self.timings["stress"] += time.perf_counter() - t1
        self.n_solves += 1
        self.last = out
        return out

    def write(self, t: float, folder):
        from sphfem.fem import FEMSeries

        t0 = time.perf_counter()
        if self.series is None or self.series.folder != folder:
            self.series = FEMSeries(folder, name="substrate")
        path = self.series.write(t, self.last.result)
        self.timings["write"] += time.perf_counter() - t0
        return path

    def diagnostics(self) -> dict:
        s = self.sub
        d = {"backend": "fem", "mesh": type(s.mesh).__name__, "element": s.element,
             "vertices": int(s.mesh.nvertices), "elements": int(s.mesh.nelements),
             "dofs": int(s.n_dofs), "free_dofs": int(len(s.I)), "solver": s.solver,
             "factorizations": s.n_factorizations, "solves": self.n_solves,
             "setup_s": dict(s.timings), "coupling_s": dict(self.timings),
             "surface": self.surface}
        if self._tmap is not None:
            d["temperature_map"] = self._tmap.stats()
        elif self.temperature_map == "nodes":
            d["temperature_map"] = {"method": "nodes", "targets": len(self.temperature_targets)}
        if self._forces is not None:
            d["sensors_clipped"] = int(self._forces.clipped.sum())
        return d


class TLSPHBackend:
    """The TL-SPH substrate (:class:`sphfem.solid.backend.TLSPHSubstrate`) as a backend.

    ``surface``: the box face the sensor forces act on.  Each coupling step:

    * each sensor force acts on the nearest particle of the coupled face (totals exact; the
      moment changes by the snap distance, reported as ``moment_out``);
    * each substrate particle takes the temperature of the nearest SPH region particle (on
      the region's own lattice, :meth:`from_scene`, this is the identity);
    * ``solve`` relaxes to the quasi-static state, warm-started from the previous one.
    """

    name = "tlsph"

    def __init__(self, substrate: TLSPHSubstrate, surface: str = "top"):
        _check_face(surface, substrate.dim)
        t0 = time.perf_counter()
        self.sub = substrate
        self.dim = substrate.dim
        self.T0 = substrate.T0
        self.surface = surface
        ax, side = substrate.faces[surface]
        edge = substrate.hi[ax] if side > 0 else substrate.lo[ax]
        self.surface_plane = (ax, float(edge), -side)
        layer = substrate.face_layer[surface]
        self._layer_X = substrate.body.ref.X[layer]
        self._layer_tree = cKDTree(self._layer_X)
        self._F = None
        self._P = None
        self._dT = None
        self._tmap_key = None
        self._tmap_src = None
        self.series = []
        self.n_solves = 0
        self.timings = {"setup": substrate.timings["setup"] + time.perf_counter() - t0,
                        "transfer": 0.0, "solve": 0.0, "write": 0.0}

    @classmethod
    def from_scene(cls, scene, config, region=None) -> TLSPHBackend:
        """The substrate of a ``[coupling]`` section: the box of the SPH solid region
        (``region``, default :func:`coupling.sensors.coupled_region`) or ``[coupling.mesh]
        lo/hi``, on the scene's spacing ``[sph] dx`` (the box rounded to whole spacings) and
        support factor, with the section's material (E, nu, alpha, rho0), ``clamps`` and
        ``rollers`` naming box faces as the gmsh recipes do."""
        cfg = config
        _check_face(cfg.surface, scene.dim)
        region = coupled_region(scene, cfg) if region is None else region
        mat = scene.materials[cfg.material]
        m = cfg["mesh"]
        lo = np.asarray(m.lo, float) if m.lo is not None else region.lo
        hi = np.asarray(m.hi, float) if m.hi is not None else region.hi
        dx = float(scene.sph.dx)
        counts = np.maximum(1, np.rint((hi - lo) / dx)).astype(int)
        sub = TLSPHSubstrate(lo, lo + counts * dx, dx, mat.E, mat.nu, mat.alpha or 0.0,
                             T0=region.T0, rho=mat.rho0, clamps=tuple(cfg.clamps),
                             rollers=dict(cfg.rollers or {}),
                             support_factor=scene.sph.support_factor)
        return cls(sub, cfg.surface)

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict:
        t0 = time.perf_counter()
        P = np.atleast_2d(np.asarray(points, float)).reshape(-1, self.dim)
        F = np.atleast_2d(np.asarray(forces, float)).reshape(-1, self.dim)
        self._P, self._F = P, F
        snapped = self._layer_X[self._layer_tree.query(P)[1]] if len(P) else P
        book = _bookkeeping(F, P, F.sum(axis=0), point_moment(snapped, F) if len(P) else None,
                            0)
        self._dT = None
        if T is not None:
            Tp = np.atleast_2d(np.asarray(T_points, float))
            key = (Tp.shape, Tp.tobytes())
            if key != self._tmap_key:
                _, self._tmap_src = cKDTree(Tp).query(self.sub.X)
                self._tmap_key = key
            self._dT = np.asarray(T, float)[self._tmap_src] - self.T0
        self.timings["transfer"] += time.perf_counter() - t0
        return book

    def solve(self, t: float) -> CoupledResult:
        t0 = time.perf_counter()
        pf = (self._P, self._F) if self._P is not None and len(self._P) else None
        res = self.sub.solve(dT_nodal=self._dT, point_forces=pf, snap=self.surface)
        self.timings["solve"] += time.perf_counter() - t0
        self.n_solves += 1
        self.last = CoupledResult(res, t, self.T0, self.sub.X, res.stress, self.sub.vol)
        return self.last

    def write(self, t: float, folder):
        """Particles of the substrate as a VTU (vertex cells): u, von Mises, stress, T."""
        import meshio

        t0 = time.perf_counter()
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        r = self.last.result
        X = self.sub.X
        pts = np.zeros((len(X), 3))
        pts[:, : self.dim] = X + r.u
        path = folder / f"substrate_{len(self.series):05d}.vtu"
        u3 = np.zeros((len(X), 3))
        u3[:, : self.dim] = r.u
        meshio.write(path, meshio.Mesh(
            pts, [("vertex", np.arange(len(X)).reshape(-1, 1))],
            point_data={"u": u3, "von_mises": r.von_mises,
                        "stress": r.stress.reshape(len(X), 9), "T": r.dT + self.T0}))
        self.series.append((float(t), path.name))
        self.timings["write"] += time.perf_counter() - t0
        return path

    def diagnostics(self) -> dict:
        return {**self.sub.diagnostics(), "surface": self.surface, "solves": self.n_solves,
                "coupling_s": dict(self.timings)}


def _check_face(surface: str, dim: int) -> None:
    faces = face_axes(dim)
    if surface not in faces:
        raise ValueError(f"coupling.surface {surface!r}: the TL-SPH backend names box faces "
                         f"{sorted(faces)}")


def _bookkeeping(forces, at, force_out, moment_out, clipped: int) -> dict:
    """The hand-over's record: total force and moment of the sensor ``forces`` acting at
    ``at`` (n, dim) and what the substrate received (``moment_out`` None: no sensors,
    zero), with the number of ``clipped`` sensors."""
    zero = np.zeros(3 if at.shape[1] == 3 else 1)
    return {"force_in": forces.sum(axis=0), "force_out": force_out,
            "moment_in": point_moment(at, forces) if len(at) else zero,
            "moment_out": moment_out if moment_out is not None else zero,
            "clipped": clipped}


#: backend name -> class (``[coupling] backend``)
BACKENDS = {"fem": FEMBackend, "tlsph": TLSPHBackend}


def make_backend(kind: str, **kw):
    """The backend ``kind`` of :data:`BACKENDS` built with ``kw``: ``"fem"`` ->
    :class:`FEMBackend` (substrate, surface, temperature_map, R, kernel); ``"tlsph"`` ->
    :class:`TLSPHBackend` (substrate, surface)."""
    if kind not in BACKENDS:
        raise ValueError(f"unknown substrate backend {kind!r}; expected one of "
                         f"{sorted(BACKENDS)}")
    return BACKENDS[kind](**kw)
