"""2D negative-thermal-expansion metamaterial (Park 2019 sec. 2.5.9, table 2.1), TL-SPH
and FEM on the same particle geometry.

Microstructure: an n x n square array of circular nodes (material 1) with period ``a``,
neighbouring nodes joined by circular-arc bilayer ribs (anti-tetrachiral layout: the bow
of a rib alternates so that every node can rotate, the sense of rotation alternating like a
checkerboard).  Each rib's convex half is material 2 (stiff, large alpha), its concave half
material 1 (compliant, small alpha): heating curls the ribs, the nodes rotate, the chords
shorten and the structure contracts although both materials expand (Wu et al. 2016; Qu et
al. 2017; Ha, Hestekin & Lakes 2015 for bimaterial chiral lattices).

Materials (table 2.1): lam1 = 1e5 Pa, mu1 = 0.5e5 Pa, alpha1 = 2e-5 /K; lam2 = 1e6 Pa,
mu2 = 0.5e6 Pa, alpha2 = 2e-4 /K (nu = 1/3 for both).  The thesis exposes the structure to
a sudden ambient rise of 100 K and follows the conduction; here the final, uniform
temperature rise dT = 100 K is applied at once and the body relaxed to equilibrium
(dynamic relaxation) -- the end state of the thesis' transient.  2D plane strain.

Effective (secant) expansion coefficient: the node centres' displacements (mean over each
node's particles) are fitted by u = eps X + rotation + translation; alpha_eff =
(eps_xx + eps_yy) / (2 dT).  The FEM comparison (plane-strain linear thermo-elasticity,
scikit-fem, Q2 elements) meshes exactly the particles' cells (one square of side dx per
particle), so both see the same staircase geometry.

    PYTHONPATH=. python examples/tlsph/metamaterial.py [--cells 4] [--per-layer 3]

Results are module globals after :func:`run` (importable; the plot is made only as a
script): ``RESULT`` with ``alpha_eff_tlsph``, ``alpha_eff_fem``, wall seconds, particle
counts.  Measured (1 cell and 2 x 2 cells, 2 particles per rib layer, dx = 3 mm, relaxed
to 1e-6): alpha_eff TL-SPH -3.68e-4 / -3.59e-4 /K, linear FEM -3.05e-4 / -3.05e-4 /K --
TL-SPH about 20% more negative (finite rotations of the nodes, which the linear FEM
misses, and two particles per layer).  The thesis reports alpha = 2.054e-6 for its
(unpublished) geometry, calling it a negative expansion; the sign there is presumably
lost -- this geometry's value is its own.
"""

from __future__ import annotations

import time

import numpy as np

LAM = (1.0e5, 1.0e6)
MU = (0.5e5, 0.5e6)
ALPHA = (2.0e-5, 2.0e-4)
RHO = 1000.0       # only scales the pseudo-dynamics of the relaxation
DT = 100.0         # K

RESULT: dict = {}


