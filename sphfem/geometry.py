"""Particle blocks: shapes, lattice and Poisson-disk placement, and :func:`build_particles`.

Shapes (``box``, ``sphere``, ``cylinder``) in 1D, 2D and 3D:

* 1D: a box and a sphere are segments (``[c - r, c + r]``); a cylinder is the segment of
  ``length`` along x centred at ``center`` (its radius is not used).
* 2D: a sphere is a disc; a cylinder is its axial section, the rectangle ``length`` along
  ``axis`` by ``2 radius`` across, centred at ``center``.
* 3D: a cylinder is circular, axis along ``axis``, centred (mid-length) at ``center``.

Placement:

* :func:`lattice_points` -- Cartesian lattice.  Cell-centred by default: a box ``[0, 1]``
  with ``dx = 0.1`` gets 10 particles per axis at 0.05, 0.15, ..., 0.95; the spacing of a
  box (and of a cylinder along its axis) is adjusted per axis to ``L / round(L / dx)`` so
  the box is tiled exactly by particle cells.  ``include_boundary=True`` gives the
  node-aligned lattice ``round(L / dx) + 1`` points per axis from ``lo`` to ``hi``
  inclusive (11 at 0, 0.1, ..., 1.0), as the Laplacian patch test needs.  Spheres and
  discs take the points of a lattice centred on ``center`` (cell-centred: ``c + (i + 1/2)
  dx``; node-aligned: ``c + i dx``) that lie inside the shape.
* :func:`poisson_points` -- blue noise for free-surface bodies: a maximal Poisson-disk
  sample of the bounding box (Bridson's algorithm, drawing exactly the points of
  ``scipy.stats.qmc.PoissonDisk``, :func:`_poisson_box`), clipped to the shape.  The
  disk radius starts from a calibrated fraction of ``dx`` and is corrected until the count
  is within a few per cent of ``volume / dx^dim``; a few repulsion sweeps then even out
  the spacing.  Deterministic for a given seed.  (~0.25 ms per point: ~1 s for the
  4,000 points of the 3D droplet's bounding box, which took ~15-50 s with scipy's sampler.)
* :func:`shell_points` -- a sphere (disc in 2D) as concentric layers, so that its surface
  is smooth rather than a lattice staircase (a staircase reads to a surface-tension model
  as curvature of order 1 / dx at every step; docs/validation/droplet_impact, session 27).
  2D: circles mirror-symmetric about the vertical axis with no point on it (their half
  x > 0 is the meridian section :func:`~sphfem.fluid.axisymmetric_surface_tension.
  half_disc_arcs` of an axisymmetric ball, areas from :func:`shell_areas`); 3D: the
  Fibonacci shells of :func:`~sphfem.fluid.setup.droplet_packing`.

:func:`build_particles` fills every block of a scene: mass ``rho0 * V / n`` (so a block
carries its exact mass), ``rho = rho0``, ``vol = m / rho``, ``kind``, ``material`` (the
position of the material in ``scene.materials``), and the fields ``v`` (n, dim) and ``T``
(n,) from the block's velocity and temperature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from sphfem.errors import SceneError
from sphfem.particles import KIND_NAMES, ParticleSet

AXES = "xyz"

#: disk radius / dx for which a maximal Poisson-disk sample has mean density 1/dx^dim
POISSON_RADIUS_FACTOR = {1: 0.687, 2: 0.778, 3: 0.835}
#: bump when :func:`poisson_points` changes the points it makes for the same parameters
#: (the cached samples carry it in their key)
POISSON_VERSION = 1


@dataclass(frozen=True)
class Shape:
    """A block geometry.  Build with :meth:`box`, :meth:`sphere`, :meth:`cylinder`."""

    kind: str
    dim: int
    lo: tuple = ()
    hi: tuple = ()
    center: tuple = ()
    radius: float = 0.0
    length: float = 0.0
    axis: int = 0

    @classmethod
    def box(cls, lo, hi) -> Shape:
        lo, hi = _vec(lo), _vec(hi)
        if len(lo) != len(hi) or not 1 <= len(lo) <= 3:
            raise ValueError("box lo and hi must be vectors of the same length 1, 2 or 3")
        if any(h <= l for l, h in zip(lo, hi, strict=True)):
            raise ValueError("box hi must exceed lo on every axis")
        return cls("box", len(lo), lo=lo, hi=hi)

    @classmethod
    def sphere(cls, center, radius) -> Shape:
        c = _vec(center)
        if not radius > 0:
            raise ValueError("sphere radius must be positive")
        return cls("sphere", len(c), center=c, radius=float(radius))

    @classmethod
    def cylinder(cls, center, radius, length, axis="z") -> Shape:
        c = _vec(center)
        a = AXES.index(axis) if isinstance(axis, str) else int(axis)
        if a >= len(c):
            raise ValueError(f"cylinder axis {axis!r} does not exist in {len(c)}D")
        if not (radius > 0 and length > 0):
            raise ValueError("cylinder radius and length must be positive")
        return cls("cylinder", len(c), center=c, radius=float(radius), length=float(length),
                   axis=a)

    @classmethod
    def from_block(cls, block, dim: int | None = None) -> Shape:
        """The shape of a scene block record (``scene.blocks[i]``)."""
        if block.shape == "box":
            s = cls.box(block.lo, block.hi)
        elif block.shape == "sphere":
            s = cls.sphere(block.center, block.radius)
        elif block.shape == "cylinder":
            s = cls.cylinder(block.center, block.radius, block.length, block.axis)
        else:
            raise ValueError(f"unknown shape {block.shape!r}")
        if dim is not None and s.dim != dim:
            raise ValueError(f"block geometry is {s.dim}D in a {dim}D scene")
        return s

    def as_box(self) -> Shape | None:
        """The equivalent box of a segment (1D) or a 2D cylinder, else None."""
        if self.kind == "box":
            return self
        c = np.array(self.center)
        if self.kind == "sphere" and self.dim == 1:
            return Shape.box(c - self.radius, c + self.radius)
        if self.kind == "cylinder" and self.dim <= 2:
            half = np.full(self.dim, self.radius)
            half[self.axis] = 0.5 * self.length
            return Shape.box(c - half, c + half)
        return None

    def volume(self) -> float:
        """Exact measure: length (1D), area (2D) or volume (3D) [m^dim]."""
        b = self.as_box()
        if b is not None:
            return float(np.prod(np.subtract(b.hi, b.lo)))
        r = self.radius
        if self.kind == "sphere":
            return math.pi * r * r if self.dim == 2 else 4.0 / 3.0 * math.pi * r**3
        return math.pi * r * r * self.length  # 3D cylinder

    def bounds(self) -> tuple[tuple, tuple]:
        """Axis-aligned bounding box (lo, hi)."""
        b = self.as_box()
        if b is not None:
            return b.lo, b.hi
        c = np.array(self.center)
        half = np.full(self.dim, self.radius)
        if self.kind == "cylinder":
            half[self.axis] = 0.5 * self.length
        return _vec(c - half), _vec(c + half)

    def contains(self, x, tol: float = 0.0) -> np.ndarray:
        """Mask of the points ``x`` (n, dim) inside the shape (grown by ``tol``)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, self.dim)
        b = self.as_box()
        if b is not None:
            return np.all((x >= np.array(b.lo) - tol) & (x <= np.array(b.hi) + tol), axis=1)
        d = x - np.array(self.center)
        if self.kind == "sphere":
            return np.einsum("ij,ij->i", d, d) <= (self.radius + tol) ** 2
        across = np.delete(d, self.axis, axis=1)
        return (np.einsum("ij,ij->i", across, across) <= (self.radius + tol) ** 2) & (
            np.abs(d[:, self.axis]) <= 0.5 * self.length + tol
        )


