"""Substrate backends: what the staggered driver hands loads to and reads stresses from.

The driver (:mod:`coupling.driver`) talks to a substrate only through this protocol, so a
total-Lagrangian SPH solid (issue 7, ``sphfem/solid``) can replace the FEM substrate
without any change to the driver:

``backend.apply(points, forces, T_points, T, vol) -> dict``
    This coupling step's loads: point forces ``forces`` (n, dim) [N] acting on the coupled
    surface at the sensor positions ``points`` (n, dim), and the SPH solid region's
    temperatures ``T`` (m,) [K] at ``T_points`` (m, dim) with particle volumes ``vol``
    (``T=None``: no thermal load).  A backend whose nodes *are* the particles (TL-SPH) takes
    the values as they are; the FEM backend maps them (:mod:`coupling.transfer`).  Returns
    the bookkeeping of the hand-over: ``force_in`` / ``force_out`` (totals before and after
    the transfer), ``moment_in`` / ``moment_out``, ``clipped`` (sensors off the surface).
``backend.solve(t) -> result``
    Quasi-static (FEM) or advanced (TL-SPH) response to the loads; ``result`` offers
    ``probe(points) -> {"stress": (n, 3, 3), "von_mises": (n,), "u": (n, dim), "T": (n,)}``,
    ``peak_von_mises() -> (value, location)`` and ``mean_stress() -> (3, 3)`` (volume
    average over the substrate, Park 2019 eq. 2.110 divided by the volume).
``backend.write(t, folder) -> path | None``
    One frame of the backend's own output series (FEM: VTU + PVD).
``backend.diagnostics() -> dict``
    JSON figures for summary.json (size, set-up and solve seconds, map statistics).
Attributes: ``name``, ``dim``, ``T0`` (reference temperature [K]) and ``surface_plane``
(``(axis, value, inward)`` of the coupled surface, or None).
"""

from __future__ import annotations

import inspect
import time
from typing import Protocol, runtime_checkable

import numpy as np

from coupling.transfer import ForceTransfer, TemperatureMap, group_plane, point_moment


@runtime_checkable
class SubstrateBackend(Protocol):
    name: str
    dim: int
    T0: float

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict: ...

    def solve(self, t: float): ...

    def write(self, t: float, folder): ...

    def diagnostics(self) -> dict: ...


class FEMCoupledResult:
    """A coupling step's FEM solution (wraps :class:`sphfem.fem.FEMResult`)."""

    def __init__(self, result, t: float, T0: float):
        self.fem = result
        self.t = float(t)
        self.T0 = T0

    def probe(self, points) -> dict:
        r = self.fem.probe(points)
        return {"stress": r["stress"], "von_mises": r["von_mises"], "u": r["u"],
                "T": r["dT"] + self.T0}

    def peak_von_mises(self) -> tuple[float, np.ndarray]:
        vm = self.fem.von_mises_nodes
        i = int(np.argmax(vm))
        return float(vm[i]), self.fem.substrate.mesh.p[:, i].copy()

    def mean_stress(self) -> np.ndarray:
        dx = self.fem.substrate.basis.dx.sum(axis=-1)  # element measures
        s = self.fem.stress_elem  # (nelems, 3, 3)
        return (s * dx[:, None, None]).sum(axis=0) / dx.sum()


class FEMBackend:
    """The FEM substrate (:class:`sphfem.fem.FEMSubstrate`, K factorised once) as a backend.

    ``surface``: facet group the sensor forces act on; ``temperature_map``: "mls",
    "shepard", "nearest" (:class:`coupling.transfer.TemperatureMap`) or "off" (no thermal
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
        self._forces: ForceTransfer | None = None
        self._tmap: TemperatureMap | None = None
        self._tmap_key = None
        self._f = None
        self._T_nodes = None
        self._has_load_arg = "load" in inspect.signature(substrate.solve).parameters
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
        self._F = forces
        book = {"force_in": forces.sum(axis=0), "force_out": ft.total(self._f),
                "moment_in": point_moment(ft.points, forces) if len(points) else
                np.zeros(3 if self.dim == 3 else 1),
                "moment_out": ft.moment(self._f), "clipped": int(ft.clipped.sum())}
        self.timings["transfer"] += time.perf_counter() - t1
        self._T_nodes = None
        if T is not None and self.temperature_map != "off":
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

    def solve(self, t: float) -> FEMCoupledResult:
        t0 = time.perf_counter()
        dT = None if self._T_nodes is None else self._T_nodes - self.T0
        if self._f is None:
            res = self.sub.solve(dT_nodal=dT)
        elif self._has_load_arg:
            res = self.sub.solve(dT_nodal=dT, load=self._f)
        else:  # the snapped points and the forces: P is rebuilt by the substrate
            res = self.sub.solve(dT_nodal=dT, point_forces=(self._forces.points, self._F),
                                 snap=None)
        self.timings["solve"] += time.perf_counter() - t0
        t1 = time.perf_counter()
        out = FEMCoupledResult(res, t, self.T0)
        _ = res.von_mises_nodes  # stress recovery, timed here (cached on the result)
        self.timings["stress"] += time.perf_counter() - t1
        self.n_solves += 1
        self.last = out
        return out

    def write(self, t: float, folder):
        from sphfem.fem import FEMSeries

        t0 = time.perf_counter()
        if self.series is None or self.series.folder != folder:
            self.series = FEMSeries(folder, name="substrate")
        path = self.series.write(t, self.last.fem)
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
        if self._forces is not None:
            d["sensors_clipped"] = int(self._forces.clipped.sum())
        return d


def make_backend(kind: str, **kw):
    """``"fem"`` -> :class:`FEMBackend` (``kw``: substrate, surface, temperature_map, R,
    kernel); ``"tlsph"`` -> ``sphfem.solid``'s backend (issue 7) once it exists."""
    if kind == "fem":
        return FEMBackend(**kw)
    if kind == "tlsph":
        try:
            from sphfem.solid import TLSPHBackend  # type: ignore[attr-defined]
        except ImportError:
            raise NotImplementedError(
                "coupling backend 'tlsph' needs sphfem.solid.TLSPHBackend (issue 7), which "
                "is not available in this installation; use backend = \"fem\"") from None
        return TLSPHBackend(**kw)
    raise ValueError(f"unknown substrate backend {kind!r}; expected 'fem' or 'tlsph'")
