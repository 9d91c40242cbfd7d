"""Building blocks for fluid set-ups: cell-centred lattices, wall layers, hydrostatic state."""

from __future__ import annotations

import numpy as np

from sphfem.fluid.eos import density
from sphfem.particles import FLUID, WALL, ParticleSet


def lattice(lo, hi, dx: float) -> np.ndarray:
    """Cell-centred lattice filling the box [lo, hi] with spacing ~dx (exact fit per axis).

    Returns positions (n, dim); the spacing on each axis is (hi - lo) / round((hi - lo)/dx).
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    axes = []
    for a, b in zip(lo, hi, strict=True):
        m = max(1, int(round((b - a) / dx)))
        s = (b - a) / m
        axes.append(a + (np.arange(m) + 0.5) * s)
    g = np.meshgrid(*axes, indexing="ij")
    return np.ascontiguousarray(np.stack([c.ravel() for c in g], axis=1))


def box_walls(lo, hi, dx: float, layers: int, open_axes=(), open_top: bool = True) -> np.ndarray:
    """Wall-particle layers around the box [lo, hi] (a tank), cell-centred on the same lattice.

    ``layers`` layers outside every face, except faces of axes in ``open_axes`` (periodic)
    and, if ``open_top``, the upper face of the last axis.
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    dim = lo.size
    ext_lo = lo.copy()
    ext_hi = hi.copy()
    for k in range(dim):
        if k in open_axes:
            continue
        ext_lo[k] -= layers * dx
        if not (open_top and k == dim - 1):
            ext_hi[k] += layers * dx
    x = lattice(ext_lo, ext_hi, dx)
    inside = np.ones(x.shape[0], dtype=bool)
    for k in range(dim):
        inside &= (x[:, k] > lo[k]) & (x[:, k] < hi[k])
    return np.ascontiguousarray(x[~inside])


def make_particles(x_fluid, x_wall, dx: float, rho0: float, rho_fluid=None) -> ParticleSet:
    """Fluid (mass rho0 dx^d) and wall (volume dx^d, density rho0) particles in one set."""
    x_fluid = np.atleast_2d(np.asarray(x_fluid, float))
    dim = x_fluid.shape[1]
    x_wall = np.zeros((0, dim)) if x_wall is None else np.atleast_2d(np.asarray(x_wall, float))
    nf, nw = x_fluid.shape[0], x_wall.shape[0]
    vol = dx**dim
    rho = np.full(nf + nw, rho0)
    if rho_fluid is not None:
        rho[:nf] = rho_fluid
    kind = np.concatenate([np.full(nf, FLUID, np.int8), np.full(nw, WALL, np.int8)])
    m = np.full(nf + nw, rho0 * vol)
    ps = ParticleSet.from_arrays(np.concatenate([x_fluid, x_wall]), m=m, rho=rho, kind=kind)
    ps.fields["vol"][:] = vol
    return ps


def hydrostatic_density(depth, rho0: float, c0: float, g: float, gamma: float = 7.0):
    """Density of the Tait fluid at rest at ``depth`` below a free surface (p = rho0 g depth).

    Uses p = rho0 g depth (the weakly compressible fluid's exact hydrostatic state differs by
    O(Mach^2)); particle masses stay rho0 dx^d, so the column is slightly compressed.
    """
    return density(rho0 * g * np.asarray(depth, float), rho0, c0, gamma)


def droplet_packing(dim: int, radius: float, dx: float) -> np.ndarray:
    """Particles filling a disc (2D) or ball (3D) of ``radius`` centred at the origin, in
    concentric rings / shells of spacing ``radius / round(radius / dx)`` (the outer layer at
    radius - dx/2), so that the surface is smooth rather than a lattice staircase.

    2D: ring k at r_k = (k + 1/2) dx with round(2 pi r_k / dx) particles (alternate rings
    rotated by half a spacing); 3D: shell k at r_k with round(4 pi r_k^2 / dx^2) particles
    on a Fibonacci spiral (rotated by k radians from shell to shell).
    """
    nr = max(1, int(round(radius / dx)))
    dx = radius / nr
    pts = []
    golden = np.pi * (3.0 - np.sqrt(5.0))
    for k in range(nr):
        r = (k + 0.5) * dx
        if dim == 2:
            m = max(1, int(round(2 * np.pi * r / dx)))
            th = (np.arange(m) + 0.5 * (k % 2)) * 2 * np.pi / m
            pts.append(r * np.stack([np.cos(th), np.sin(th)], 1))
        elif dim == 3:
            m = max(1, int(round(4 * np.pi * r * r / dx**2)))
            s = np.arange(m) + 0.5
            z = 1.0 - 2.0 * s / m
            rho = np.sqrt(1.0 - z * z)
            phi = golden * s + k
            pts.append(r * np.stack([rho * np.cos(phi), rho * np.sin(phi), z], 1))
        else:
            raise ValueError(f"droplet_packing: dim must be 2 or 3, got {dim}")
    return np.ascontiguousarray(np.concatenate(pts))