def _vec(v) -> tuple:
    return tuple(float(x) for x in np.atleast_1d(np.asarray(v, dtype=np.float64)))


def _check(shape: Shape, dx: float, dim: int | None) -> None:
    if dim is not None and dim != shape.dim:
        raise ValueError(f"shape is {shape.dim}D, asked for {dim}D points")
    if not (dx > 0 and math.isfinite(dx)):
        raise ValueError(f"spacing dx must be positive, got {dx}")


# --------------------------------------------------------------------------------------
# lattice


def _axis_points(lo: float, hi: float, dx: float, include_boundary: bool) -> np.ndarray:
    n = int(round((hi - lo) / dx))
    if n == 0:  # thinner than half a spacing: no particles (build_particles reports it)
        return np.empty(0)
    if include_boundary:
        return np.linspace(lo, hi, n + 1)
    h = (hi - lo) / n
    return lo + (np.arange(n) + 0.5) * h


def _grid(axes: list[np.ndarray]) -> np.ndarray:
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.reshape(-1) for m in mesh], axis=1)


def _ball_offsets(r: float, dx: float, dim: int, include_boundary: bool) -> np.ndarray:
    k = int(math.ceil(r / dx)) + 1
    if include_boundary:
        line = np.arange(-k, k + 1) * dx
        keep_r2 = (r * (1.0 + 1e-12)) ** 2
    else:
        line = (np.arange(-k, k) + 0.5) * dx
        keep_r2 = r * r
    p = _grid([line] * dim)
    p = p[np.einsum("ij,ij->i", p, p) <= keep_r2] if include_boundary else p[
        np.einsum("ij,ij->i", p, p) < keep_r2]
    return p


