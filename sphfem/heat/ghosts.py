"""Ghost particles for thermal boundary conditions (Park 2019, sec. 2.3.3, algorithm 2.5).

Boundary surfaces are axis-aligned planes (:class:`Face`), e.g. the six faces of a box
(:func:`box_faces`).  Ghosts sit on the particles' lattice *outside* a face, along its
outward normal, and only where they are needed:

1. *place*: around every real particle whose number density  n_i = sum_j V_j W_ij
   (self included) is below ``eta_place`` (default 0.85), every empty lattice point within
   the support radius R that lies beyond at least one face becomes a candidate
   (points beyond a ``free`` face get none: a plain free surface has no ghosts);
2. *trim*: a candidate whose number density, counted over real particles and candidates,
   exceeds ``eta_trim`` (default 1.3) penetrates the body and is removed.

Algorithm 2.5 as printed removes ghosts whose density is *below* eta_trim, which would
delete every well-placed ghost (a ghost continuing a uniform lattice has n ~ 1); the text
("ghost particles that penetrate the physical region are trimmed") needs *above*, which is
what is implemented.

Boundary conditions (sec. 2.3.3.2):

* ``dirichlet`` -- the ghost holds the wall temperature T_w (``hold``, the thesis), or is
  the antisymmetric image T_w - r (T_s - T_w) of its mirror source s, r = d_g / d_s the
  ratio of their distances to the wall (``antisymmetric``: exact for T linear across the
  wall, second order; r = 1 on a lattice, capped at ``R_MAX``);
* ``insulated`` -- the ghost copies the temperature of a real particle: the one nearest the
  ghost's mirror image across the face(s) (``mirror``: a symmetric extension, zero normal
  gradient to second order, and on a lattice exactly energy conserving), or the real
  particle nearest the ghost itself (``nearest``, the thesis' wording, first order);
* ``free`` -- no ghosts; with the Cleary form the truncated support exchanges no heat
  through the surface (zero flux), with the corrected form the one-sided operator applies.

A ghost beyond several faces (a corner) takes a Dirichlet face if any (the deepest one),
otherwise it is insulated and mirrored across all of them.

Periodic axes (``period[a] > 0``, the neighbour list's convention): the number densities of
steps 1 and 2 use the minimum image, so a body that fills the period has no low-density
particles at its periodic ends; candidates are wrapped into the periodic cell
``[lo, lo + period)`` before the face tests, so a lattice point beyond a periodic end lands
on a real particle (and is dropped) instead of becoming a ghost that the periodic search
lays onto the particles of the opposite end.  Face depths and mirror distances along a
periodic axis use the minimum image, so a block shorter than the period still gets its
ghosts in the gap.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from sphfem import kernels
from sphfem.neighbors import build_neighbor_list
from sphfem.operators import interpolate

BCS = ("dirichlet", "insulated", "free")
#: ghost type codes
DIRICHLET, INSULATED = 1, 2
DIRICHLET_MODES = ("hold", "antisymmetric")
NEUMANN_SOURCES = ("mirror", "nearest")
_AXES = "xyz"
#: largest extrapolation ratio d_ghost / d_source of antisymmetric Dirichlet ghosts
R_MAX = 3.0


@dataclass
class Face:
    """Boundary plane ``x[axis] = position`` with outward normal ``side`` (-1 or +1) e_axis.

    ``lo``/``hi`` bound the face laterally (on all axes; only the others matter), ``None``
    for unbounded.  ``temperature`` [K] is used by Dirichlet faces.
    """

    axis: int
    side: int
    position: float
    bc: str = "insulated"
    temperature: float = float("nan")
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None

    def __post_init__(self):
        if self.bc not in BCS:
            raise ValueError(f"face bc must be one of {BCS}, got {self.bc!r}")
        if self.side not in (-1, 1):
            raise ValueError("face side must be -1 (low) or +1 (high)")
        if self.bc == "dirichlet" and not np.isfinite(self.temperature):
            raise ValueError("a dirichlet face needs a finite temperature")


def box_faces(lo, hi, bcs: dict) -> list[Face]:
    """The 2*dim faces of the box [lo, hi]; ``bcs`` maps "xmin", "xmax", "ymin", ... to
    ``"insulated"``, ``"free"`` or ``("dirichlet", T)``; unnamed faces are insulated."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    known = {f"{_AXES[a]}{s}" for a in range(lo.size) for s in ("min", "max")}
    unknown = set(bcs) - known
    if unknown:
        raise ValueError(f"unknown face names {sorted(unknown)}; expected {sorted(known)}")
    faces = []
    for a in range(lo.size):
        for side, name, pos in ((-1, "min", lo[a]), (1, "max", hi[a])):
            spec = bcs.get(f"{_AXES[a]}{name}", "insulated")
            if isinstance(spec, tuple | list):
                bc, temp = spec[0], float(spec[1])
            else:
                bc, temp = spec, float("nan")
            faces.append(Face(a, side, float(pos), bc, temp, lo.copy(), hi.copy()))
    return faces


