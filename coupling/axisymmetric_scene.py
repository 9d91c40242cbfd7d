"""The substrate of an axisymmetric scene: ``[coupling] backend = "fem-axisymmetric"``.

In a scene with ``[scene] geometry = "axisymmetric"`` (:mod:`sphfem.axisymmetric_scene`)
the wall particles are rings; the fluid writes on each the total force of its ring
(``f_fluid`` [N], eq. 1 there), so the sensors hand ring forces to
:class:`coupling.backend_fem_axisymmetric.AxisymmetricFEMBackend` with
``force_convention = "ring"``: f = P^T F / (2 pi) per radian on the (r, z) mesh, whose net
axial load is then sum_w F_w,z, the integral of the wall pressure over the wetted disc.

The substrate (:func:`build_axisymmetric_backend`) is an
:class:`sphfem.fem.axisymmetric.AxisymmetricFEMSubstrate` on the ``[coupling.mesh]`` recipe's
(r, z) rectangle (:func:`sphfem.fem.meshing.substrate_rect`: ``lo``/``hi`` in (r, z), lo[0]
= 0, refined around the impact point (0, top) by default) or on ``mesh_file``; the axis
r = 0 carries u_r = 0, ``clamps`` / ``rollers`` by group name ("right", "bottom").

Temperatures: the particles' ``vol`` are ring volumes 2 pi r A, while the particle -> node
map of the (r, z) plane wants meridian areas A (:class:`RingBackend` divides by 2 pi r).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from coupling.backend_fem_axisymmetric import AxisymmetricFEMBackend

__all__ = ["RingBackend", "build_axisymmetric_backend"]


class RingBackend(AxisymmetricFEMBackend):
    """:class:`AxisymmetricFEMBackend` fed by ring particles: ring forces ("ring"
    convention) and ring volumes, turned into meridian areas A = vol / (2 pi r) for the
    temperature map."""

    axisymmetric = True

    def apply(self, points, forces, T_points=None, T=None, vol=None) -> dict:
        if vol is not None and T_points is not None:
            r = np.atleast_2d(np.asarray(T_points, float))[:, 0]
            vol = np.asarray(vol, float) / (2.0 * math.pi * np.maximum(r, 1e-300))
        return super().apply(points, forces, T_points, T, vol)


def build_axisymmetric_backend(scene, cfg, region_lo, region_hi, T0: float, ctx):
    """The :class:`RingBackend` of ``scene.coupling`` (module docstring)."""
    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate
    from sphfem.fem.meshing import substrate_rect
    from sphfem.fem.substrate import load_mesh
    from sphfem.schema import SceneError

    mat = scene.materials[cfg.material]
    t0 = time.perf_counter()
    if cfg.mesh_file is not None:
        path = Path(cfg.mesh_file)
        if not path.is_absolute() and scene.source and not scene.source.startswith("<"):
            path = Path(scene.source).resolve().parent / path
        try:
            mesh = load_mesh(path)
        except Exception as e:  # whatever meshio / scikit-fem make of a user's file
            raise SceneError(scene.source or "", "coupling.mesh_file",
                             f"mesh file {path} could not be read ({e})") from None
    else:
        m = cfg["mesh"]
        lo = np.array(m.lo if m.lo is not None else region_lo, float)
        hi = np.array(m.hi if m.hi is not None else region_hi, float)
        if lo[0] != 0.0:
            raise SceneError(scene.source or "", "coupling.mesh.lo",
                             f"an axisymmetric substrate starts at the axis: lo[0] = 0, got "
                             f"{lo[0]:g}")
        h_fine = m.h_fine if m.h_fine is not None else 2.0 * scene.sph.dx
        h_coarse = m.h_coarse if m.h_coarse is not None else 8.0 * h_fine
        center = (tuple(m.refine_center) if m.refine_center is not None
                  else (0.0, float(region_hi[1])))
        radius = (m.refine_radius if m.refine_radius is not None
                  else 0.5 * float(region_hi[0] - region_lo[0]))
        path = substrate_rect(size=tuple(hi - lo), origin=tuple(lo), h_fine=h_fine,
                              h_coarse=max(h_coarse, h_fine), refine_center=center,
                              refine_radius=radius, growth=m.growth,
                              element=m.cells or "quad")
        mesh = load_mesh(path)
    t_load = time.perf_counter() - t0
    sub = AxisymmetricFEMSubstrate(mesh, E=mat.E, nu=mat.nu, alpha=mat.alpha or 0.0, T0=T0,
                                   element=cfg.element, clamps=list(cfg.clamps),
                                   rollers=dict(cfg.rollers or {}), force_convention="ring")
    sub.mesh_path = Path(path)
    sub.timings["load_mesh"] = t_load
    return RingBackend(sub, cfg.surface, cfg.temperature_map, R=ctx.R, kernel=ctx.kernel,
                       force_convention="ring")