def lattice_points(shape: Shape, dx: float, dim: int | None = None, *,
                   include_boundary: bool = False) -> np.ndarray:
    """Cartesian lattice positions (n, dim) filling ``shape`` (see the module docstring)."""
    _check(shape, dx, dim)
    b = shape.as_box()
    if b is not None:
        axes = [_axis_points(lo, hi, dx, include_boundary)
                for lo, hi in zip(b.lo, b.hi, strict=True)]
        return np.ascontiguousarray(_grid(axes))
    c = np.array(shape.center)
    if shape.kind == "sphere":
        return np.ascontiguousarray(c + _ball_offsets(shape.radius, dx, shape.dim,
                                                      include_boundary))
    # 3D cylinder: disc lattice across times a line along the axis
    disc = _ball_offsets(shape.radius, dx, 2, include_boundary)
    half = 0.5 * shape.length
    line = _axis_points(-half, half, dx, include_boundary)
    x = np.empty((disc.shape[0] * line.shape[0], 3))
    across = [a for a in range(3) if a != shape.axis]
    x[:, shape.axis] = np.repeat(line, disc.shape[0])
    x[:, across] = np.tile(disc, (line.shape[0], 1))
    return np.ascontiguousarray(x + c)


# --------------------------------------------------------------------------------------
# Poisson disk (blue noise)


