"""Sensor particles: the SPH particles of the substrate's surface layers.

Park (2019) sec. 2.4.4.4: "Sensor particles that are located near the surface of the solid
directly feed the observed temperature and forces to the finite element nodes" (figure 2.5).
Here the sensors are the particles of the *SPH solid region* (the blocks the coupling names:
kind WALL -- the fluid's wall particles -- or SOLID for a heat-only substrate) that lie within
``depth`` of the coupled surface.  Every coupling step a :class:`SensorSet` reports

* ``force`` -- the force [N] the fluid exerts on each sensor, the ``f_fluid`` field the fluid
  writes (pressure + viscous pair forces, the exact negative of what the fluid feels from that
  wall particle, see :mod:`sphfem.fluid.wcsph`);
* ``T`` -- the temperature [K] of every particle of the SPH solid region (not only the
  surface layers: the substrate's temperature field is mapped from all of them).

Particles are found by a predicate (kind, material, inside one of the coupled blocks' shapes)
and reported in ascending ``id`` order, so a reading does not depend on the driver's cell
sorts and the transfer operators built for one reading stay valid while the walls stand
still.  Particles of the region deeper than ``depth`` are not sensors; any force found on
them is reported as ``unassigned_force`` (zero whenever ``depth`` >= the kernel support R,
because the fluid only pushes on particles within R of a fluid particle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sphfem.particles import SOLID, WALL, ParticleSet


@dataclass
class Surface:
    """An axis-aligned plane ``x[axis] = value``; ``inward`` = +1 if the solid lies on its
    +axis side, -1 if on its -axis side (a top face)."""

    axis: int
    value: float
    inward: int = -1

    def depth(self, x: np.ndarray) -> np.ndarray:
        """Distance below the surface, measured into the solid (negative outside)."""
        return self.inward * (x[:, self.axis] - self.value)


@dataclass
class SensorReading:
    """One coupling step's data, all in ascending particle-id order."""

    t: float
    x: np.ndarray  #: (n, dim) sensor positions [m]
    force: np.ndarray  #: (n, dim) force of the fluid on each sensor [N]
    ids: np.ndarray  #: (n,) particle ids of the sensors
    x_region: np.ndarray  #: (m, dim) positions of all region particles [m]
    T_region: np.ndarray | None  #: (m,) their temperatures [K] (None: no T field)
    vol_region: np.ndarray  #: (m,) their volumes [m^dim]
    ids_region: np.ndarray  #: (m,)
    unassigned_force: np.ndarray  #: (dim,) force on region particles that are not sensors

    @property
    def total_force(self) -> np.ndarray:
        return self.force.sum(axis=0)


class SensorSet:
    """Selects the SPH solid region and its sensor layers, and reads them.

    Parameters
    ----------
    shapes : shapes (:class:`sphfem.geometry.Shape`) of the coupled blocks; a particle
        belongs to the region when it lies in one of them (grown by ``tol``).  ``None``:
        every particle of the right kind and material.
    materials : material indices of the region (``None``: any).
    kinds : particle kinds of the region (default WALL and SOLID).
    surface : the coupled surface; ``None``: every region particle is a sensor.
    depth : sensors lie within this distance below ``surface`` [m].
    """

    def __init__(self, shapes=None, materials=None, kinds=(WALL, SOLID),
                 surface: Surface | None = None, depth: float = np.inf, tol: float = 0.0):
        self.shapes = list(shapes) if shapes is not None else None
        self.materials = None if materials is None else np.asarray(list(materials), np.int64)
        self.kinds = np.asarray(list(kinds), np.int64)
        self.surface = surface
        self.depth = float(depth)
        self.tol = float(tol)

    def region_mask(self, ps: ParticleSet) -> np.ndarray:
        m = np.isin(ps.kind, self.kinds)
        if self.materials is not None:
            m &= np.isin(ps.material, self.materials)
        if self.shapes is not None:
            inside = np.zeros(ps.n, bool)
            for s in self.shapes:
                inside |= s.contains(ps.x, self.tol)
            m &= inside
        return m

    def sensor_mask(self, ps: ParticleSet, region: np.ndarray | None = None) -> np.ndarray:
        region = self.region_mask(ps) if region is None else region
        if self.surface is None or not np.isfinite(self.depth):
            return region
        return region & (self.surface.depth(ps.x) <= self.depth)

    def read(self, ps: ParticleSet, t: float = 0.0) -> SensorReading:
        """Forces on the sensors and temperatures of the region, in ascending id order."""
        region = self.region_mask(ps)
        sens = self.sensor_mask(ps, region)
        dim = ps.dim
        f = ps.fields.get("f_fluid")
        ir = np.nonzero(region)[0]
        ir = ir[np.argsort(ps.id[ir], kind="stable")]
        isn = np.nonzero(sens)[0]
        isn = isn[np.argsort(ps.id[isn], kind="stable")]
        force = f[isn].copy() if f is not None else np.zeros((isn.size, dim))
        rest = region & ~sens
        unassigned = f[rest].sum(axis=0) if f is not None else np.zeros(dim)
        T = ps.fields.get("T")
        return SensorReading(
            t=float(t), x=ps.x[isn].copy(), force=force, ids=ps.id[isn].copy(),
            x_region=ps.x[ir].copy(), T_region=None if T is None else T[ir].copy(),
            vol_region=ps.vol[ir].copy(), ids_region=ps.id[ir].copy(),
            unassigned_force=np.asarray(unassigned, float))


@dataclass
class CoupledRegion:
    """The SPH solid region of a ``[coupling]`` section: its blocks, their shapes and
    bounding box, and the substrate's stress-free temperature."""

    names: list[str]  #: block names (``coupling.blocks``, default: see below)
    blocks: list  #: the scene's block records, in that order
    shapes: list  #: their :class:`sphfem.geometry.Shape`
    lo: np.ndarray  #: (dim,) lower corner of the shapes' bounding box [m]
    hi: np.ndarray  #: (dim,) upper corner [m]
    T0: float  #: ``coupling.T0``, default the first block's initial temperature [K]


def coupled_region(scene, cfg) -> CoupledRegion:
    """The region of ``cfg`` (``scene.coupling``): the blocks it names, by default every
    wall or solid block of its material (:func:`coupling.scene_section.region_block_names`);
    both substrate backends and the driver's sensors take their box and T0 from here."""
    from coupling.scene_section import region_block_names
    from sphfem.geometry import Shape

    names = region_block_names(cfg, scene.blocks)
    blocks = [scene.blocks[scene.block_index(n)] for n in names]
    shapes = [Shape.from_block(b, scene.dim) for b in blocks]
    lo = np.min([s.bounds()[0] for s in shapes], axis=0).astype(float)
    hi = np.max([s.bounds()[1] for s in shapes], axis=0).astype(float)
    T0 = float(cfg.T0 if cfg.T0 is not None else blocks[0].temperature)
    return CoupledRegion(names, blocks, shapes, lo, hi, T0)
