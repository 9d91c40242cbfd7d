"""``TLSPHBackend``: the TL-SPH substrate behind the coupling driver's backend protocol
(:mod:`coupling.backends`: ``apply``, ``solve``, ``write``, ``diagnostics``).

The substrate is a :class:`~sphfem.solid.backend.TLSPHSubstrate` on the box of the SPH solid
region (or ``[coupling.mesh] lo/hi``) with the scene's spacing ``[sph] dx`` and support
factor, the ``[coupling]`` material (E, nu, alpha, rho0), ``clamps`` and ``rollers`` naming
box faces as the gmsh recipes do.  Each coupling step:

* sensor point forces act on the nearest particle of the coupled face (totals exact; the
  moment changes by the snap distance, reported as ``moment_out``);
* the SPH region's temperatures are taken at the nearest region particle (the substrate's
  lattice is the region's, so on matching lattices this is the identity);
* ``solve`` relaxes to the quasi-static state (warm start), like the FEM backend.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from sphfem.solid.backend import TLSPHSubstrate, face_axes


class TLSPHCoupledResult:
    def __init__(self, result, t: float, T0: float):
        self.res = result
        self.t = float(t)
        self.T0 = T0

    def probe(self, points) -> dict:
        r = self.res.probe(points)
        return {"stress": r["stress"], "von_mises": r["von_mises"], "u": r["u"],
                "T": r["dT"] + self.T0}

    def peak_von_mises(self) -> tuple[float, np.ndarray]:
        vm = self.res.von_mises
        i = int(np.argmax(vm))
        return float(vm[i]), self.res.substrate.X[i].copy()

    def mean_stress(self) -> np.ndarray:
        return self.res.stress.mean(axis=0)  # equal particle volumes


class TLSPHBackend:
    name = "tlsph"

    def __init__(self, scene, sim, config):
        from sphfem.geometry import Shape

        cfg = config
        mat = scene.materials[cfg.material]
        names = cfg.blocks if cfg.blocks is not None else [
            b.name for b in scene.blocks if b.material == cfg.material
            and b.kind in ("wall", "solid")]
        shapes = [Shape.from_block(scene.blocks[scene.block_index(n)], scene.dim)
                  for n in names]
        lo = np.min([s.bounds()[0] for s in shapes], axis=0).astype(float)
        hi = np.max([s.bounds()[1] for s in shapes], axis=0).astype(float)
        m = cfg["mesh"]
        if m.lo is not None:
            lo = np.asarray(m.lo, float)
        if m.hi is not None:
            hi = np.asarray(m.hi, float)
        dx = float(scene.sph.dx)
        counts = np.maximum(1, np.rint((hi - lo) / dx)).astype(int)
        hi = lo + counts * dx
        first = scene.blocks[scene.block_index(names[0])]
        self.T0 = float(cfg.T0 if cfg.T0 is not None else first.temperature)
        self.dim = scene.dim
        self.surface = cfg.surface
        faces = face_axes(self.dim)
        if self.surface not in faces:
            raise ValueError(f"coupling.surface {self.surface!r}: the TL-SPH backend names "
                             f"box faces {sorted(faces)}")
        t0 = time.perf_counter()
        self.sub = TLSPHSubstrate(lo, hi, dx, mat.E, mat.nu, mat.alpha or 0.0, T0=self.T0,
                                  rho=mat.rho0, clamps=tuple(cfg.clamps),
                                  rollers=dict(cfg.rollers or {}),
                                  support_factor=scene.sph.support_factor)
        ax, side = faces[self.surface]
        self.surface_plane = (ax, float(hi[ax] if side > 0 else lo[ax]), -side)
        self._F = None
        self._P = None
        self._dT = None
        self._tmap_key = None
        self._tmap_src = None
        self.series = []
        self.n_solves = 0
        self.timings = {"setup": time.perf_counter() - t0, "transfer": 0.0, "solve": 0.0,
                        "write": 0.0}

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict:
        from coupling.transfer import point_moment

        t0 = time.perf_counter()
        P = np.atleast_2d(np.asarray(points, float)).reshape(-1, self.dim)
        F = np.atleast_2d(np.asarray(forces, float)).reshape(-1, self.dim)
        self._P, self._F = P, F
        layer = self.sub.face_layer[self.surface]
        if len(P):
            _, k = cKDTree(self.sub.body.ref.X[layer]).query(P)
            snapped = self.sub.body.ref.X[layer[k]]
        else:
            snapped = P
        book = {"force_in": F.sum(axis=0), "force_out": F.sum(axis=0),
                "moment_in": point_moment(P, F) if len(P) else
                np.zeros(3 if self.dim == 3 else 1),
                "moment_out": point_moment(snapped, F) if len(P) else
                np.zeros(3 if self.dim == 3 else 1), "clipped": 0}
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

    def solve(self, t: float) -> TLSPHCoupledResult:
        t0 = time.perf_counter()
        pf = (self._P, self._F) if self._P is not None and len(self._P) else None
        res = self.sub.solve(dT_nodal=self._dT, point_forces=pf, snap=self.surface)
        self.timings["solve"] += time.perf_counter() - t0
        self.n_solves += 1
        self.last = TLSPHCoupledResult(res, t, self.T0)
        return self.last

    def write(self, t: float, folder):
        """Particles of the substrate as a VTU (vertex cells): u, von Mises, stress, T."""
        import meshio

        t0 = time.perf_counter()
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        r = self.last.res
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