def _poisson_box(lo, hi, radius: float, rng, ncandidates: int = 30) -> np.ndarray:
    """A maximal Poisson-disk sample of the box ``[lo, hi]`` with disk radius ``radius``:
    Bridson's algorithm (SIGGRAPH sketches 2007) exactly as ``scipy.stats.qmc.PoissonDisk(d,
    radius=radius, rng=rng, l_bounds=lo, u_bounds=hi).fill_space()`` (scipy 1.17) draws
    and tests it, with the same random stream, so the points are bit-identical, but with
    each centre's ``ncandidates`` candidates tested at once against the grid (one numpy
    gather instead of one Python call per candidate; ~10-20x faster).

    scipy's procedure: a generator spawned from ``rng`` (``rng.spawn(1)``); a grid of cells
    of side ``radius / sqrt(d)`` holding at most one sample each (stored as float32); a
    first sample uniform in the box; then, until the pool of active samples is empty, a
    centre taken out of the pool at random and ``ncandidates`` candidates drawn uniformly in
    the ball of radius ``2 radius`` around it, each accepted (and added to the pool) when it
    lies in the box, its cell is empty and no sample of the 5^d cells around it is closer
    than ``radius``.  Candidates are tested in order, so one is also tested against those of
    its own batch accepted before it.
    """
    from scipy.special import gammainc

    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    d = lo.shape[0]
    rng = rng.spawn(1)[0]
    r2 = radius**2
    cell = radius / np.sqrt(d)
    pad = 2  # the 5^d window of a cell never leaves the padded grid
    shape = np.ceil((hi - lo) / cell).astype(int) + 2 * pad + 1
    stride = np.r_[np.cumprod(shape[::-1])[:-1][::-1], 1]  # C order
    grid = np.zeros((int(np.prod(shape)), d), dtype=np.float32)  # cell -> its sample
    full = np.zeros(grid.shape[0], dtype=bool)  # cell holds a sample
    win = np.stack(np.meshgrid(*([np.arange(-pad, pad + 1)] * d), indexing="ij"),
                   axis=-1).reshape(-1, d) @ stride

    def cells(x):
        return (((x - lo) / cell).astype(int) + pad) @ stride

    first = rng.uniform(lo, hi)
    out = [first]
    pool = [first]
    grid[cells(first)] = first
    full[cells(first)] = True
    ball, a, p = radius * 2, d / 2, 1 / d
    for_all = np.logical_and.reduce
    while pool:
        centre = pool.pop(int(rng.integers(len(pool))))
        x = rng.standard_normal(size=(ncandidates, d))
        ssq = np.sum(x**2, axis=1)
        cand = centre + x * (ball * gammainc(a, ssq / 2) ** p / np.sqrt(ssq))[:, None]
        cand = cand[for_all((cand <= hi) & (cand >= lo), axis=1)]
        if cand.shape[0] == 0:
            continue
        lin = cells(cand)
        ci, wj = np.nonzero(full[lin[:, None] + win])  # candidate, filled cell of its window
        free = ~full[lin]
        if ci.shape[0]:
            d2 = np.sum(np.square(cand[ci] - grid[lin[ci] + win[wj]]), axis=1)
            free[ci[d2 < r2]] = False
        taken = []  # (cell, float32 value as floats) of this batch's accepted candidates
        for c, i in zip(cand[free], lin[free].tolist(), strict=True):
            if taken and any(i == j or (_dist2(c, v) < r2 and _within(i, j, stride, pad))
                             for j, v in taken):
                continue
            v = c.astype(np.float32)
            grid[i] = v
            full[i] = True
            taken.append((i, v.tolist()))
            out.append(c)
            pool.append(c)
    return np.array(out)


def _dist2(c: np.ndarray, v: list) -> float:
    """Squared distance of ``c`` and ``v`` summed in axis order (as numpy sums a short
    axis, so the value is bit-identical to ``np.sum(np.square(c - v))``)."""
    s = 0.0
    for a, b in zip(c.tolist(), v, strict=True):
        s += (a - b) * (a - b)
    return s


