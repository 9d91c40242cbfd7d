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