@dataclass
class Ghosts:
    """Ghost particles: positions, type (:data:`DIRICHLET` / :data:`INSULATED`), source
    real particle (index into the real set), wall temperature (Dirichlet) and face index."""

    x: np.ndarray
    type: np.ndarray
    source: np.ndarray
    t_wall: np.ndarray
    face: np.ndarray
    ratio: np.ndarray | None = None
    stats: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.ratio is None:
            self.ratio = np.ones(self.x.shape[0])

    @property
    def n(self) -> int:
        return self.x.shape[0]


def _min_image(d: np.ndarray, L: float) -> np.ndarray:
    """Separation ``d`` wrapped into [-L/2, L/2) when ``L > 0`` (periodic axis), else ``d``."""
    return d - L * np.floor(d / L + 0.5) if L > 0.0 else d


def _wrap(p: np.ndarray, lo: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Positions wrapped into ``[lo, lo + period)`` on the periodic axes (a copy)."""
    p = np.array(p, dtype=np.float64)
    for a in np.flatnonzero(period > 0):
        y = np.mod(p[:, a] - lo[a], period[a])
        p[:, a] = lo[a] + np.where(y >= period[a], 0.0, y)
    return p


def _shifted(p: np.ndarray, lo: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Coordinates for a toroidal k-d tree: in [0, period) on the periodic axes."""
    p = np.array(p, dtype=np.float64)
    for a in np.flatnonzero(period > 0):
        y = np.mod(p[:, a] - lo[a], period[a])
        p[:, a] = np.where(y >= period[a], 0.0, y)
    return p


def _tree(x: np.ndarray, lo: np.ndarray, period: np.ndarray) -> cKDTree:
    """k-d tree of ``x``, toroidal on the periodic axes (query it with :func:`_query`)."""
    if not np.any(period > 0):
        return cKDTree(x)
    return cKDTree(_shifted(x, lo, period), boxsize=np.where(period > 0, period, 0.0))


def _query(tree: cKDTree, p: np.ndarray, lo: np.ndarray, period: np.ndarray):
    """Distance to and index of the point of ``tree`` (from :func:`_tree`) nearest each
    row of ``p`` (minimum image on the periodic axes)."""
    return tree.query(_shifted(p, lo, period) if np.any(period > 0) else p)


def _beyond(p: np.ndarray, faces: list[Face], R: float, period=None) -> np.ndarray:
    """(n, nfaces) bool: point beyond face f (outside its plane by at most R, within its
    lateral extent enlarged by R) and penetration depth (n, nfaces).

    The depth limit keeps a face to its own neighbourhood: a point beyond one block's face
    is not also "beyond" the parallel face of another block far away (which would mirror
    its source into that block).  On a periodic axis the depth is the minimum image."""
    n = p.shape[0]
    period = np.zeros(p.shape[1]) if period is None else period
    out = np.zeros((n, len(faces)), dtype=bool)
    depth = np.zeros((n, len(faces)))
    for f, face in enumerate(faces):
        d = face.side * _min_image(p[:, face.axis] - face.position, period[face.axis])
        b = (d > 1e-12 * max(1.0, abs(face.position))) & (d <= R * (1.0 + 1e-12))
        for a in range(p.shape[1]):
            if a == face.axis:
                continue
            if face.lo is not None:
                b &= p[:, a] >= face.lo[a] - R
            if face.hi is not None:
                b &= p[:, a] <= face.hi[a] + R
        out[:, f] = b
        depth[:, f] = np.where(b, d, 0.0)
    return out, depth


def number_density(x, vol, R, kernel: str = "wendland_c2", period=None):
    """n_i = sum_j V_j W_ij (self included): 1 inside a uniform body, about 1/2 at a face;
    minimum image on the axes with ``period > 0``."""
    kind = kernels.kernel_code(kernel)
    dim = x.shape[1]
    sigma = kernels.kernel_sigma(kind, dim, R)
    period = np.zeros(dim) if period is None else np.asarray(period, float)
    lo, hi = x.min(0) - R, x.max(0) + R
    nl = build_neighbor_list(x, R, lo, hi, period)
    return interpolate(np.ones(x.shape[0]), x, vol, nl.offsets, nl.indices, R, sigma, kind,
                       period)


def _owner_mask(p: np.ndarray, faces: list[Face]) -> np.ndarray:
    """(n, nfaces) bool: face f belongs to the box nearest to point p (faces without a box
    always count).

    With several blocks, a ghost below block a next to block b lies laterally within R of
    b's face at the a|b interface too; only the faces of the block the ghost hangs off (the
    nearest box) may mirror it, or its source lands in the wrong block."""
    boxes = {}
    fid = []
    for fc in faces:
        key = None if fc.lo is None else (tuple(fc.lo), tuple(fc.hi))
        fid.append(boxes.setdefault(key, len(boxes)))
    fid = np.array(fid)
    dist = np.zeros((p.shape[0], len(boxes)))
    for key, b in boxes.items():
        if key is not None:
            lo, hi = np.array(key[0]), np.array(key[1])
            gap = np.maximum(np.maximum(lo - p, p - hi), 0.0)
            dist[:, b] = np.sqrt((gap**2).sum(axis=1))
    nearest = dist.min(axis=1, keepdims=True)
    box_ok = dist <= nearest * (1 + 1e-12) + 1e-300
    for key, b in boxes.items():
        if key is None:
            box_ok[:, b] = True
    return box_ok[:, fid]


def place_ghosts(x, vol, dx: float, R: float, faces: list[Face], *, kernel="wendland_c2",
                 eta_place: float = 0.85, eta_trim: float = 1.3, origin=None,
                 neumann_source: str = "mirror", period=None, lo=None) -> Ghosts:
    """Algorithm 2.5: ghosts on the lattice ``origin + dx * integer`` beyond the faces.

    ``x`` (n, dim) and ``vol`` are the real particles; ``origin`` defaults to the first
    particle's position (the lattice the particles were generated on).  ``period`` (dim,)
    is the periodic length per axis (0: open) and ``lo`` the lower corner of the periodic
    cell (default: the cell centred on the particles); no ghost is placed across a periodic
    axis (module docstring).  Returns :class:`Ghosts` with ``source`` indexing ``x`` and
    positions inside the periodic cell; ``stats`` counts the particles with low density,
    the candidates and the trimmed ghosts.
    """
    if neumann_source not in NEUMANN_SOURCES:
        raise ValueError(f"neumann_source must be one of {NEUMANN_SOURCES}")
    x = np.ascontiguousarray(x, dtype=np.float64)
    vol = np.ascontiguousarray(vol, dtype=np.float64)
    n, dim = x.shape
    origin = x[0] if origin is None else np.asarray(origin, float)
    period = (np.zeros(dim) if period is None
              else np.broadcast_to(np.asarray(period, float), (dim,)).copy())
    periodic = bool(np.any(period > 0))
    if lo is None:
        lo = 0.5 * (x.min(0) + x.max(0) - period)
    lo = np.broadcast_to(np.asarray(lo, float), (dim,)).copy()
    dens = number_density(x, vol, R, kernel, period)
    low = np.flatnonzero(dens < eta_place)
    stats = {"low_density_particles": int(low.size)}
    empty = Ghosts(np.zeros((0, dim)), np.zeros(0, np.int8), np.zeros(0, np.int64),
                   np.zeros(0), np.zeros(0, np.int64), None, stats)
    if low.size == 0 or not any(f.bc != "free" for f in faces):
        return empty
    # lattice points within R of every low-density particle
    m = int(np.ceil(R / dx))
    stencil = np.stack(np.meshgrid(*[np.arange(-m, m + 1)] * dim, indexing="ij"),
                       axis=-1).reshape(-1, dim)
    base = np.rint((x[low] - origin) / dx).astype(np.int64)
    idx = (base[:, None, :] + stencil[None, :, :]).reshape(-1, dim)
    pts = origin + dx * idx
    near = np.linalg.norm(pts - np.repeat(x[low], stencil.shape[0], axis=0), axis=1)
    idx = np.unique(idx[near <= R * (1 + 1e-12)], axis=0)
    pts = origin + dx * idx
    if periodic:  # into the periodic cell; images of one point reached from both ends: once
        pts = _wrap(pts, lo, period)
        pairs = _tree(pts, lo, period).query_pairs(0.5 * dx, output_type="ndarray")
        pts = np.delete(pts, np.unique(pairs.max(axis=1)), axis=0)
    beyond, depth = _beyond(pts, faces, R, period)
    owner = _owner_mask(pts, faces)
    beyond &= owner
    depth = np.where(owner, depth, 0.0)
    is_free = np.array([f.bc == "free" for f in faces])
    keep = beyond.any(axis=1) & ~(beyond & is_free).any(axis=1)
    tree = _tree(x, lo, period)
    dist, _ = _query(tree, pts, lo, period)
    keep &= dist > 0.5 * dx
    pts, beyond, depth = pts[keep], beyond[keep], depth[keep]
    stats["candidates"] = int(pts.shape[0])
    if pts.shape[0] == 0:
        return empty
    # trim: number density over real + candidate ghosts
    gvol = np.full(pts.shape[0], dx**dim)
    dens_all = number_density(np.concatenate([x, pts]), np.concatenate([vol, gvol]), R,
                              kernel, period)
    keep = dens_all[n:] <= eta_trim
    stats["trimmed"] = int((~keep).sum())
    pts, beyond, depth = pts[keep], beyond[keep], depth[keep]
    # boundary condition of each ghost
    is_dir = np.array([f.bc == "dirichlet" for f in faces])
    dir_depth = np.where(beyond & is_dir, depth, -1.0)
    has_dir = (beyond & is_dir).any(axis=1)
    face = np.where(has_dir, np.argmax(dir_depth, axis=1), np.argmax(depth, axis=1))
    gtype = np.where(has_dir, DIRICHLET, INSULATED).astype(np.int8)
    t_wall = np.array([faces[f].temperature if t == DIRICHLET else np.nan
                       for f, t in zip(face, gtype, strict=True)])
    # mirror once per axis, about the plane the ghost is deepest beyond on that axis (two
    # blocks' coplanar faces must not mirror it twice, back onto itself)
    mirror = pts.copy()
    for a in range(dim):
        on_axis = np.array([fc.axis == a for fc in faces])
        d_a = np.where(beyond & on_axis, depth, -1.0)
        f_a = np.argmax(d_a, axis=1)
        sel = d_a[np.arange(pts.shape[0]), f_a] > 0.0
        plane = np.array([fc.position for fc in faces])[f_a[sel]]
        mirror[sel, a] = (2.0 * plane - pts[sel, a] if period[a] == 0.0
                          else plane - _min_image(pts[sel, a] - plane, period[a]))
    if neumann_source == "nearest":
        target = np.where((gtype == INSULATED)[:, None], pts, mirror)
    else:
        target = mirror
    _, source = _query(tree, target, lo, period)
    # antisymmetric Dirichlet: T_g = T_w - r (T_s - T_w), r = d_g / d_s (depth of the ghost
    # beyond, and of its source inside, the Dirichlet face): exact for T linear along the
    # normal also when the real particles are off the lattice (r = 1 on it); r <= R_MAX
    ratio = np.ones(pts.shape[0])
    for q in np.flatnonzero(gtype == DIRICHLET):
        fc = faces[face[q]]
        d_s = fc.side * _min_image(fc.position - x[source[q], fc.axis], period[fc.axis])
        ratio[q] = min(depth[q, face[q]] / max(d_s, 1e-12), R_MAX)
    stats["ghosts"] = int(pts.shape[0])
    stats["dirichlet"] = int((gtype == DIRICHLET).sum())
    stats["insulated"] = int((gtype == INSULATED).sum())
    return Ghosts(np.ascontiguousarray(pts), gtype, source.astype(np.int64), t_wall,
                  face.astype(np.int64), ratio, stats)