def geometry(cells: int = 2, per_layer: int = 2, a: float = 0.15):
    """Cell-centred particle lattice of the microstructure: positions X (n, 2), material
    index (0/1), node index per particle (-1 on ribs) and the spacing dx.  ``cells`` x
    ``cells`` unit cells (cells + 1 nodes per side), ribs two layers of ``per_layer``
    particles; the rib thickness is a fixed 8% of the period, so ``per_layer`` sets dx."""
    h = 0.08 * a                         # rib thickness (two layers)
    dx = h / (2 * per_layer)
    rn = 0.14 * a                        # node radius
    s = 0.2 * a                          # sagitta of the rib arcs
    Rc = (a * a / 4 + s * s) / (2 * s)   # arc radius
    nn = cells + 1
    lo = -rn - s
    hi = cells * a + rn + s
    m = int(np.ceil((hi - lo) / dx))
    g = lo + dx * (np.arange(m) + 0.5)
    X = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    mat = np.full(X.shape[0], -1)
    node = np.full(X.shape[0], -1)
    for i in range(nn):
        for j in range(nn):
            P = np.array([i * a, j * a])
            for e in (np.array([1.0, 0.0]), np.array([0.0, 1.0])):
                Q = P + a * e
                if Q.max() > cells * a + 1e-12:
                    continue
                left = np.array([-e[1], e[0]])        # left of the travel P -> Q
                bow = left * (-1.0) ** (i + j)
                C = 0.5 * (P + Q) - (Rc - s) * bow    # arc centre (opposite to the bow)
                d = X - C
                r = np.hypot(d[:, 0], d[:, 1])
                along = (X - P) @ e
                side = (X - 0.5 * (P + Q)) @ bow > -(Rc - s)
                band = (np.abs(r - Rc) < h / 2) & (along > 0) & (along < a) & side
                mat[band & (mat < 0)] = np.where(r[band & (mat < 0)] > Rc, 1, 0)
    for i in range(nn):
        for j in range(nn):
            k = i * nn + j
            inside = np.hypot(X[:, 0] - i * a, X[:, 1] - j * a) < rn
            mat[inside] = 0
            node[inside] = k
    # keep the largest edge-connected part: staircase arcs leave cells touching only at a
    # corner (a hinge for the FEM cells) or stray fragments
    from scipy import ndimage

    grid = (mat >= 0).reshape(m, m)
    lab, _ = ndimage.label(grid)
    big = np.argmax(np.bincount(lab.ravel())[1:]) + 1
    keep = (lab == big).ravel()
    centres = np.array([[i * a, j * a] for i in range(nn) for j in range(nn)])
    return X[keep], mat[keep], node[keep], dx, centres


def effective_alpha(X, u, node, centres, dT=DT):
    """Secant expansion coefficient from the nodes' mean displacements (least-squares fit
    of eps (symmetric) + rotation + translation)."""
    k = np.unique(node[node >= 0])
    U = np.array([u[node == q].mean(axis=0) for q in k])
    C = centres[k] - centres[k].mean(axis=0)
    A = np.zeros((2 * len(k), 6))  # exx, eyy, exy, w, tx, ty
    A[0::2, 0] = C[:, 0]
    A[0::2, 2] = C[:, 1]
    A[0::2, 3] = -C[:, 1]
    A[0::2, 4] = 1.0
    A[1::2, 1] = C[:, 1]
    A[1::2, 2] = C[:, 0]
    A[1::2, 3] = C[:, 0]
    A[1::2, 5] = 1.0
    c, *_ = np.linalg.lstsq(A, U.reshape(-1), rcond=None)
    return 0.5 * (c[0] + c[1]) / dT, c


def run_tlsph(X, mat, dx, tol=1e-6, u0=None):
    from sphfem.solid.body import SolidBody
    from sphfem.solid.integrate import relax

    lam = np.take(LAM, mat)
    mu = np.take(MU, mat)
    alpha = np.take(ALPHA, mat)
    body = SolidBody(X, dx * dx, RHO, lam, mu, alpha, dx)
    body.theta[:] = DT
    if u0 is not None:  # warm start (the linear FEM solution): the relaxation then only
        body.x += u0    # has to find the geometrically nonlinear correction
    info = relax(body, tol=tol, max_steps=400000)
    body.internal_forces()
    return body, info


