"""Axisymmetric SPH in the (r, z) half-plane: ring masses and mirror particles at the axis.

A particle at (r, z), r > 0, stands for a ring of radius r around the z axis.  Its *ring
mass* M = 2 pi r rho A is constant (A: the particle's area in the meridian plane, dx^2 on a
lattice), so mass is conserved exactly while the particle moves; its planar area changes as

    A_i = M_i / (2 pi r_i rho_i)                                                      (1)

(Petschek & Libersky 1993, J. Comput. Phys. 109, 76; Garcia-Senz & Relano-Pastor 2012,
MNRAS 424, 1585 [GSR12], sec. 2).  Planar 2D kernels W(|x_i - x_j|) in (r, z) are used;
the sums over neighbours then approximate the r-z derivatives, and the terms of the
cylindrical operators that a planar sum misses (hoop terms in 1/r) are added explicitly by
the fluid and heat modules.

The axis r = 0 is handled with *mirror particles* (the reflective particles of GSR12, sec.
2.2): every particle with r < R (R: support radius) gets an image at (-r, z) that carries its
fields with the parity of the axisymmetric field: scalars (rho, p, T) and v_z even, v_r odd.
With the mirrors every kernel sum near the axis sees a full support of a smooth (even/odd)
extension, so the planar sums keep their interior accuracy up to the axis.  Coordinates:
``x[:, 0] = r >= 0``, ``x[:, 1] = z``.
"""

from __future__ import annotations

import math

import numpy as np

#: kind codes of the mirror particles inside an augmented particle set (fluid rings' and wall
#: rings' images across the axis; not ParticleSet kinds)
MIRROR_FLUID, MIRROR_WALL = 4, 5


def ring_mass(r, rho, area) -> np.ndarray:
    """M = 2 pi r rho A [kg] of rings at radius ``r`` [m] with density ``rho`` and meridian
    area ``area`` [m^2] (eq. 1)."""
    return 2.0 * math.pi * np.asarray(r, float) * np.asarray(rho, float) * np.asarray(area,
                                                                                     float)


def planar_area(M, r, rho) -> np.ndarray:
    """A = M / (2 pi r rho) [m^2] (eq. 1)."""
    return np.asarray(M, float) / (2.0 * math.pi * np.asarray(r, float) * np.asarray(rho, float))


def axis_mirrors(x, R: float) -> tuple[np.ndarray, np.ndarray]:
    """Images (-r, z) of the particles with r < R: ``(positions, source indices)``.

    Particles exactly on the axis (r = 0) get no image (it would coincide with them).
    """
    x = np.asarray(x, float)
    if x.ndim != 2 or x.shape[1] != 2:
        raise ValueError("axisymmetric positions must have shape (n, 2): columns r and z")
    if np.any(x[:, 0] < 0):
        raise ValueError("axisymmetric positions need r >= 0")
    src = np.flatnonzero((x[:, 0] < R) & (x[:, 0] > 0.0))
    xm = x[src].copy()
    xm[:, 0] *= -1.0
    return xm, src


def half_disc_lattice(radius: float, dx: float, center_z: float = 0.0) -> np.ndarray:
    """Lattice points (r, z) = ((i + 1/2) dx, center_z + (k + 1/2) dx) inside the meridian
    half-disc of a sphere of ``radius`` (r >= 0); the r-lattice is offset by dx/2 so no
    particle sits on the axis."""
    n = int(math.ceil(radius / dx)) + 1
    r = (np.arange(n) + 0.5) * dx
    z = (np.arange(-n, n) + 0.5) * dx
    rr, zz = np.meshgrid(r, z, indexing="ij")
    keep = rr**2 + zz**2 <= radius**2
    return np.column_stack([rr[keep], zz[keep] + center_z])