def _within(i: int, j: int, stride, pad: int) -> bool:
    """Cells ``i`` and ``j`` (linear indices, C-order ``stride``) at most ``pad`` apart on
    every axis."""
    for s in stride.tolist():
        if abs(i // s - j // s) > pad:
            return False
        i, j = i % s, j % s
    return True


def poisson_points(shape: Shape, dx: float, dim: int | None = None, seed=0, *,
                   relax: int = 3, tolerance: float = 0.03) -> np.ndarray:
    """Poisson-disk positions (n, dim) in ``shape`` with mean spacing ``dx``.

    The count matches ``volume / dx^dim`` within ``tolerance`` (or ``1/sqrt(target)`` for
    very small blocks, where the count is noisy), the minimum distance is about
    ``0.7-0.8 dx`` and ``relax`` repulsion sweeps even the spacing out.  ``seed`` is an int
    or a sequence of ints (``numpy.random.default_rng`` semantics).  Samples are cached on disk
    (:func:`sphfem.cache.cached_array`, key: every parameter and the library versions).
    """
    _check(shape, dx, dim)
    import scipy

    from sphfem.cache import cached_array

    seed_key = np.asarray(seed).tolist() if not isinstance(seed, (int, np.integer)) else int(seed)
    params = {"shape": [shape.kind, shape.dim, list(shape.lo), list(shape.hi),
                        list(shape.center), shape.radius, shape.length, shape.axis],
              "dx": dx, "seed": seed_key, "relax": relax, "tolerance": tolerance,
              "version": POISSON_VERSION, "numpy": np.__version__, "scipy": scipy.__version__}
    return cached_array("poisson", params,
                        lambda: _poisson_points(shape, dx, seed, relax, tolerance))


def _poisson_points(shape: Shape, dx: float, seed, relax: int, tolerance: float) -> np.ndarray:
    """:func:`poisson_points` without the cache."""
    d = shape.dim
    target = shape.volume() / dx**d
    lo, hi = shape.bounds()
    tol = max(tolerance, 1.0 / math.sqrt(max(target, 1.0)))
    radius = POISSON_RADIUS_FACTOR[d] * dx
    best = None
    for _ in range(4):
        rng = np.random.default_rng(seed)
        x = _poisson_box(lo, hi, radius, rng)
        x = x[shape.contains(x)]
        ratio = x.shape[0] / target
        if best is None or abs(ratio - 1.0) < abs(best[1] - 1.0):
            best = (x, ratio, radius)
        if abs(ratio - 1.0) <= tol or x.shape[0] == 0:
            break
        radius *= ratio ** (1.0 / d)
    x, _, radius = best
    if relax and x.shape[0] > 1:
        x = _relax(x, shape, dx, relax)
    return np.ascontiguousarray(x)


def _relax(x: np.ndarray, shape: Shape, dx: float, iterations: int) -> np.ndarray:
    """Repulsion sweeps between points closer than dx; moves leaving the shape are undone."""
    x = x.copy()
    for _ in range(iterations):
        pairs = cKDTree(x).query_pairs(dx, output_type="ndarray")
        if pairs.shape[0] == 0:
            break
        i, j = pairs[:, 0], pairs[:, 1]
        d = x[i] - x[j]
        r = np.sqrt(np.einsum("ij,ij->i", d, d))
        w = ((1.0 - r / dx) ** 2 / np.maximum(r, 1e-12 * dx))[:, None] * d
        disp = np.zeros_like(x)
        np.add.at(disp, i, w)
        np.add.at(disp, j, -w)
        disp *= 0.1 * dx
        step = np.sqrt(np.einsum("ij,ij->i", disp, disp))
        cap = 0.1 * dx
        disp *= np.minimum(1.0, cap / np.maximum(step, 1e-300))[:, None]
        moved = x + disp
        ok = shape.contains(moved)
        x[ok] = moved[ok]
    return x


# --------------------------------------------------------------------------------------
# scene blocks -> particles


def place_above(block, placed: dict, R: float, ctx, path: str):
    """``block`` with its ``above``/``gap`` keys resolved (the record unchanged without them).

    The block is translated along the last axis (z in 3D, y in 2D, x in 1D) so that its
    lowest point lies ``gap`` above the highest point of block ``placed[block.above]``
    (an earlier block, already placed); ``gap`` defaults to the kernel support radius
    ``R``.  A clearance below ``R`` is a :class:`SceneError` (``ctx.error``): the two blocks
    would interact at t = 0.  Particles of a cell-centred lattice lie at least dx/2 inside
    their shape, so a clearance ``>= R`` keeps every particle pair of the two blocks at
    least ``R`` apart.  The result carries the resolved ``gap``; resolving it again is a
    no-op, so ``Scene.to_dict()`` round-trips.
    """
    if block.above is None:
        if block.gap is not None:
            ctx.error(f"{path}.gap", "applies only with `above` (the name of the block the "
                                     "clearance is measured from)")
        return block
    if block.above == block.name:
        ctx.error(f"{path}.above", f"block {block.name!r} cannot be placed above itself")
    if block.above not in placed:
        known = ", ".join(repr(n) for n in placed) or "none"
        ctx.error(f"{path}.above", f"expected the name of an earlier block, got "
                                   f"{block.above!r} (earlier blocks: {known})")
    gap = R if block.gap is None else block.gap
    if gap < R * (1.0 - 1e-12):
        ctx.error(f"{path}.gap", f"clearance {gap:g} m is less than the kernel support radius "
                                 f"R = {R:g} m: particles of {block.name!r} and "
                                 f"{block.above!r} would interact at t = 0 (a load before "
                                 f"contact); use gap >= {R:g}")
    dim = len(block.center if block.shape != "box" else block.lo)
    ax = dim - 1
    top = Shape.from_block(placed[block.above], dim).bounds()[1][ax]
    low = Shape.from_block(block, dim).bounds()[0][ax]
    shift = top + gap - low

    def moved(v):
        v = list(v)
        v[ax] += shift
        return tuple(v)

    if block.shape == "box":
        return block.replace(lo=moved(block.lo), hi=moved(block.hi), gap=gap)
    return block.replace(center=moved(block.center), gap=gap)


def block_points(scene, i: int) -> np.ndarray:
    """Positions of block ``i`` of ``scene`` (its own ``dx`` or ``[sph] dx``)."""
    b = scene.blocks[i]
    dx = b.dx if b.dx is not None else scene.sph.dx
    shape = Shape.from_block(b, scene.dim)
    if b.sampling == "poisson":
        x = poisson_points(shape, dx, scene.dim, seed=[scene.seed, i])
    elif b.sampling == "shells":
        x = shell_points(shape, dx, scene.dim)
    else:
        x = lattice_points(shape, dx, scene.dim)
    if b.jitter:
        rng = np.random.default_rng([scene.seed, i, 1])
        x = x + rng.uniform(-b.jitter * dx, b.jitter * dx, size=x.shape)
    return x


def shell_points(shape: Shape, dx: float, dim: int | None = None) -> np.ndarray:
    """A sphere (2D: disc) ``shape`` filled with concentric layers of spacing dx' = radius /
    round(radius / dx), layer k at rho_k = (k + 1/2) dx' (the outer layer dx'/2 inside the
    surface).  2D: circle k holds 2 m_k points, m_k = round(pi rho_k / dx'), at the angles
    (j + 1/2) pi / m_k from the vertical (+y) axis, so the set is mirror-symmetric about the
    vertical axis through the centre and no point lies on it; 3D:
    :func:`sphfem.fluid.setup.droplet_packing` (round(4 pi rho_k^2 / dx'^2) points per shell
    on a Fibonacci spiral)."""
    _check(shape, dx, dim)
    if shape.kind != "sphere" or shape.dim not in (2, 3):
        raise ValueError(f"shell_points: a sphere in 2D or 3D, got a {shape.kind} in "
                         f"{shape.dim}D")
    c = np.array(shape.center)
    if shape.dim == 3:
        from sphfem.fluid.setup import droplet_packing

        return np.ascontiguousarray(c + droplet_packing(3, shape.radius, dx))
    nr = max(1, int(round(shape.radius / dx)))
    h = shape.radius / nr
    pts = []
    for k in range(nr):
        rk = (k + 0.5) * h
        m = max(1, int(round(math.pi * rk / h)))
        th = (np.arange(2 * m) + 0.5) * math.pi / m
        pts.append(np.column_stack([rk * np.sin(th), rk * np.cos(th)]))
    return np.ascontiguousarray(c + np.concatenate(pts))


def shell_areas(x: np.ndarray, shape: Shape, dx: float) -> np.ndarray:
    """Meridian areas [m^2] of 2D :func:`shell_points` ``x`` of ``shape``: pi rho_k dx' /
    m_k for a point of circle k (its circle's annulus shared evenly by its 2 m_k points;
    they sum to the disc's area pi radius^2)."""
    nr = max(1, int(round(shape.radius / dx)))
    h = shape.radius / nr
    d = np.asarray(x, float) - np.array(shape.center)
    k = np.clip(np.rint(np.hypot(d[:, 0], d[:, 1]) / h - 0.5), 0, nr - 1)
    rk = (k + 0.5) * h
    m = np.maximum(1.0, np.rint(math.pi * rk / h))
    return math.pi * rk * h / m


def build_particles(scene) -> ParticleSet:
    """All blocks of ``scene`` as one :class:`ParticleSet` (block order, then lattice order).

    Raises :class:`SceneError` naming the block if a block gets no particles or if particles
    of two blocks are closer than half the (smaller) spacing.
    """
    dim = scene.dim
    pts, spacing, boxes = [], [], []
    for i, b in enumerate(scene.blocks):
        x = block_points(scene, i)
        dx = b.dx if b.dx is not None else scene.sph.dx
        if x.shape[0] == 0:
            raise SceneError(scene.source, f"blocks[{i}]",
                             f"block {b.name!r} gets no particles: it is smaller than its "
                             f"spacing dx = {dx:g} m")
        pts.append(x)
        spacing.append(dx)
        boxes.append((x.min(axis=0), x.max(axis=0)))
    _check_overlaps(scene, pts, spacing, boxes)

    out = None
    for i, b in enumerate(scene.blocks):
        x = pts[i]
        n = x.shape[0]
        rho0 = scene.materials[b.material].rho0
        m = rho0 * Shape.from_block(b, dim).volume() / n
        ps = ParticleSet.from_arrays(x, m=m, rho=rho0, kind=KIND_NAMES[b.kind],
                                     material=scene.material_index(b.material))
        v = ps.add_field("v", dim)
        v[:] = np.asarray(b.velocity, dtype=np.float64)
        ps.add_field("T", 1, fill=float(b.temperature))
        if out is None:
            out = ps
        else:
            out.append(ps)
    return out


def _check_overlaps(scene, pts, spacing, boxes) -> None:
    """Raise :class:`SceneError` if two blocks overlap, found as particles of one closer than
    dx/2 (half the smaller spacing) to particles of the other or deeper than dx/2 inside the
    other's shape (this catches lattices that happen to be staggered by exactly dx/2).  A
    block whose particles all lie within the other's shape is reported as lying inside it
    (key: the inner block), any other overlap with the later block as the key."""

    def deep_inside(shape, x, depth):  # points more than ``depth`` inside ``shape``
        if shape.as_box() is None and shape.radius <= depth:
            return np.zeros(len(x), bool)
        return shape.contains(x, tol=-depth)

    shapes = [Shape.from_block(b, scene.dim) for b in scene.blocks]
    trees = {}
    for j in range(len(pts)):
        for i in range(j):
            tol = 0.5 * min(spacing[i], spacing[j])
            (lo_i, hi_i), (lo_j, hi_j) = boxes[i], boxes[j]
            (slo_i, shi_i), (slo_j, shi_j) = shapes[i].bounds(), shapes[j].bounds()
            if ((np.any(lo_j > hi_i + tol) or np.any(lo_i > hi_j + tol)) and
                    (np.any(np.greater_equal(slo_j, shi_i))
                     or np.any(np.greater_equal(slo_i, shi_j)))):
                continue
            if i not in trees:
                trees[i] = cKDTree(pts[i])
            dist, _ = trees[i].query(pts[j], k=1, distance_upper_bound=tol)
            close = int(np.count_nonzero((dist < tol) | deep_inside(shapes[i], pts[j], tol))
                        + np.count_nonzero(deep_inside(shapes[j], pts[i], tol)))
            if close:
                for inner, outer in ((j, i), (i, j)):
                    b_in, b_out = scene.blocks[inner], scene.blocks[outer]
                    if shapes[outer].contains(pts[inner], tol=1e-9 * tol).all():
                        n = pts[inner].shape[0]
                        raise SceneError(
                            scene.source, f"blocks[{inner}]",
                            f"block {b_in.name!r} lies inside block {b_out.name!r} "
                            f"(blocks[{outer}]): all {n} of its particles are within it; "
                            f"move it out of {b_out.name!r}")
                bi, bj = scene.blocks[i], scene.blocks[j]
                raise SceneError(
                    scene.source, f"blocks[{j}]",
                    f"block {bj.name!r} overlaps block {bi.name!r} (blocks[{i}]): {close} "
                    f"particle(s) closer than dx/2 = {tol:g} m to the other block or deeper "
                    f"than that inside it; move or shrink one of them")