def run_fem(X, mat, dx):
    """Plane-strain linear thermo-elasticity on the particles' cells (Q2 quads)."""
    from scipy.sparse.linalg import splu
    from skfem import Basis, ElementQuad2, ElementVector, MeshQuad1

    from sphfem.fem import forms

    ij = np.rint((X - X.min(axis=0)) / dx).astype(int)
    m = ij.max(axis=0) + 2
    nid = -np.ones(m[0] * m[1], int)
    corners = np.stack([ij, ij + [1, 0], ij + [1, 1], ij + [0, 1]], axis=1)   # (n, 4, 2)
    flat = corners[..., 0] * m[1] + corners[..., 1]
    used = np.unique(flat)
    nid[used] = np.arange(used.size)
    p = np.stack([used // m[1], used % m[1]]).astype(float) * dx
    p += (X.min(axis=0) - 0.5 * dx)[:, None]
    mesh = MeshQuad1(p, nid[flat].T)
    e = ElementVector(ElementQuad2())
    basis = Basis(mesh, e)
    K = None
    f = basis.zeros()
    for k in (0, 1):
        sel = np.flatnonzero(mat == k)
        b = Basis(mesh, e, elements=sel)
        Ki = forms.elasticity(LAM[k], MU[k]).assemble(b)
        K = Ki if K is None else K + Ki
        f += forms.thermal_load(LAM[k], MU[k], ALPHA[k]).assemble(
            b, dT=np.full((b.nelems, b.X.shape[1]), DT))
    nd = basis.nodal_dofs
    c = mesh.p.mean(axis=1)
    a0 = int(np.argmin(np.hypot(*(mesh.p - c[:, None]))))
    a1 = int(np.argmin(np.hypot(*(mesh.p - c[:, None] - [[0.05], [0.0]]))))
    D = np.array([nd[0, a0], nd[1, a0], nd[1, a1]])
    free = np.setdiff1d(np.arange(basis.N), D)
    u = basis.zeros()
    u[free] = splu(K[free][:, free].tocsc()).solve(f[free])
    U = u[nd].T                                   # (vertices, 2)
    cell_u = U[mesh.t].mean(axis=0)               # mean of the 4 corners (cell ~ particle)
    return cell_u, basis.N


def run(cells: int = 2, per_layer: int = 2, fem: bool = True, tol: float = 1e-6,
        warm_start: bool = False) -> dict:
    """Build, solve (FEM), relax (TL-SPH to the residual ``tol``; ``warm_start`` starts
    it from the FEM displacements, which did not shorten it in a trial); fill and return
    :data:`RESULT`.  The soft node-rotation mechanism makes the dynamic relaxation slow:
    ~1.8e5 steps for 1 cell at 2 particles per layer (~100-240 s on a loaded 2-core
    machine); a residual of 1e-5 is not yet converged (alpha_eff -3.15e-4 vs -3.68e-4 at
    1e-6)."""
    X, mat, node, dx, centres = geometry(cells, per_layer)
    RESULT.clear()
    u_fem = None
    if fem:
        t0 = time.perf_counter()
        u_fem, ndof = run_fem(X, mat, dx)
        RESULT.update(alpha_eff_fem=float(effective_alpha(X, u_fem, node, centres)[0]),
                      fem_wall_s=time.perf_counter() - t0, fem_dofs=int(ndof))
    t0 = time.perf_counter()
    body, info = run_tlsph(X, mat, dx, tol, u_fem if warm_start else None)
    t_sph = time.perf_counter() - t0
    a_sph, fit = effective_alpha(X, body.u, node, centres)
    RESULT.update(cells=cells, per_layer=per_layer, dx=dx, particles=int(X.shape[0]),
                  alpha_eff_tlsph=float(a_sph), tlsph_wall_s=t_sph,
                  relax_steps=info["steps"], relax_residual=info["residual"],
                  strain_fit=fit.tolist(), von_mises_max=float(body.von_mises().max()),
                  warm_start=bool(fem and warm_start), X=X, mat=mat, body=body)
    return RESULT


def plot(path: str = "metamaterial.png") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    body, X = RESULT["body"], RESULT["X"]
    vm = body.von_mises()
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.scatter(X[:, 0], X[:, 1], s=1, c="0.85", lw=0, label="reference")
    sc = ax.scatter(body.x[:, 0], body.x[:, 1], s=2, c=vm, cmap="viridis", lw=0)
    fig.colorbar(sc, ax=ax, label="von Mises [Pa] (plane strain)")
    ax.set_aspect("equal")
    t = (f"dT = {DT:g} K: alpha_eff TL-SPH = {RESULT['alpha_eff_tlsph']:.3e} /K"
         + (f", FEM = {RESULT['alpha_eff_fem']:.3e} /K" if "alpha_eff_fem" in RESULT else ""))
    ax.set_title(t, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=150)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=4)
    ap.add_argument("--per-layer", type=int, default=3)
    ap.add_argument("--png", default="metamaterial.png")
    args = ap.parse_args()
    r = run(args.cells, args.per_layer)
    print({k: v for k, v in r.items() if k not in ("X", "mat", "body")})
    plot(args.png)
    print("wrote", args.png)
