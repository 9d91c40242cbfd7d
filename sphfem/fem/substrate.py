"""Quasi-static linear thermo-elastic substrate on a gmsh mesh, factorised once.

>>> sub = FEMSubstrate("substrate.msh", E=300e9, nu=0.21, alpha=7e-6,
...                    clamps=["bottom"], element="P1")
>>> res = sub.solve(dT_nodal=dT, point_forces=(x_sensors, F_sensors))
>>> res.u, res.stress_nodes, res.von_mises_nodes, res.probe(points)

``K`` is assembled once in the constructor (:mod:`sphfem.fem.assembly`) and the condensed
matrix ``K_II`` (free dofs) is factorised once (``solver="direct"``, :mod:`sphfem.fem.direct`:
MKL PARDISO when pypardiso is installed, otherwise SuperLU in symmetric mode on a METIS
nested-dissection ordering) or given an algebraic
multigrid hierarchy once (``solver="cg-amg"``: pyamg smoothed aggregation with the rigid
body modes as near-nullspace, conjugate gradients warm-started from the previous step).
Every :meth:`FEMSubstrate.solve` re-assembles only the load vector and back-substitutes.

Boundary conditions are named by gmsh physical group: ``clamps`` (all components zero) and
``rollers`` (``{group: "z"}`` -- the listed components zero).  A body with no constraint
at all is held by a statically determinate 3-2-1 pin set (``pin_rigid``), which removes
the rigid motions without stressing the body.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from skfem import (
    Basis,
    ElementHex1,
    ElementHex2,
    ElementQuad1,
    ElementQuad2,
    ElementTetP1,
    ElementTetP2,
    ElementTriP1,
    ElementTriP2,
    ElementVector,
    FacetBasis,
    Mesh,
    MeshHex1,
    MeshQuad1,
    MeshTet1,
    MeshTri1,
)

from sphfem.fem import forms
from sphfem.fem.assembly import elasticity_stiffness, stiffness_intorder
from sphfem.fem.direct import factorize
from sphfem.loads import scalar_at, temperature_change
from sphfem.progress import stage
from sphfem.quasistatic import QuasiStaticSubstrate

logger = logging.getLogger(__name__)

_ELEMENTS = {
    (MeshTet1, "P1"): ElementTetP1, (MeshTet1, "P2"): ElementTetP2,
    (MeshHex1, "P1"): ElementHex1, (MeshHex1, "P2"): ElementHex2,
    (MeshTri1, "P1"): ElementTriP1, (MeshTri1, "P2"): ElementTriP2,
    (MeshQuad1, "P1"): ElementQuad1, (MeshQuad1, "P2"): ElementQuad2,
}
_LINEAR_CELLS = {"tetra10": ("tetra", 4), "hexahedron20": ("hexahedron", 8),
                 "hexahedron27": ("hexahedron", 8), "triangle6": ("triangle", 3),
                 "quad8": ("quad", 4), "quad9": ("quad", 4), "line3": ("line", 2)}
_COMPONENTS = {"x": 0, "y": 1, "z": 2}


def load_mesh(path) -> Mesh:
    """Read a gmsh ``.msh`` (or any meshio format) into a scikit-fem mesh.

    Physical groups of the facets become ``mesh.boundaries``.  Second-order cells
    (tetra10, ...) are reduced to their vertices (the recipes make straight-sided
    meshes; use ``element="P2"`` for quadratic displacements), orphan nodes are dropped.
    """
    import meshio
    from skfem.io.meshio import from_meshio

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    m = read_quiet(path)
    cells = []
    for block in m.cells:
        if block.type in _LINEAR_CELLS:
            t, n = _LINEAR_CELLS[block.type]
            cells.append(meshio.CellBlock(t, block.data[:, :n]))
        else:
            cells.append(block)
    used = np.zeros(len(m.points), bool)
    for b in cells:
        if b.type != "vertex":
            used[b.data.ravel()] = True
    remap = np.cumsum(used) - 1
    cells = [meshio.CellBlock(b.type, remap[b.data]) for b in cells
             if b.type != "vertex" or used[b.data].all()]
    points = m.points[used]
    dim3 = any(b.type in ("tetra", "hexahedron") for b in cells)
    if not dim3:
        points = points[:, :2]
    keep = [i for i, b in enumerate(m.cells) if b.type != "vertex" or used[b.data].all()]
    cell_sets = {k: [v[i] for i in keep] for k, v in m.cell_sets.items()}
    mm = meshio.Mesh(points, cells, cell_sets=cell_sets)
    # skfem warns "Failure to orient a boundary" for quad facets of hex meshes; the
    # orientation only matters for facet normals, which no load here uses
    skfem_log = logging.getLogger("skfem.io.meshio")
    level = skfem_log.level
    skfem_log.setLevel(logging.ERROR)
    try:
        mesh = from_meshio(mm)
    finally:
        skfem_log.setLevel(level)
    if type(mesh) not in {k[0] for k in _ELEMENTS}:
        raise ValueError(f"{path}: unsupported mesh type {type(mesh).__name__}")
    return mesh


def read_quiet(path):
    """meshio.read without the blank line meshio's gmsh reader prints to stdout.

    A file meshio cannot parse raises ``ValueError`` naming the file (meshio itself prints
    to stderr and calls ``sys.exit(1)`` on an unreadable file of an ambiguous suffix).
    """
    import contextlib
    import io

    import meshio

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            return meshio.read(path)
    except (SystemExit, meshio.ReadError, KeyError, IndexError, ValueError) as e:
        said = " ".join((err.getvalue() + " " + str(e)).split()) or type(e).__name__
        raise ValueError(f"mesh file {path} could not be read ({said})") from None


def _component_indices(spec, dim: int) -> list[int]:
    """'z' | 'xy' | 2 | [0, 2] -> sorted component indices."""
    if isinstance(spec, (int, np.integer)):
        items = [int(spec)]
    elif isinstance(spec, str):
        items = [_COMPONENTS.get(c, -1) for c in spec.lower()]
    else:
        items = [int(c) if not isinstance(c, str) else _COMPONENTS.get(c.lower(), -1)
                 for c in spec]
    if not items or any(c < 0 or c >= dim for c in items):
        raise ValueError(f"roller components {spec!r}: use letters from "
                         f"{'xyz'[:dim]!r} or indices < {dim}")
    return sorted(set(items))


def rigid_body_modes(x: np.ndarray, comp: np.ndarray) -> np.ndarray:
    """Rigid body modes (N, 6) in 3D or (N, 3) in 2D at dofs with locations ``x`` (dim, N)
    and component ``comp`` (N,)."""
    dim, n = x.shape
    xc = x - x.mean(axis=1, keepdims=True)
    modes = [(comp == c).astype(float) for c in range(dim)]
    if dim == 2:
        modes.append(np.where(comp == 0, -xc[1], xc[0]))
    else:
        for a, b in ((0, 1), (1, 2), (2, 0)):  # rotation in the (a, b) plane
            r = np.zeros(n)
            r[comp == a] = -xc[b][comp == a]
            r[comp == b] = xc[a][comp == b]
            modes.append(r)
    return np.column_stack(modes)


@dataclass
class FEMResult:
    """One solve: displacement and stresses, computed lazily from the dof vector."""

    substrate: FEMSubstrate
    dofs: np.ndarray  #: full displacement dof vector
    load: np.ndarray  #: assembled load vector f
    dT_spec: object = None  #: the temperature change as given to solve()
    info: dict = field(default_factory=dict)

    @property
    def u(self) -> np.ndarray:
        """Displacement at the mesh vertices, (nvertices, dim)."""
        return self.dofs[self.substrate.basis.nodal_dofs].T

    @property
    def dT_nodes(self) -> np.ndarray:
        """Temperature change at the mesh vertices."""
        return self.substrate._dT_at(self.dT_spec, self.substrate.mesh.p)

    @property
    def stress_qp(self) -> np.ndarray:
        """Cauchy stress (3, 3, nelems, nqp) at the quadrature points."""
        if "stress_qp" not in self.__dict__:
            s = self.substrate
            grad = s.grad_qp(self.dofs)
            self.__dict__["stress_qp"] = forms.thermo_elastic_stress(
                s.lam, s.mu, s.alpha, grad, s._dT_qp(self.dT_spec))
        return self.__dict__["stress_qp"]

    @property
    def stress_elem(self) -> np.ndarray:
        """Volume-averaged Cauchy stress per element, (nelems, 3, 3) (cached)."""
        if "stress_elem" not in self.__dict__:
            dx = self.substrate.basis.dx
            s = (self.stress_qp * dx).sum(axis=-1) / dx.sum(axis=-1)
            self.__dict__["stress_elem"] = np.moveaxis(s, -1, 0)
        return self.__dict__["stress_elem"]

    @property
    def stress_nodes(self) -> np.ndarray:
        """Cauchy stress L2-projected onto the P1 vertex field, (nvertices, 3, 3)."""
        if "stress_nodes" not in self.__dict__:
            self.__dict__["stress_nodes"] = self.substrate.project_tensor(self.stress_qp)
        return self.__dict__["stress_nodes"]

    @property
    def von_mises_nodes(self) -> np.ndarray:
        """Von Mises stress of :attr:`stress_nodes` (cached)."""
        if "von_mises_nodes" not in self.__dict__:
            self.__dict__["von_mises_nodes"] = forms.von_mises(
                np.moveaxis(self.stress_nodes, 0, -1))
        return self.__dict__["von_mises_nodes"]

    @property
    def von_mises_elem(self) -> np.ndarray:
        dx = self.substrate.basis.dx
        return (forms.von_mises(self.stress_qp) * dx).sum(axis=-1) / dx.sum(axis=-1)

    @property
    def residual(self) -> np.ndarray:
        """K u - f: the reaction forces at constrained dofs, ~0 elsewhere."""
        return self.substrate.K @ self.dofs - self.load

    def reaction(self, group: str) -> np.ndarray:
        """Total reaction force (dim,) on the dofs of boundary ``group``."""
        s = self.substrate
        r = self.residual
        dofs = s._group_dofs(group)
        return np.array([r[np.intersect1d(dofs, s.component_dofs[c])].sum()
                         for c in range(s.dim)])

    def probe(self, points) -> dict:
        """Displacement, stress (from the displacement gradient, not the projection) and
        von Mises at arbitrary points inside the mesh, ``points`` (n, dim)."""
        s = self.substrate
        X = np.atleast_2d(np.asarray(points, float)).T
        cells, pts = s._locate(X)
        b = s.basis
        n = X.shape[1]
        u = np.zeros((s.dim, n))
        grad = np.zeros((s.dim, s.dim, n))
        for k in range(b.Nbfun):
            phi = b.elem.gbasis(b.mapping, pts, k, tind=cells)[0]
            coef = self.dofs[b.element_dofs[k, cells]]
            u += np.asarray(phi)[..., 0] * coef
            grad += phi.grad[..., 0] * coef
        dT = s._dT_at(self.dT_spec, X)
        S = self._stress_at(grad, u, X, dT)
        return {"u": u.T, "stress": np.moveaxis(S, -1, 0), "von_mises": forms.von_mises(S),
                "dT": dT}

    def _stress_at(self, grad, u, X, dT) -> np.ndarray:
        """Cauchy stress (3, 3, n) from the displacement gradient (dim, dim, n), the
        displacement (dim, n) and dT (n,) at the points X (dim, n)."""
        s = self.substrate
        return forms.thermo_elastic_stress(s.lam, s.mu, s.alpha, grad, dT)


class FEMSubstrate(QuasiStaticSubstrate):
    """Linear thermo-elastic quasi-static substrate; K assembled and factorised once.
    ``solve(dT_nodal, tractions, point_forces, body_force, T_nodal, snap, load)``
    (:meth:`sphfem.quasistatic.QuasiStaticSubstrate.solve`) back-substitutes each step.

    Parameters
    ----------
    mesh : path of a mesh file (gmsh .msh via meshio) or a scikit-fem mesh with named
        ``boundaries``.
    E, nu, alpha : Young's modulus [Pa], Poisson ratio, linear expansion [1/K].
    T0 : reference temperature [K] (``solve(T_nodal=...)`` uses dT = T - T0).
    element : "P1" (linear) or "P2" (quadratic) displacement; tets, hexes (Q1/Q2),
        triangles and quads (2D = plane strain).
    clamps : group names where every displacement component is zero.
    rollers : ``{group: components}``, e.g. ``{"bottom": "z", "left": "x"}``.
    solver : "direct" (sparse Cholesky/LU, factorised once) or "cg-amg" (pyamg
        smoothed-aggregation preconditioner built once, CG warm-started from the previous
        solution).
    direct_backend : "auto" (PARDISO when pypardiso is installed, else SuperLU), "pardiso",
        "splu" or "cholespy" (:mod:`sphfem.fem.direct`).
    pin_rigid : hold rigid motions by a 3-2-1 pin set; default: only when nothing else
        constrains the body.
    rtol, maxiter : CG stopping criterion (relative residual) and iteration cap.
    nthreads : threads for the stiffness assembly.
    """

    #: the ``solver`` choices of this substrate
    solvers = ("direct", "cg-amg")
    #: the weak forms (:mod:`sphfem.fem.forms`): a subclass states its own (axisymmetric)
    stiffness_form = staticmethod(forms.elasticity)
    thermal_form = staticmethod(forms.thermal_load)
    traction_form = staticmethod(forms.traction_load)
    body_force_form = staticmethod(forms.body_force_load)

    def __init__(self, mesh, E: float, nu: float, alpha: float, T0: float = 293.15,
                 element: str = "P1", clamps=(), rollers=None, solver: str = "direct",
                 pin_rigid: bool | None = None, rtol: float = 1e-10, maxiter: int = 2000,
                 nthreads: int | None = None, direct_backend: str = "auto",
                 intorder: int | None = None):
        t0 = time.perf_counter()
        self.timings: dict[str, float] = {}
        if isinstance(mesh, (str, os.PathLike)):
            self.mesh_path = Path(mesh)
            mesh = load_mesh(mesh)
        else:
            self.mesh_path = None
        if element not in ("P1", "P2"):
            raise ValueError(f"element must be 'P1' or 'P2', got {element!r}")
        if solver not in self.solvers:
            raise ValueError(f"solver must be one of {self.solvers}, got {solver!r}")
        if not (E > 0 and -1 < nu < 0.5):
            raise ValueError(f"need E > 0 and -1 < nu < 0.5, got E={E}, nu={nu}")
        self.mesh = mesh = self._prepare_mesh(mesh)
        self.timings["load_mesh"] = time.perf_counter() - t0
        self.E, self.nu, self.alpha, self.T0 = float(E), float(nu), float(alpha), float(T0)
        self.lam, self.mu = forms.lame_parameters(self.E, self.nu)
        self.element, self.solver = element, solver
        self.rtol, self.maxiter = rtol, maxiter
        self.direct_backend = direct_backend
        self.intorder = intorder
        self.dim = mesh.p.shape[0]
        self.n_factorizations = 0
        self.n_solves = 0
        self.cg_iterations: list[int] = []

        escal = _ELEMENTS[(type(mesh), element)]()
        self.basis = Basis(mesh, ElementVector(escal, dim=self.dim),
                           intorder=self._basis_intorder(mesh, element, intorder))
        self.sbasis = self.basis.with_element(escal)  # scalar, same order
        self.vbasis = self.basis.with_element(_ELEMENTS[(type(mesh), "P1")]())  # vertices
        self.component_dofs = self.basis.split_indices()
        self._facet_bases: dict[str, FacetBasis] = {}

        # --- boundary conditions --------------------------------------------------
        clamps = [clamps] if isinstance(clamps, str) else list(clamps)
        rollers = dict(rollers or {})
        D = [self._group_dofs(g) for g in clamps]
        held = set()
        for g, comps in rollers.items():
            d = self._group_dofs(g)
            for c in self._roller_components(comps):
                D.append(np.intersect1d(d, self.component_dofs[c]))
                held.add(c)
        D += self._symmetry_dofs()
        if pin_rigid is None:
            pin_rigid = self._free_to_move(clamps, held)
        if pin_rigid:
            D.append(self._rigid_pins())
        self.D = np.unique(np.concatenate(D)).astype(np.int64) if D else np.zeros(0, np.int64)
        self.I = np.setdiff1d(np.arange(self.basis.N), self.D)
        self.clamps, self.rollers, self.pin_rigid = clamps, rollers, bool(pin_rigid)

        # --- stiffness, once ------------------------------------------------------
        t1 = time.perf_counter()
        with stage(f"assembling K ({self.basis.N} dofs)"):
            self.K = self._assemble_stiffness(nthreads)
        self.timings["assemble_K"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        what = "factorising" if solver == "direct" else "building the AMG preconditioner of"
        with stage(f"{what} K ({len(self.I)} unknowns)"):
            self._factorize()
        self.timings["factorize"] = time.perf_counter() - t2
        self._u_prev = None
        self._mass = None
        self._tables = None
        self._phi = None
        logger.info("%s: %s %s, %d dofs (%d free), %s; assembly %.2f s, "
                    "factorisation %.2f s", type(self).__name__, type(mesh).__name__, element,
                    self.basis.N, len(self.I), solver, self.timings["assemble_K"],
                    self.timings["factorize"])

    # ------------------------------------------------------------------ geometry hooks
    def _prepare_mesh(self, mesh):
        """The mesh the substrate works on (a subclass checks or extends it)."""
        return mesh

    def _roller_components(self, spec) -> list[int]:
        """Displacement components held by a roller spec ('z', 'xy', [0, 2])."""
        return _component_indices(spec, self.dim)

    def _symmetry_dofs(self) -> list[np.ndarray]:
        """Dofs held by the geometry itself (none in plane strain / 3D)."""
        return []

    def _free_to_move(self, clamps, held: set) -> bool:
        """Whether rigid motions are left (``pin_rigid`` default): nothing constrains the
        body."""
        return not clamps and not held

    @staticmethod
    def _basis_intorder(mesh, element: str, intorder: int | None) -> int | None:
        """Quadrature order of ``basis`` (loads, stresses): as given; by default scikit-fem's
        rule, except on quadrilateral / hexahedral meshes of parallelepipeds, where Gauss with
        p + 1 points per direction (:func:`sphfem.fem.assembly.stiffness_intorder`)
        integrates the stiffness and the loads of polynomial fields of degree <= p per
        direction exactly (scikit-fem's default 2 * maxdeg takes 64 points per Q1 hexahedron
        for the same integrals)."""
        if intorder is not None or isinstance(mesh, (MeshTet1, MeshTri1)):
            return intorder
        return stiffness_intorder(mesh, int(element[1]))

    def _assemble_stiffness(self, nthreads: int | None = None) -> sp.csr_matrix:
        """K: the element-type-aware assembly (:mod:`sphfem.fem.assembly`) of
        :func:`sphfem.fem.forms.elasticity`; scikit-fem's assembly of ``stiffness_form``
        when a subclass states another form or ``nthreads`` is given."""
        if self.stiffness_form is forms.elasticity and not nthreads:
            io = self.intorder
            if io is None:
                io = stiffness_intorder(self.mesh, int(self.element[1]))
            K = elasticity_stiffness(self.basis, self.lam, self.mu, io)
            if K is not None:
                return K
        form = self.stiffness_form(self.lam, self.mu)
        if nthreads:
            form = type(form)(form.form, nthreads=nthreads)
        return form.assemble(self._stiffness_basis()).tocsr()

    def _stiffness_basis(self) -> Basis:
        """The basis K is assembled on: on affine simplices with the default quadrature,
        grad u : grad v is a polynomial of degree 2(p-1), so the minimal exact rule (1 point
        for P1, 4x cheaper than the default rule)."""
        if self.intorder is None and isinstance(self.mesh, (MeshTet1, MeshTri1)):
            return Basis(self.mesh, self.basis.elem, intorder=2 * (int(self.element[1]) - 1))
        return self.basis

    # ------------------------------------------------------------------ set-up
    @property
    def n_dofs(self) -> int:
        return self.basis.N

    def _group_dofs(self, group: str) -> np.ndarray:
        names = sorted(self.mesh.boundaries or {})
        if group not in names:
            raise ValueError(f"mesh has no boundary group {group!r}; available: "
                             f"{', '.join(names) if names else '(none)'}")
        return np.asarray(self.basis.get_dofs(group).flatten(), dtype=np.int64)

    def _rigid_pins(self) -> np.ndarray:
        """3-2-1 (2D: 2-1) statically determinate pins at three well separated vertices."""
        p = self.mesh.p
        nd = self.basis.nodal_dofs  # (dim, nvertices)
        a = int(np.argmin(p.sum(axis=0)))
        b = int(np.argmax(np.linalg.norm(p - p[:, [a]], axis=0)))
        ab = p[:, b] - p[:, a]
        # A: all components; B: every component except the one along AB
        pins = list(nd[:, a])
        along = int(np.argmax(np.abs(ab)))
        pins += [nd[c, b] for c in range(self.dim) if c != along]
        if self.dim == 3:
            r = p - p[:, [a]]
            dist = np.linalg.norm(np.cross(r.T, ab), axis=1)
            c = int(np.argmax(dist))
            vel = np.cross(ab, p[:, c] - p[:, a])  # rotation about AB moves C along this
            pins.append(nd[int(np.argmax(np.abs(vel))), c])
        return np.asarray(pins, dtype=np.int64)

    def _factorize(self) -> None:
        A = self.K[self.I][:, self.I]
        if self.solver == "direct":
            groups = self.I // self.dim  # the scalar dof (node) of each vector unknown
            self.factor = factorize(A, self.direct_backend, groups=groups)
            self._backsolve = self.factor.solve
            self.backend = self.factor.backend
        else:
            self.backend = "pyamg-sa"
            pyamg = _import_pyamg()
            x = self.basis.doflocs[:, self.I]
            comp = np.empty(self.basis.N, dtype=np.int64)
            for c, idx in enumerate(self.component_dofs):
                comp[idx] = c
            B = rigid_body_modes(x, comp[self.I])
            self._A = A.tocsr()
            self._ml = pyamg.smoothed_aggregation_solver(self._A, B=B, symmetry="hermitian",
                                                         max_coarse=500)
            self._M = self._ml.aspreconditioner(cycle="V")
        self.n_factorizations += 1

    # ------------------------------------------------------------------ loads
    def _dT_qp(self, spec) -> np.ndarray | float:
        """Temperature change at the quadrature points of ``basis``."""
        if spec is None:
            return 0.0
        if callable(spec):
            return np.asarray(spec(np.asarray(self.basis.global_coordinates())), float)
        a = np.asarray(spec, float)
        if a.ndim == 0:
            return float(a)
        if a.shape == (self.mesh.nvertices,):
            return self._interpolate_qp(self.vbasis, a)
        if a.shape == (self.sbasis.N,):
            return self._interpolate_qp(self.sbasis, a)
        raise ValueError(f"dT: expected a scalar, a callable, or an array of length "
                         f"{self.mesh.nvertices} (vertices) or {self.sbasis.N} (scalar "
                         f"{self.element} dofs); got shape {a.shape}")

    def _dT_at(self, spec, X: np.ndarray) -> np.ndarray:
        """Temperature change at points X (dim, n) (:func:`sphfem.loads.scalar_at`); vertex
        or scalar-dof arrays are interpolated."""
        return scalar_at(spec, X, lambda a: self._interpolate_scalar(a, X))

    def _interpolate_scalar(self, a: np.ndarray, X: np.ndarray) -> np.ndarray:
        """A vertex (P1) or scalar-dof array interpolated at points X (dim, n)."""
        if X is self.mesh.p and a.shape == (self.mesh.nvertices,):
            return a.copy()
        b = self.vbasis if a.shape == (self.mesh.nvertices,) else self.sbasis
        cells, pts = self._locate(X)
        out = np.zeros(X.shape[1])
        for k in range(b.Nbfun):
            out += np.asarray(b.elem.gbasis(b.mapping, pts, k, tind=cells)[0])[..., 0] * \
                a[b.element_dofs[k, cells]]
        return out

    def thermal_load(self, dT) -> np.ndarray:
        """Load vector of the thermal strain for the temperature change ``dT``:
        f_(a, c) = int (3 lam + 2 mu) alpha dT d phi_a / d x_c dx (forms.thermal_load), summed
        from the cached basis gradients; a subclass's own ``thermal_form`` is assembled by
        scikit-fem."""
        dTq = self._dT_qp(dT)
        if self.thermal_form is not forms.thermal_load:
            return self.thermal_form(self.lam, self.mu, self.alpha).assemble(self.basis, dT=dTq)
        G, dx, edofs = self._qp_tables()
        w = np.broadcast_to(np.asarray(dTq, float), dx.shape) * dx
        vals = np.einsum("akeq,eq->ake", G, w)  # (nloc, dim, nelems)
        beta = forms.thermal_modulus(self.lam, self.mu) * self.alpha
        return beta * np.bincount(edofs.ravel(), vals.ravel(), minlength=self.basis.N)

    # ------------------------------------------------------------------ quadrature tables
    def _qp_tables(self):
        """(G, dx, edofs), cached: the scalar basis gradients G (nloc, dim, nelems, nqp) at the
        quadrature points of ``basis``, the weights dx (nelems, nqp) and the vector dofs
        edofs (nloc, dim, nelems) (scikit-fem's ElementVector: local function dim a + c is
        scalar function a in component c)."""
        if self._tables is None:
            sb = self.sbasis
            G = np.stack([np.asarray(sb.basis[a][0].grad) for a in range(sb.Nbfun)])
            edofs = self.basis.element_dofs.reshape(sb.Nbfun, self.dim, -1)
            self._tables = (G, np.asarray(self.basis.dx), edofs)
        return self._tables

    def grad_qp(self, dofs: np.ndarray) -> np.ndarray:
        """Displacement gradient (dim, dim, nelems, nqp) at the quadrature points of
        ``basis``: grad u[c, k] = sum_a u_(a, c) d phi_a / d x_k."""
        G, _, edofs = self._qp_tables()
        return np.einsum("ace,akeq->ckeq", np.asarray(dofs)[edofs], G)

    def values_qp(self, dofs: np.ndarray) -> np.ndarray:
        """Displacement (dim, nelems, nqp) at the quadrature points of ``basis``:
        u[c] = sum_a u_(a, c) phi_a."""
        if self._phi is None:
            sb = self.sbasis
            self._phi = np.stack([np.asarray(sb.basis[a][0]) for a in range(sb.Nbfun)])
        _, _, edofs = self._qp_tables()
        return np.einsum("ace,aeq->ceq", np.asarray(dofs)[edofs], self._phi)

    @staticmethod
    def _interpolate_qp(basis: Basis, a: np.ndarray) -> np.ndarray:
        """A scalar dof array of ``basis`` at its quadrature points (nelems, nqp)."""
        out = np.zeros(basis.dx.shape)
        for k in range(basis.Nbfun):
            out += a[basis.element_dofs[k]][:, None] * np.asarray(basis.basis[k][0])
        return out

    def facet_basis(self, group: str) -> FacetBasis:
        if group not in self._facet_bases:
            self._group_dofs(group)  # validates the name
            self._facet_bases[group] = FacetBasis(self.mesh, self.basis.elem,
                                                  facets=self.mesh.boundaries[group])
        return self._facet_bases[group]

    def traction_load(self, tractions: dict) -> np.ndarray:
        """``{group: t}`` with t a constant vector or a callable ``t(x) -> (dim, ...)``
        [Pa], integrated over the facets of the group."""
        f = self.basis.zeros()
        for g, t in tractions.items():
            f += self.traction_form(t).assemble(self.facet_basis(g))
        return f

    def body_force_load(self, force) -> np.ndarray:
        return self.body_force_form(force).assemble(self.basis)

    def snap_to_surface(self, points, group: str = "top") -> np.ndarray:
        """Move points (n, dim) onto the nearest facet of ``group`` (projection on the facet
        plane, clipped into the facet), then a hair (1e-9 of the facet size) inside the
        element, so that point location accepts them."""
        from scipy.spatial import cKDTree

        P = np.atleast_2d(np.asarray(points, float))
        m = self.mesh
        facets = m.boundaries[group] if group in (m.boundaries or {}) else None
        if facets is None:
            self._group_dofs(group)  # raises the naming error
        fv = m.facets[:, facets]  # (nverts_per_facet, nf)
        cen = m.p[:, fv].mean(axis=1)  # (dim, nf)
        tree = cKDTree(cen.T)
        _, j = tree.query(P)
        out = np.empty_like(P)
        for i, (x, f) in enumerate(zip(P, j, strict=True)):
            V = m.p[:, fv[:, f]].T  # (k, dim)
            out[i] = _closest_on_facet(x, V)
        # nudge inside along the inward normal of the facet's element
        t = m.f2t[0, facets[j]]
        ec = m.p[:, m.t[:, t]].mean(axis=1).T
        d = ec - out
        size = np.linalg.norm(m.p[:, fv[0, j]] - m.p[:, fv[1, j]], axis=0)
        out += 1e-9 * size[:, None] * d / np.linalg.norm(d, axis=1)[:, None]
        return out

    def point_force_load(self, points, forces, snap: str | None = "top") -> np.ndarray:
        """Consistent nodal loads of point forces (n, dim) at ``points`` (n, dim): f = P^T F
        with P the probe (interpolation) matrix, so sum_nodes f_c = sum_points F_c exactly."""
        X = np.atleast_2d(np.asarray(points, float))
        F = np.atleast_2d(np.asarray(forces, float))
        if X.shape != F.shape or X.shape[1] != self.dim:
            raise ValueError(f"point forces: points {X.shape} and forces {F.shape} must both "
                             f"be (n, {self.dim})")
        if snap:
            X = self.snap_to_surface(X, snap)
        P = self.probe_matrix(X)
        return P.T @ F.T.ravel()

    def probe_matrix(self, points) -> sp.csr_matrix:
        """Interpolation matrix P (dim*n, ndofs), rows ordered [x-comps, y-comps, ...]."""
        X = np.atleast_2d(np.asarray(points, float)).T
        cells, pts = self._locate(X)
        b = self.basis
        n = X.shape[1]
        rows, cols, vals = [], [], []
        for k in range(b.Nbfun):
            v = np.asarray(b.elem.gbasis(b.mapping, pts, k, tind=cells)[0])[..., 0]  # (dim, n)
            for c in range(self.dim):
                nz = v[c] != 0
                rows.append(c * n + np.nonzero(nz)[0])
                cols.append(b.element_dofs[k, cells][nz])
                vals.append(v[c][nz])
        return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                     np.concatenate(cols))),
                             shape=(self.dim * n, b.N)).tocsr()

    def _locate(self, X: np.ndarray):
        """Element and reference coordinates of points X (dim, n); the last few answers for
        up to 4096 points kept (the coupling's probes are located twice per solve, at
        every solve)."""
        X = np.asarray(X, float)
        small = X.shape[1] <= 4096
        key = (X.shape, X.tobytes()) if small else None
        cache = self.__dict__.setdefault("_located", {})
        if key in cache:
            cells, pts = cache[key]
            return cells.copy(), pts.copy()
        cells, pts = self._find(X)
        if small:
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            cache[key] = (cells.copy(), pts.copy())
        return cells, pts

    def _find(self, X: np.ndarray):
        try:
            if isinstance(self.mesh, (MeshTet1, MeshTri1)):
                cells = _find_simplices(self.mesh, self.basis.mapping, X)
            else:
                cells = self.mesh.element_finder(mapping=self.basis.mapping)(*X)
        except ValueError:
            lo, hi = self.mesh.p.min(axis=1), self.mesh.p.max(axis=1)
            raise ValueError(f"probe: some of the {X.shape[1]} points are outside the mesh "
                             f"(bounding box {lo} .. {hi}); snap surface points first") from None
        pts = self.basis.mapping.invF(X[:, :, np.newaxis], tind=cells)
        return cells, pts

    # ------------------------------------------------------------------ solve
    def load_vector(self, dT_nodal=None, tractions=None, point_forces=None, body_force=None,
                    T_nodal=None, snap: str | None = "top", load=None):
        """(f, dT): the nodal load vector of :meth:`solve`'s loads and the temperature change
        as given (also the elastodynamic substrate's load, sphfem.fem.elastodynamic)."""
        dT_nodal = temperature_change(dT_nodal, T_nodal, self.T0)
        return self._assemble(dT_nodal, tractions, point_forces, body_force, snap,
                              load), dT_nodal

    def _assemble(self, dT, tractions, point_forces, body_force, snap, load) -> np.ndarray:
        """The nodal load vector f of a step's loads (:meth:`solve`)."""
        f = self.basis.zeros()
        if dT is not None:
            f += self.thermal_load(dT)
        if tractions:
            f += self.traction_load(tractions)
        if point_forces is not None:
            f += self.point_force_load(*point_forces, snap=snap)
        if body_force is not None:
            f += self.body_force_load(body_force)
        if load is not None:
            f += np.asarray(load, dtype=float)
        return f

    def _respond(self, f: np.ndarray, info: dict) -> np.ndarray:
        """u with K_II u_I = f_I, u_D = 0: back-substitution (direct) or CG warm-started
        from the previous solution (cg-amg; ``info["cg_iterations"]``)."""
        u = self.basis.zeros()
        if self.solver == "direct":
            u[self.I] = self._backsolve(f[self.I])
        else:
            from scipy.sparse.linalg import cg

            b = f[self.I]
            x0 = self._u_prev[self.I] if self._u_prev is not None else None
            its = [0]

            def count(_):
                its[0] += 1

            x, flag = cg(self._A, b, x0=x0, rtol=self.rtol, atol=0.0, maxiter=self.maxiter,
                         M=self._M, callback=count)
            if flag != 0:
                raise RuntimeError(f"CG did not converge in {self.maxiter} iterations "
                                   f"(rtol {self.rtol})")
            u[self.I] = x
            info["cg_iterations"] = its[0]
            self.cg_iterations.append(its[0])
        self._u_prev = u
        return u

    def _result(self, u, f, dT, info) -> FEMResult:
        return FEMResult(self, u, f, dT, info)

    # ------------------------------------------------------------------ projection
    def projection_rhs(self) -> sp.csr_matrix:
        """R (nvertices, nelems * nqp), assembled once: R s = int s phi_j dx for a field s
        given at the quadrature points of ``basis`` (flattened element-major)."""
        if self._mass is None:
            vb = self.vbasis
            self._mass = forms.mass.assemble(vb).tocsr()
            self._mass_diag = self._mass.diagonal()
            self._mass_factor = factorize(self._mass, "splu") if self.dim == 2 else None
            w = np.stack([np.asarray(vb.basis[k][0]) * vb.dx
                          for k in range(vb.Nbfun)])  # (nloc, nel, nqp)
            cols = np.broadcast_to(np.arange(w[0].size).reshape(w[0].shape), w.shape)
            rows = np.broadcast_to(vb.element_dofs[:, :, None], w.shape)
            self._projection_rhs = sp.csr_matrix((w.ravel(), (rows.ravel(), cols.ravel())),
                                                 shape=(vb.N, w[0].size))
        return self._projection_rhs

    def mass_solve(self, rhs: np.ndarray) -> np.ndarray:
        """M^-1 rhs, M the P1 vertex mass matrix (:meth:`project_tensor`)."""
        self.projection_rhs()
        if self._mass_factor is not None:
            return self._mass_factor.solve(rhs)
        return _block_pcg(self._mass, rhs, self._mass_diag, rtol=1e-12, maxiter=500)

    def project_tensor(self, Sq: np.ndarray) -> np.ndarray:
        """L2 projection of a (3, 3, nelems, nqp) quadrature field onto P1 vertex values,
        (nvertices, 3, 3): M x = R s for the 6 components at once, M the P1 mass matrix
        and R the matrix of the right-hand sides int s phi_j dx (both assembled once, R
        from the quadrature weights phi_j dx of every element's points); components that
        are zero at every quadrature point (the theta shears of an axisymmetric or
        plane-strain stress) are zero, not solved for.  2D: M factorised once (a planar
        graph's factor stays sparse); 3D: conjugate gradients (Jacobi preconditioned; M is
        well conditioned whatever the mesh size) to a relative residual of 1e-12 in every
        component."""
        vb = self.vbasis
        iu = np.triu_indices(3)
        comps = np.asarray(Sq)[iu].reshape(6, -1)  # (6, nelems * nqp)
        live = np.flatnonzero(np.any(comps != 0.0, axis=1))
        x = np.zeros((vb.N, 6))
        if live.size:
            x[:, live] = self.mass_solve(self.projection_rhs() @ comps[live].T)
        out = np.empty((vb.N, 3, 3))
        out[:, iu[0], iu[1]] = x
        out[:, iu[1], iu[0]] = x
        return out


def _block_pcg(A, B: np.ndarray, diag: np.ndarray, rtol: float, maxiter: int) -> np.ndarray:
    """Jacobi-preconditioned conjugate gradients for the SPD system A X = B, every column
    of B (n, m) at once (Hestenes & Stiefel 1952), each to ||r|| <= rtol ||b||; columns
    that have converged stop moving."""
    X = B / diag[:, None]
    R = B - A @ X
    Z = R / diag[:, None]
    P = Z.copy()
    rz = np.einsum("ij,ij->j", R, Z)
    tol = rtol * np.linalg.norm(B, axis=0)
    for _ in range(maxiter):
        active = np.linalg.norm(R, axis=0) > tol
        if not active.any():
            return X
        AP = A @ P
        pap = np.einsum("ij,ij->j", P, AP)
        alpha = np.where(active, rz / np.where(active, pap, 1.0), 0.0)
        X += alpha * P
        R -= alpha * AP
        Z = R / diag[:, None]
        rz_new = np.einsum("ij,ij->j", R, Z)
        beta = np.where(active, rz_new / np.where(active, rz, 1.0), 0.0)
        P = Z + beta * P
        rz = rz_new
    raise RuntimeError(f"stress projection: CG did not reach {rtol} in {maxiter} iterations")


#: entries (points x candidate elements) per block of :func:`_find_simplices`
_FIND_BLOCK = 1 << 21


def _find_simplices(mesh, mapping, X: np.ndarray) -> np.ndarray:
    """The element holding each point of X (dim, n) on a simplex mesh, in bounded memory.

    First pass: each point is mapped into its own k nearest elements by centroid (k = 10 in
    3D, 5 in 2D, scikit-fem's ``element_finder`` candidates) through the cached affine
    inverse maps, xi = J^-1 (x - p0), and keeps the nearest one that holds it (reference
    coordinates >= -eps, barycentric sum <= 1 + dim eps, scikit-fem's test): k maps per
    point.  scikit-fem's finder maps *every* point into the union of *all* points'
    candidates (3 x |union| x n reference coordinates: the 32,000 sensor points of the
    droplet job against ~6,000 candidates cost a minute in blocks).  Points no candidate
    holds are searched over every element in blocks of about ``_FIND_BLOCK`` / n elements.
    A point inside one element gets scikit-fem's element; a point on a face shared by two
    elements (to within round-off) may get the other one: either holds it, and interpolated
    values then differ by round-off.
    """
    from scipy.spatial import cKDTree

    from sphfem.fem.assembly import _inv_det, affine_jacobians

    dim, n = X.shape
    nelems = mesh.t.shape[1]
    if not hasattr(mesh, "_cached_tree"):  # the tree scikit-fem's finder caches too
        mesh._cached_tree = cKDTree(np.mean(mesh.p[:, mesh.t], axis=1).T)
    if not hasattr(mesh, "_cached_inverse_maps"):
        invJ, _ = _inv_det(affine_jacobians(mesh))
        mesh._cached_inverse_maps = (invJ, np.ascontiguousarray(mesh.p[:, mesh.t[0]].T))
    invJ, p0 = mesh._cached_inverse_maps
    k = min(10 if dim == 3 else 5, nelems)
    cand = mesh._cached_tree.query(X.T, k)[1].reshape(n, k)
    eps = np.finfo(np.float64).eps
    found = np.full(n, -1, dtype=np.int64)
    chunk = max(1, _FIND_BLOCK // (k * dim))
    for s0 in range(0, n, chunk):
        c = cand[s0:s0 + chunk]  # (m, k)
        d = X[:, s0:s0 + chunk].T[:, None, :] - p0[c]  # (m, k, dim)
        R = np.einsum("mkij,mkj->mki", invJ[c], d)
        inside = (R >= -eps).all(axis=-1) & (1 - R.sum(axis=-1) >= -dim * eps)
        hit = inside.any(axis=1)
        found[s0:s0 + chunk][hit] = c[hit, inside[hit].argmax(axis=1)]
    todo = np.flatnonzero(found < 0)
    block = max(1, _FIND_BLOCK // max(todo.size, 1))
    for b0 in range(0, nelems, block):
        if todo.size == 0:
            return found
        el = np.arange(b0, min(b0 + block, nelems))
        R = mapping.invF(X[:, None, todo], el)  # (dim, block, len(todo))
        rest = 1 - R.sum(axis=0)
        inside = (R >= -eps).all(axis=0) & (rest >= -dim * eps)
        hit = inside.any(axis=0)
        found[todo[hit]] = el[inside[:, hit].argmax(axis=0)]
        todo = todo[~hit]
    if todo.size == 0:
        return found
    raise ValueError("Point is outside of the mesh.")


def _closest_on_facet(x: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Closest point to x on a simplex facet with vertices V (k, dim); a quadrilateral
    facet (hex mesh) is treated as planar and axis-aligned (the recipes' box faces):
    projection on its plane, clipped to its bounding box."""
    if len(V) == 4 and V.shape[1] == 3:
        v0 = V[0]
        A = (V[1:3] - v0).T
        lam, *_ = np.linalg.lstsq(A, x - v0, rcond=None)
        return np.clip(v0 + A @ lam, V.min(axis=0), V.max(axis=0))
    return _closest_on_simplex(x, V)


def _closest_on_simplex(x, V):
    v0 = V[0]
    A = (V[1:] - v0).T  # (dim, k-1)
    lam, *_ = np.linalg.lstsq(A, x - v0, rcond=None)
    bary = np.concatenate([[1 - lam.sum()], lam])
    if (bary >= 0).all():
        return v0 + A @ lam
    # outside: clip to the best edge/vertex (small facets: brute force over sub-simplices)
    best, bd = None, np.inf
    k = len(V)
    for i in range(k):
        for j in range(i + 1, k):
            e = V[j] - V[i]
            s = np.clip(np.dot(x - V[i], e) / np.dot(e, e), 0.0, 1.0)
            q = V[i] + s * e
            d = np.linalg.norm(q - x)
            if d < bd:
                best, bd = q, d
    return best


def _import_pyamg():
    try:
        import pyamg
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("solver='cg-amg' needs pyamg (pip install pyamg); "
                          "or use solver='direct'") from e
    return pyamg
