"""Transfer of sensor forces and particle temperatures onto a substrate mesh.

Forces -- a conservative Neumann load (style anchor 9: "loads f = P^T F")
-----------------------------------------------------------------------
The sensors' forces F_p [N] (what the fluid exerts on the wall particles) act, physically,
on the substrate's wetted surface.  Each sensor point X_p is moved onto the coupled facet
group (:func:`snap_points`), and the consistent nodal load of the point forces is

    f = P^T F,      P_{(c,p),(c,a)} = N_a(X_p^s)                                       (1)

with P the probe (interpolation) matrix of the displacement basis at the snapped points
(``FEMSubstrate.probe_matrix``).  Because the Lagrange shape functions are a partition of
unity and reproduce linear fields (sum_a N_a = 1, sum_a N_a x_a = x),

    sum_a f_a = sum_p F_p                       (total force, to round-off)              (2)
    sum_a x_a x f_a = sum_p X_p^s x F_p         (moment, to round-off)                   (3)

and the virtual work of the load in any displacement u is F . (P u): the transfer is the
exact transpose of sampling u at the sensors.  Snapping changes only the coordinate along
the surface normal (points beyond the group's extent are also clipped tangentially and
counted as ``clipped``), so the moment about the surface normal and the moments of the
normal forces are those of the sensors themselves; the lever arm of a tangential force is
moved from the wall particle to the surface it acts on.  For sensors on nodes (the thesis'
figure 2.5 placement) (1) is the thesis' direct nodal loading.

Temperatures -- interpolation at the substrate's nodes
-------------------------------------------------------
A target node is *covered* when it lies in the SPH solid region, taken as the union of the
particles' cells: boxes centred on the particles with per-axis sides h_a (relative tolerance
1e-6), |X_a - x_a| <= h_a / 2 for every axis a for some particle
(:func:`particle_cells`).  The sides come from the particle lattice itself: h_a is the
smallest |dx_a| to a neighbour lying in the cone around axis a (|dx_a| >= |dx_b| for every
b), then all sides are scaled by one factor so that prod_a h_a = V, the particle's volume.
On a Cartesian lattice with spacings (s_1, ..., s_d) -- the scenes' boxes, whose spacing is
adjusted per axis -- this gives h_a = s_a exactly, so the cells tile the region with no gap
at any aspect ratio (an isotropic lattice gives cubes of side V^(1/d); a disordered set,
boxes of volume V with the aspect of the nearest neighbours).  Uncovered nodes keep the
reference temperature T0 (no heat has reached them in the SPH model, whose region must
enclose the heated zone).
Covered nodes take (``method``):

* ``"mls"`` (default) -- moving least squares with a linear basis and kernel weights
  w_j = W(|X - x_j|) V_j: T(X) = e_1^T M^{-1} sum_j w_j p_j T_j, p_j = [1, (x_j - X)/R],
  M = sum_j w_j p_j p_j^T.  Exact for linear fields at every node with a regular moment
  matrix (also at the region's faces and corners, where Shepard is first order); nodes with
  cond(M) > ``cond_max`` or fewer than d + 1 neighbours fall back to Shepard (counted).
* ``"shepard"`` -- T(X) = sum_j w_j T_j / sum_j w_j: exact for constants, bounded by the
  particle values (no over/undershoot).
* ``"nearest"`` -- the nearest particle's value (the thesis' sensor-on-node reading).

The map is a sparse matrix A (covered targets x particles) built once for fixed particle
and node positions; each coupling step is one product.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from numba import njit

from sphfem.kernels import kernel_code, kernel_f

logger = logging.getLogger(__name__)

METHODS = ("mls", "shepard", "nearest")


# ----------------------------------------------------------------------------- snapping


def group_plane(mesh, group: str, rtol: float = 1e-9):
    """``(axis, value, inward)`` if facet group ``group`` of ``mesh`` is an axis-aligned
    plane (``inward`` = +1 when the mesh lies on the +axis side of it), else None."""
    nodes = np.unique(mesh.facets[:, mesh.boundaries[group]])
    P = mesh.p[:, nodes]
    span = np.ptp(mesh.p, axis=1)
    for ax in range(mesh.p.shape[0]):
        if np.ptp(P[ax]) <= rtol * span[ax]:
            value = float(P[ax].mean())
            inward = 1 if mesh.p[ax].mean() > value else -1
            return ax, value, inward
    return None


def snap_points(substrate, points, group: str = "top"):
    """Points (n, dim) moved onto facet group ``group`` of ``substrate.mesh`` and a hair
    (1e-9 of the mean facet size) inside, so point location accepts them.

    Returns ``(snapped, clipped)`` where ``clipped`` marks points that also had to move
    tangentially (they lay beyond the group's extent).  Axis-aligned planar groups (the
    recipes' box faces) are handled in closed form; other groups through
    ``substrate.snap_to_surface`` (nearest facet).
    """
    X = np.atleast_2d(np.asarray(points, float))
    mesh = substrate.mesh
    if group not in (mesh.boundaries or {}):
        raise ValueError(f"coupling: mesh has no facet group {group!r}; available: "
                         f"{', '.join(sorted(mesh.boundaries or {}))}")
    plane = group_plane(mesh, group)
    if plane is None:
        S = substrate.snap_to_surface(X, group)
        return S, np.zeros(len(X), bool)
    ax, value, inward = plane
    fv = mesh.facets[:, mesh.boundaries[group]]
    nodes = np.unique(fv)
    lo = mesh.p[:, nodes].min(axis=1)
    hi = mesh.p[:, nodes].max(axis=1)
    size = float(np.mean(np.linalg.norm(mesh.p[:, fv[0]] - mesh.p[:, fv[1]], axis=0)))
    eps = 1e-9 * size
    S = X.copy()
    S[:, ax] = value + inward * eps
    tang = [a for a in range(X.shape[1]) if a != ax]
    clipped = np.zeros(len(X), bool)
    for a in tang:
        c = np.clip(S[:, a], lo[a] + eps, hi[a] - eps)
        clipped |= c != S[:, a]
        S[:, a] = c
    clipped &= np.any(np.abs(S[:, tang] - X[:, tang]) > 2 * eps, axis=1)
    return S, clipped


# ----------------------------------------------------------------------------- forces


class ForceTransfer:
    """Conservative point-force load f = P^T F onto an FEM substrate, eq. (1).

    Built once for fixed sensor positions ``points`` (n, dim); :meth:`loads` maps forces
    (n, dim) to the load vector (length ``substrate.n_dofs``).
    """

    def __init__(self, substrate, points, group: str = "top"):
        self.substrate = substrate
        self.group = group
        self.points_in = np.atleast_2d(np.asarray(points, float)).copy()
        self.points, self.clipped = snap_points(substrate, self.points_in, group)
        self.P = substrate.probe_matrix(self.points) if len(self.points) else None
        if self.clipped.any():
            logger.warning("coupling: %d of %d sensors lie beyond the substrate's %r face "
                           "and were clipped onto its edge", int(self.clipped.sum()),
                           len(self.points), group)

    def matches(self, points) -> bool:
        p = np.asarray(points)
        return p.shape == self.points_in.shape and np.array_equal(p, self.points_in)

    def loads(self, forces) -> np.ndarray:
        F = np.atleast_2d(np.asarray(forces, float))
        if F.shape != self.points_in.shape:
            raise ValueError(f"forces {F.shape} do not match the sensors {self.points_in.shape}")
        if self.P is None:
            return self.substrate.basis.zeros()
        return self.P.T @ F.T.ravel()

    # bookkeeping ------------------------------------------------------------------------
    def total(self, f: np.ndarray) -> np.ndarray:
        """Sum of the load vector per component, eq. (2)."""
        return np.array([f[d].sum() for d in self.substrate.component_dofs])

    def moment(self, f: np.ndarray, origin=None) -> np.ndarray:
        """sum over dofs of (x_dof - origin) x (e_c f_dof): (3,) in 3D, (1,) in 2D, eq. (3)."""
        s = self.substrate
        x = s.basis.doflocs.T  # (ndofs, dim)
        F = np.zeros_like(x)
        for c, d in enumerate(s.component_dofs):
            F[d, c] = f[d]
        return point_moment(x, F, origin)


def point_moment(x, F, origin=None) -> np.ndarray:
    """sum_p (x_p - origin) x F_p: (3,) in 3D, (1,) in 2D."""
    x = np.atleast_2d(np.asarray(x, float))
    F = np.atleast_2d(np.asarray(F, float))
    if origin is not None:
        x = x - np.asarray(origin, float)
    if x.shape[1] == 2:
        return np.array([np.sum(x[:, 0] * F[:, 1] - x[:, 1] * F[:, 0])])
    return np.cross(x, F).sum(axis=0)


# ----------------------------------------------------------------------------- temperature


class TemperatureMap:
    """Particle temperatures -> values at target nodes (see the module docstring).

    Parameters: ``targets`` (m, dim) node positions, ``sources`` (n, dim) particle positions,
    ``vol`` (n,) particle volumes, ``R`` kernel support radius, ``method``, ``kernel``.
    """

    def __init__(self, targets, sources, vol, R: float, method: str = "mls",
                 kernel: str = "wendland_c2", cond_max: float = 1e6):
        from scipy.spatial import cKDTree

        if method not in METHODS:
            raise ValueError(f"temperature map: method must be one of {METHODS}, got {method!r}")
        self.method = method
        Xt = np.atleast_2d(np.asarray(targets, float))
        Xs = np.atleast_2d(np.asarray(sources, float))
        vol = np.asarray(vol, float)
        self.n_targets, self.n_sources = len(Xt), len(Xs)
        dim = Xt.shape[1]
        self.fallbacks = 0
        if len(Xs) == 0:
            self.covered = np.zeros(len(Xt), bool)
            self.A = sp.csr_matrix((0, 0))
            return
        tree = cKDTree(Xs)
        self.cells = particle_cells(Xs, vol, tree)
        self.covered = _in_cells(Xt, Xs, self.cells)
        idx = np.nonzero(self.covered)[0]
        Xc = Xt[idx]
        m = len(idx)
        if method == "nearest":
            _, j = tree.query(Xc)
            self.A = sp.csr_matrix((np.ones(m), (np.arange(m), j)), shape=(m, len(Xs)))
            return
        D = cKDTree(Xc).sparse_distance_matrix(tree, R, output_type="coo_matrix")
        rows, cols, r = D.row, D.col, D.data
        # sparse_distance_matrix drops exact zeros (a node on a particle): add them back
        _, j0 = tree.query(Xc)
        on = np.linalg.norm(Xs[j0] - Xc, axis=1) == 0.0
        rows = np.concatenate([rows, np.nonzero(on)[0]])
        cols = np.concatenate([cols, j0[on]])
        r = np.concatenate([r, np.zeros(int(on.sum()))])
        w = _kernel_shapes(r / R, kernel_code(kernel)) * vol[cols]
        wsum = np.bincount(rows, weights=w, minlength=m)
        shep = w / wsum[rows]
        if method == "shepard":
            a = shep
        else:
            p = np.column_stack([np.ones(len(rows)), (Xs[cols] - Xc[rows]) / R])  # (nnz, d+1)
            k = dim + 1
            M = np.zeros((m, k, k))
            for i1 in range(k):
                for i2 in range(i1, k):
                    M[:, i1, i2] = M[:, i2, i1] = np.bincount(rows, weights=w * p[:, i1] * p[:, i2],
                                                              minlength=m)
            cnt = np.bincount(rows, minlength=m)
            cond = np.full(m, np.inf)
            ok = cnt >= k
            cond[ok] = np.linalg.cond(M[ok])
            ok &= cond <= cond_max
            c = np.zeros((m, k))
            e1 = np.zeros((int(ok.sum()), k, 1))
            e1[:, 0, 0] = 1.0
            c[ok] = np.linalg.solve(M[ok], e1)[..., 0]
            a = np.where(ok[rows], w * np.einsum("ij,ij->i", c[rows], p), shep)
            self.fallbacks = int((~ok).sum())
        self.A = sp.csr_matrix((a, (rows, cols)), shape=(m, len(Xs)))

    def __call__(self, T_sources, T0: float) -> np.ndarray:
        """Temperatures at every target: mapped where covered, ``T0`` elsewhere."""
        out = np.full(self.n_targets, float(T0))
        if self.A.shape[0]:
            out[self.covered] = self.A @ np.asarray(T_sources, float)
        return out

    def stats(self) -> dict:
        return {"method": self.method, "targets": self.n_targets,
                "covered": int(self.covered.sum()), "mls_fallbacks": self.fallbacks}


def particle_cells(X, vol, tree=None, k: int | None = None, chunk: int = 4096) -> np.ndarray:
    """Per-axis cell sides h (n, dim) of particles ``X`` (n, dim) with volumes ``vol``:
    h_a = min |dx_a| over the neighbours in the cone of axis a (|dx_a| >= |dx_b|, among the
    ``k`` nearest, default 4^dim), rescaled so that prod_a h_a = V (module docstring).  An
    axis with no neighbour in its cone (a single layer) takes the side that completes the
    volume; a particle with none at all, V^(1/d)."""
    from scipy.spatial import cKDTree

    X = np.atleast_2d(np.asarray(X, float))
    n, dim = X.shape
    vol = np.broadcast_to(np.asarray(vol, float), (n,))
    tree = cKDTree(X) if tree is None else tree
    k = min(n, 4**dim if k is None else k)
    h = np.empty((n, dim))
    for a in range(0, n, chunk):  # bounded work arrays (chunk x k x dim)
        b = min(n, a + chunk)
        _, nb = tree.query(X[a:b], k=k)
        D = np.abs(X[np.asarray(nb).reshape(b - a, k)] - X[a:b, None, :])
        in_cone = (D >= D.max(axis=2, keepdims=True)) & (D > 0)
        h[a:b] = np.where(in_cone, D, np.inf).min(axis=1)
    found = np.isfinite(h)
    nf = found.sum(axis=1)
    logh = np.where(found, np.log(np.where(found, h, 1.0)), 0.0)
    # missing axes share what the found ones leave of the volume
    miss = np.where(nf < dim, (np.log(vol) - logh.sum(axis=1)) / np.maximum(dim - nf, 1), 0.0)
    logh = np.where(found, logh, miss[:, None])
    logh += (np.log(vol) - logh.sum(axis=1))[:, None] / dim  # prod h = V
    h = np.exp(logh)
    none = nf == 0
    h[none] = vol[none, None] ** (1.0 / dim)
    return h


def _in_cells(Xt, Xs, h, rtol: float = 1e-6, chunk: int = 4096) -> np.ndarray:
    """True for targets inside the union of the boxes |X - x_j| <= h_j / 2 (per axis).

    Each source's box is searched with its own radius (a tree of the targets), so the work
    and memory follow the true overlaps: one large cell (an isolated particle, whose side
    completes its volume) does not widen the search of every other particle."""
    from scipy.spatial import cKDTree

    Xt = np.atleast_2d(np.asarray(Xt, float))
    Xs = np.atleast_2d(np.asarray(Xs, float))
    covered = np.zeros(len(Xt), bool)
    if len(Xt) == 0 or len(Xs) == 0:
        return covered
    half = 0.5 * np.asarray(h, float) * (1 + rtol)
    ttree = cKDTree(Xt)
    for a in range(0, len(Xs), chunk):  # bounded candidate arrays
        b = min(len(Xs), a + chunk)
        cand = ttree.query_ball_point(Xs[a:b], half[a:b].max(axis=1), p=np.inf)
        lens = np.fromiter((len(c) for c in cand), np.int64, len(cand))
        if not lens.sum():
            continue
        src = np.repeat(np.arange(a, b), lens)
        tgt = np.fromiter((i for c in cand for i in c), np.int64, int(lens.sum()))
        ok = np.all(np.abs(Xt[tgt] - Xs[src]) <= half[src], axis=1)
        covered[tgt[ok]] = True
    return covered


@njit(cache=True)
def _kernel_shapes(q: np.ndarray, kind: int) -> np.ndarray:
    """The un-normalised kernel shape f(q) of :func:`sphfem.kernels.kernel_f` at every q
    (the normalisation cancels in the Shepard and MLS weights)."""
    out = np.empty(q.size)
    for i in range(q.size):
        out[i] = kernel_f(q[i], kind)
    return out
