"""Axisymmetric quasi-static linear thermo-elasticity in the (r, z) half-plane, r >= 0.

A body of revolution under loads of revolution (a normal droplet impact) has displacements
``u = u_r(r, z) e_r + u_z(r, z) e_z`` and four strains (Zienkiewicz & Taylor, *The Finite
Element Method*, vol. 1, ch. "Axisymmetric stress analysis"; Timoshenko & Goodier,
*Theory of Elasticity*, sec. 131)::

    e_rr = du_r/dr,  e_zz = du_z/dz,  e_tt = u_r / r  (hoop),  e_rz = (du_r/dz + du_z/dr)/2

    sigma = lam tr(e) I + 2 mu e - (3 lam + 2 mu) alpha (T - T0) I,  tr(e) = e_rr + e_zz + e_tt

The weak form is written **per radian** (the 3D integrals divided by 2 pi)::

    int [lam tr(e(u)) tr(e(v)) + 2 mu e(u) : e(v)] r dr dz
        = int (3 lam + 2 mu) alpha dT tr(e(v)) r dr dz + int t . v r ds + int f . v r dr dz
          + sum_p F_p . v(X_p) / (2 pi)

so the stiffness ``K``, the load vector and the reactions at nodes are per radian.

Point-force convention.  A point ``X_p = (r_p, z_p)`` of the half-plane is a ring of radius
r_p.  ``point_forces`` take, by default (``force_convention="ring"``), the **total force of
the ring** F [N]: a ring load of f [N/m] along the circumference is the ring force
F = 2 pi r_p f, and its axial component is the true net force on the body.  With
``force_convention="radian"`` the forces are per radian [N/rad] = F / (2 pi); with
``"line"`` they are the line density f [N/m] (an axisymmetric SPH particle's planar mass
times its acceleration), per radian r_p f.  Tractions [Pa] and body forces [N/m^3] are the
3D fields, without convention.  ``reaction`` returns ring totals (2 pi times the per-radian
sums).

Stress tensors are 3 x 3 in the order **(r, z, theta)**: ``S[0, 0] = sigma_rr``,
``S[1, 1] = sigma_zz``, ``S[2, 2] = sigma_tt`` (hoop), ``S[0, 1] = S[1, 0] = sigma_rz``,
the theta-shear components zero -- the layout of the plane-strain substrate with the
out-of-plane axis third, so :func:`sphfem.fem.forms.von_mises` uses all four components.

The axis is found geometrically (boundary facets with r = 0), named ``"axis"`` and carries
``u_r = 0`` (symmetry).  Other edges take ``clamps`` and ``rollers`` ({group: "r" | "z" |
"rz"}) by gmsh physical-group name, as :class:`sphfem.fem.FEMSubstrate`.  The only rigid
motion left by the axis condition is a z translation; with nothing else holding z, one
vertex is pinned in z (``pin_rigid``).  ``K`` is assembled and factorised once.

>>> mesh = substrate_rz(radius=1e-3, depth=0.26e-3, h_fine=2e-6, h_coarse=50e-6)
>>> sub = AxisymmetricFEMSubstrate(mesh, E=300e9, nu=0.21, alpha=7e-6, clamps=["bottom"])
>>> res = sub.solve(tractions={"top": p_of_x}, dT_nodal=dT)
>>> res.probe([[0.0, -1e-6]])["von_mises"], res.peak_von_mises()
"""

from __future__ import annotations

import logging

import numpy as np
from skfem import BilinearForm, LinearForm, MeshQuad1, MeshTri1

from sphfem.fem import forms
from sphfem.fem.substrate import FEMResult, FEMSubstrate

logger = logging.getLogger(__name__)

__all__ = ["AxisymmetricFEMSubstrate", "AxisymmetricResult", "axisymmetric_elasticity",
           "axisymmetric_thermal_load", "axisymmetric_thermal_coupling",
           "axisymmetric_traction_load",
           "axisymmetric_body_force_load", "axisymmetric_stress", "graded_tensor_rz",
           "substrate_rz", "per_radian", "FORCE_CONVENTIONS"]

TWO_PI = 2.0 * np.pi
_COMPONENTS_RZ = {"r": 0, "z": 1}
FORCE_CONVENTIONS = ("ring", "radian", "line")


def per_radian(points, forces, convention: str) -> np.ndarray:
    """Point forces (n, 2) at (r, z) points (n, 2) given per ``convention`` as forces per
    radian: ring totals F / (2 pi), per radian as given, line densities r f."""
    F = np.atleast_2d(np.asarray(forces, float))
    if convention == "ring":
        return F / TWO_PI
    if convention == "radian":
        return F
    if convention == "line":
        r = np.atleast_2d(np.asarray(points, float))[:, 0]
        return F * np.maximum(r, 0.0)[:, None]
    raise ValueError(f"force_convention must be one of {FORCE_CONVENTIONS}, got "
                     f"{convention!r}")


# ----------------------------------------------------------------------------- forms
def _strains(u, r):
    """(e_rr, e_zz, e_tt, e_rz) of a vector DiscreteField ``u`` = (u_r, u_z) at radii r."""
    g = u.grad
    return g[0, 0], g[1, 1], u[0] / r, 0.5 * (g[0, 1] + g[1, 0])


def axisymmetric_elasticity(lam: float, mu: float) -> BilinearForm:
    """Per-radian stiffness ``int [lam tr e(u) tr e(v) + 2 mu e(u):e(v)] r dr dz`` with the
    hoop strain e_tt = u_r / r (Zienkiewicz & Taylor vol. 1, axisymmetric B matrix)."""

    @BilinearForm
    def form(u, v, w):
        r = w.x[0]
        a = _strains(u, r)
        b = _strains(v, r)
        tra, trb = a[0] + a[1] + a[2], b[0] + b[1] + b[2]
        eab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * a[3] * b[3]
        return (lam * tra * trb + 2.0 * mu * eab) * r

    return form


def axisymmetric_thermal_load(lam: float, mu: float, alpha: float) -> LinearForm:
    """``int (3 lam + 2 mu) alpha dT (e_rr + e_zz + e_tt)(v) r dr dz`` (per radian), dT at
    quadrature points passed as ``.assemble(basis, dT=...)``."""
    beta = forms.thermal_modulus(lam, mu) * alpha

    @LinearForm
    def form(v, w):
        r = w.x[0]
        return beta * w.dT * ((v.grad[0, 0] + v.grad[1, 1]) * r + v[0])

    return form


def axisymmetric_thermal_coupling(lam: float, mu: float, alpha: float) -> BilinearForm:
    """The thermal load of :func:`axisymmetric_thermal_load` as a bilinear form of the
    temperature change (trial function u, a scalar basis) and the displacement test
    function v: ``int (3 lam + 2 mu) alpha u (e_rr + e_zz + e_tt)(v) r dr dz``.  Assembled
    with ``assemble(scalar_basis, vector_basis)`` it is the matrix B of f = B dT for
    nodal dT (the same integral as the linear form with dT interpolated at the
    quadrature points; only the summation order differs)."""
    beta = forms.thermal_modulus(lam, mu) * alpha

    @BilinearForm
    def form(u, v, w):
        r = w.x[0]
        return beta * u * ((v.grad[0, 0] + v.grad[1, 1]) * r + v[0])

    return form


def _vector_field(spec, x):
    if callable(spec):
        return np.asarray(spec(x)) + 0.0 * x
    s = np.asarray(spec, float)
    return s.reshape((-1,) + (1,) * (x.ndim - 1)) + 0.0 * x


def axisymmetric_traction_load(traction) -> LinearForm:
    """``int t . v r ds`` (per radian) on a FacetBasis; ``traction`` a constant (t_r, t_z)
    [Pa] or a callable ``t(x) -> (2, ...)`` of the (r, z) quadrature points."""

    @LinearForm
    def form(v, w):
        t = _vector_field(traction, w.x)
        return (t[0] * v[0] + t[1] * v[1]) * w.x[0]

    return form


def axisymmetric_body_force_load(force) -> LinearForm:
    """``int f . v r dr dz`` (per radian); ``force`` constant (f_r, f_z) [N/m^3] or a
    callable of x."""

    @LinearForm
    def form(v, w):
        f = _vector_field(force, w.x)
        return (f[0] * v[0] + f[1] * v[1]) * w.x[0]

    return form


def axisymmetric_stress(lam: float, mu: float, alpha: float, grad_u, u_r, r, dT,
                        r_axis: float = 0.0):
    """Cauchy stress (3, 3, ...) in the order (r, z, theta) from the displacement gradient
    (2, 2, ...), u_r (...), the radius r (...) and dT (...).  On the axis (r <= r_axis) the
    hoop strain u_r / r is its limit du_r/dr."""
    g = np.asarray(grad_u)
    r = np.asarray(r, float)
    on_axis = r <= r_axis
    ett = np.where(on_axis, g[0, 0], np.asarray(u_r) / np.where(on_axis, 1.0, r))
    err, ezz, erz = g[0, 0], g[1, 1], 0.5 * (g[0, 1] + g[1, 0])
    iso = lam * (err + ezz + ett) - forms.thermal_modulus(lam, mu) * alpha * np.asarray(dT)
    S = np.zeros((3, 3) + np.broadcast(err, iso).shape)
    S[0, 0] = iso + 2.0 * mu * err
    S[1, 1] = iso + 2.0 * mu * ezz
    S[2, 2] = iso + 2.0 * mu * ett
    S[0, 1] = S[1, 0] = 2.0 * mu * erz
    return S


# ----------------------------------------------------------------------------- mesh
def substrate_rz(path=None, radius=1e-3, depth=0.26e-3, h_fine=20e-6, h_coarse=150e-6,
                 refine_radius=None, growth=1.3, order=1, element="tri", refine_center=None):
    """Graded gmsh mesh of the (r, z) section [0, radius] x [-depth, 0] of a cylindrical
    substrate, refined to ``h_fine`` within ``refine_radius`` (default 10 h_fine) of the
    impact point (0, 0) (:func:`sphfem.fem.meshing.substrate_rect`, cached).  Groups:
    "left" (the axis r = 0; the substrate adds the alias "axis"), "right" (r = radius),
    "bottom", "top"."""
    from sphfem.fem.meshing import substrate_rect

    refine_radius = 10.0 * h_fine if refine_radius is None else refine_radius
    center = (0.0, 0.0) if refine_center is None else tuple(refine_center)
    return substrate_rect(path, size=(radius, depth), h_fine=h_fine, h_coarse=h_coarse,
                          refine_center=center, refine_radius=refine_radius, order=order,
                          element=element, origin=(0.0, -depth), growth=growth)


def graded_tensor_rz(radius: float, depth: float, h_fine: float, fine_extent: float,
                     growth: float = 1.2, element: str = "quad"):
    """Structured (r, z) mesh of [0, radius] x [-depth, 0] without gmsh: spacing exactly
    ``h_fine`` for r, |z| <= ``fine_extent`` (so a load patch whose radius is a multiple of
    h_fine ends on a node), then growing by ``growth`` per cell.  ``element`` "quad" or
    "tri"; boundaries "left" (the axis), "right", "bottom", "top"."""
    from skfem import MeshQuad, MeshTri

    if not 0 < h_fine <= fine_extent or growth < 1.0:
        raise ValueError("graded_tensor_rz: need 0 < h_fine <= fine_extent and growth >= 1")

    def axis(total):
        n = int(round(min(fine_extent, total) / h_fine))
        x, step = list(h_fine * np.arange(n + 1)), h_fine
        while x[-1] < total * (1 - 1e-12):
            step *= growth
            x.append(min(x[-1] + step, total))
        if len(x) > n + 2 and x[-1] - x[-2] < 0.5 * (x[-2] - x[-3]):
            del x[-2]  # merge a sliver last cell into its neighbour
        x[-1] = total
        return np.array(x)

    mesh_type = {"quad": MeshQuad, "tri": MeshTri}[element]
    return mesh_type.init_tensor(axis(radius), -axis(depth)[::-1]).with_defaults()


def _rz_components(spec) -> list[int]:
    """'r' | 'z' | 'rz' | 0 | [0, 1] -> sorted component indices of (u_r, u_z)."""
    items = [spec] if isinstance(spec, (int, np.integer, str)) else list(spec)
    out = []
    for it in items:
        if isinstance(it, str):
            out += [_COMPONENTS_RZ.get(c, -1) for c in it.lower()]
        else:
            out.append(int(it))
    if not out or any(c not in (0, 1) for c in out):
        raise ValueError(f"roller components {spec!r}: use 'r', 'z' or 'rz' (or 0, 1)")
    return sorted(set(out))


# ----------------------------------------------------------------------------- result
class AxisymmetricResult(FEMResult):
    """One axisymmetric solve; the :class:`sphfem.fem.FEMResult` interface with the hoop
    strain in every stress, r-weighted element averages and ring-total reactions."""

    @property
    def stress_qp(self) -> np.ndarray:
        """Cauchy stress (3, 3, nelems, nqp) in the order (r, z, theta)."""
        if "stress_qp" not in self.__dict__:
            s = self.substrate
            self.__dict__["stress_qp"] = axisymmetric_stress(
                s.lam, s.mu, s.alpha, s.grad_qp(self.dofs), s.values_qp(self.dofs)[0],
                s.r_qp, s._dT_qp(self.dT_spec))
        return self.__dict__["stress_qp"]

    @property
    def stress_nodes(self) -> np.ndarray:
        """Cauchy stress L2-projected onto the P1 vertex field, (nvertices, 3, 3) (cached):
        by the substrate's linear maps of (u, dT) (:meth:`AxisymmetricFEMSubstrate.
        linear_stress`) when dT is None or a vertex array, else from :attr:`stress_qp`."""
        if "stress_nodes" not in self.__dict__:
            S = self.substrate.linear_stress(self.dofs, self.dT_spec, "nodes")
            self.__dict__["stress_nodes"] = (S if S is not None else
                                             self.substrate.project_tensor(self.stress_qp))
        return self.__dict__["stress_nodes"]

    @property
    def stress_elem(self) -> np.ndarray:
        """Volume average (weight r dr dz) of the stress per element, (nelems, 3, 3)
        (cached; by the linear maps as :attr:`stress_nodes`)."""
        if "stress_elem" not in self.__dict__:
            S = self.substrate.linear_stress(self.dofs, self.dT_spec, "elements")
            if S is not None:
                self.__dict__["stress_elem"] = S
                return S
            # per component of the upper triangle that is not zero everywhere (the theta
            # shears are), mirrored: the same sums as over the whole (3, 3) field
            w = self.substrate.rdx
            ws = w.sum(axis=-1)
            S, out = self.stress_qp, np.zeros((3, 3, w.shape[0]))
            for i, j in zip(*np.triu_indices(3), strict=True):
                if np.any(S[i, j]):
                    out[i, j] = out[j, i] = (S[i, j] * w).sum(axis=-1) / ws
            self.__dict__["stress_elem"] = np.moveaxis(out, -1, 0)
        return self.__dict__["stress_elem"]

    @property
    def von_mises_elem(self) -> np.ndarray:
        w = self.substrate.rdx
        return (forms.von_mises(self.stress_qp) * w).sum(axis=-1) / w.sum(axis=-1)

    def peak_von_mises(self) -> tuple[float, np.ndarray]:
        """Largest nodal von Mises stress [Pa] and its vertex (r, z)."""
        vm = self.von_mises_nodes
        i = int(np.argmax(vm))
        return float(vm[i]), self.substrate.mesh.p[:, i].copy()

    def reaction(self, group: str) -> np.ndarray:
        """Ring-total reaction (2,) [N] on the dofs of ``group``: 2 pi times the per-radian
        nodal sums; the z component is the net axial force on the body."""
        return TWO_PI * super().reaction(group)

    def _stress_at(self, grad, u, X, dT) -> np.ndarray:
        """Stress (3, 3, n) in (r, z, theta) order at the (r, z) points X of ``probe``
        (on the axis e_tt = du_r/dr)."""
        s = self.substrate
        return axisymmetric_stress(s.lam, s.mu, s.alpha, grad, u[0], X[0], dT, s._r_axis)


# ----------------------------------------------------------------------------- substrate
class AxisymmetricFEMSubstrate(FEMSubstrate):
    """Axisymmetric linear thermo-elastic quasi-static substrate in the (r, z) half-plane;
    K (per radian) assembled and factorised once.

    Parameters as :class:`sphfem.fem.FEMSubstrate`, except:

    mesh : a 2D mesh (triangles or quadrilaterals; path or scikit-fem mesh) with x[0] = r
        >= 0 and x[1] = z, e.g. :func:`substrate_rz`.
    rollers : ``{group: "r" | "z" | "rz"}``.
    force_convention : "ring" (point forces are ring totals [N], = 2 pi r f for a line load
        f [N/m]), "radian" (forces per radian [N/rad]) or "line" (line densities f [N/m]).
    intorder : quadrature order of the cells (default 2p + 1 for P_p: the r-weighted
        gradient terms exactly, the rational hoop term u_r v_r / r to high order).
    solver : "direct" only (a 2D problem; sparse Cholesky / LU, factorised once).

    Attributes ``r_qp`` (nelems, nqp): the radius at the quadrature points of ``basis``;
    ``rdx``: the per-radian volume weights r dx there (for r-weighted norms and averages).
    """

    solvers = ("direct",)
    stiffness_form = staticmethod(axisymmetric_elasticity)
    thermal_form = staticmethod(axisymmetric_thermal_load)
    traction_form = staticmethod(axisymmetric_traction_load)
    body_force_form = staticmethod(axisymmetric_body_force_load)

    def __init__(self, mesh, E: float, nu: float, alpha: float, T0: float = 293.15,
                 element: str = "P1", clamps=(), rollers=None, solver: str = "direct",
                 pin_rigid: bool | None = None, force_convention: str = "ring",
                 intorder: int | None = None, nthreads: int | None = None,
                 direct_backend: str = "auto"):
        if force_convention not in FORCE_CONVENTIONS:
            raise ValueError(f"force_convention must be one of {FORCE_CONVENTIONS}, got "
                             f"{force_convention!r}")
        self.force_convention = force_convention
        if intorder is None and element in ("P1", "P2"):
            intorder = 2 * int(element[1]) + 1
        super().__init__(mesh, E, nu, alpha, T0=T0, element=element, clamps=clamps,
                         rollers=rollers, solver=solver, pin_rigid=pin_rigid,
                         nthreads=nthreads, direct_backend=direct_backend, intorder=intorder)
        self._thermal_matrices: dict = {}  # thermal_load's B per dT basis
        self._stress_map_cache: dict = {}  # linear_stress's maps per "nodes" / "elements"
        self.r_qp = self.basis.global_coordinates()[0]  # (nelems, nqp)
        self.rdx = self.r_qp * self.basis.dx  # r-weighted quadrature weights

    # ------------------------------------------------------------------ geometry hooks
    def _prepare_mesh(self, mesh):
        """A 2D (r, z) mesh with r >= 0, its facets on the axis named "axis"."""
        if not isinstance(mesh, (MeshTri1, MeshQuad1)):
            raise ValueError(f"axisymmetric substrate: need a 2D (r, z) mesh of triangles or "
                             f"quadrilaterals, got {type(mesh).__name__}")
        span = float(np.ptp(mesh.p, axis=1).max())
        self._r_axis = 1e-12 * span
        if mesh.p[0].min() < -self._r_axis:
            raise ValueError(f"axisymmetric substrate: the mesh reaches r = "
                             f"{mesh.p[0].min():.3g} < 0; x[0] is the radius (r >= 0)")
        return self._with_axis(mesh)

    def _roller_components(self, spec) -> list[int]:
        return _rz_components(spec)

    def _symmetry_dofs(self) -> list[np.ndarray]:
        """The axis carries u_r = 0."""
        if "axis" not in self.mesh.boundaries:
            return []
        return [np.intersect1d(self._group_dofs("axis"), self.component_dofs[0])]

    def _free_to_move(self, clamps, held: set) -> bool:
        """The axis leaves one rigid motion, a z translation: free unless z is held."""
        return not clamps and 1 not in held

    # ------------------------------------------------------------------ set-up
    def _with_axis(self, mesh):
        """The mesh with its boundary facets on r = 0 named "axis" (none: no axis)."""
        bf = mesh.boundary_facets()
        on = np.all(mesh.p[0, mesh.facets[:, bf]] <= self._r_axis, axis=0)
        bounds = dict(mesh.boundaries or {})
        if on.any():
            bounds["axis"] = bf[on]
        elif "axis" in bounds:
            raise ValueError("axisymmetric substrate: the mesh's group 'axis' is not on r = 0")
        return mesh.with_boundaries(bounds) if bounds else mesh

    def _rigid_pins(self) -> np.ndarray:
        """The one rigid motion of an axisymmetric body, a z translation: pin u_z at the
        vertex of least z (ties: least r), statically determinate."""
        p = self.mesh.p
        a = int(np.lexsort((p[0], p[1]))[0])
        return np.asarray([self.basis.nodal_dofs[1, a]], dtype=np.int64)

    @property
    def cell_volume(self) -> np.ndarray:
        """Volumes of the rings swept by the cells, 2 pi int r dr dz, (nelems,) [m^3]."""
        return TWO_PI * self.rdx.sum(axis=-1)

    # ------------------------------------------------------------------ stress maps
    #: the stress components that are not zero, (r, r), (z, z), (theta, theta), (r, z)
    _LIVE = ((0, 0), (1, 1), (2, 2), (0, 1))

    def linear_stress(self, dofs, dT, where: str):
        """The stress of a solve as linear maps of its displacement dofs u and vertex
        temperature change dT, built once (:meth:`_stress_maps`): ``where`` = "nodes", the
        L2 projection onto the vertices M^-1 (R L_c u - beta R Phi dT), or "elements", the
        r-weighted element averages (A L_c u - beta A Phi dT), each (n, 3, 3) in the order
        (r, z, theta).  L_c maps u to the stress component c at the quadrature points (the
        strains e_rr, e_zz, e_tt = u_r / r, e_rz of :func:`axisymmetric_stress`), Phi the
        vertex values to dT there, R the projection's right-hand sides, A the averaging
        weights r dx / sum r dx; the same sums as from :attr:`AxisymmetricResult.stress_qp`
        in another order (round-off).  None when dT is neither None nor a vertex array."""
        if dT is not None and (callable(dT) or np.shape(dT) != (self.mesh.nvertices,)):
            return None
        ops = self._stress_maps(where)
        dofs = np.asarray(dofs, float)
        vals = [Lu @ dofs for Lu in ops[0]]
        if dT is not None:
            t = ops[1] @ np.asarray(dT, float)
            for c in range(3):  # -(3 lam + 2 mu) alpha dT on the diagonal
                vals[c] = vals[c] - t
        X = np.column_stack(vals)
        if where == "nodes":
            X = self.mass_solve(X)
        out = np.zeros((X.shape[0], 3, 3))
        for k, (i, j) in enumerate(self._LIVE):
            out[:, i, j] = out[:, j, i] = X[:, k]
        return out

    def _stress_maps(self, where: str):
        """([Q L_c for c in _LIVE], beta Q Phi) with Q = R (nodes) or A (elements)."""
        maps = self._stress_map_cache
        if where in maps:
            return maps[where]
        import scipy.sparse as sp

        G, _, edofs = self._qp_tables()  # (nloc, 2, nel, nqp), (nloc, 2, nel)
        if self._phi is None:
            self.values_qp(np.zeros(self.basis.N))  # fills the basis values table
        phi = self._phi  # (nloc, nel, nqp)
        nloc, _, nel, nqp = G.shape
        rows = np.broadcast_to(np.arange(nel * nqp).reshape(nel, nqp), (nloc, nel, nqp))
        shape = (nel * nqp, self.basis.N)

        def op(parts):
            """Sum over (component c, values (nloc, nel, nqp)) of the map u -> sum_a
            u_(a, c) values[a] at every quadrature point."""
            r, c, v = [], [], []
            for comp, val in parts:
                r.append(rows.ravel())
                c.append(np.broadcast_to(edofs[:, comp, :, None], val.shape).ravel())
                v.append(val.ravel())
            return sp.csr_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                                 shape=shape)

        err, ezz = op([(0, G[:, 0])]), op([(1, G[:, 1])])
        ett = op([(0, phi / self.r_qp)])
        erz = op([(0, 0.5 * G[:, 1]), (1, 0.5 * G[:, 0])])
        lam, mu = self.lam, self.mu
        L = [(lam + 2 * mu) * err + lam * (ezz + ett), (lam + 2 * mu) * ezz + lam * (err + ett),
             (lam + 2 * mu) * ett + lam * (err + ezz), 2 * mu * erz]
        vb = self.vbasis
        vphi = np.stack([np.asarray(vb.basis[k][0]) for k in range(vb.Nbfun)])
        vrows = np.broadcast_to(np.arange(nel * nqp).reshape(nel, nqp), vphi.shape)
        vcols = np.broadcast_to(vb.element_dofs[:, :, None], vphi.shape)
        Phi = sp.csr_matrix((vphi.ravel(), (vrows.ravel(), vcols.ravel())),
                            shape=(nel * nqp, vb.N))
        if where == "nodes":
            Q = self.projection_rhs()
        else:
            w = self.rdx / self.rdx.sum(axis=-1, keepdims=True)
            Q = sp.csr_matrix((w.ravel(), (np.repeat(np.arange(nel), nqp),
                                           np.arange(nel * nqp))), shape=(nel, nel * nqp))
        beta = forms.thermal_modulus(lam, mu) * self.alpha
        maps[where] = ([(Q @ Lc).tocsr() for Lc in L], (beta * (Q @ Phi)).tocsr())
        return maps[where]

    # ------------------------------------------------------------------ loads
    def thermal_load(self, dT) -> np.ndarray:
        """Per-radian load vector of the thermal strain (:func:`axisymmetric_thermal_load`).
        A vertex or scalar-dof array dT: f = B dT with B the matrix of
        :func:`axisymmetric_thermal_coupling` on that basis, assembled once (one sparse
        product per coupling step instead of a scikit-fem assembly: 21 ms -> < 1 ms on the
        droplet job's 19k-dof mesh); a scalar or callable dT: the linear form."""
        a = None if callable(dT) else np.asarray(dT, float)
        if a is None or a.ndim != 1:
            return super().thermal_load(dT)
        if a.shape == (self.mesh.nvertices,):
            kind, basis = "vertices", self.vbasis
        elif a.shape == (self.sbasis.N,):
            kind, basis = "scalar", self.sbasis
        else:
            return super().thermal_load(dT)  # raises the shape error
        B = self._thermal_matrices.get(kind)
        if B is None:
            form = axisymmetric_thermal_coupling(self.lam, self.mu, self.alpha)
            B = self._thermal_matrices[kind] = form.assemble(basis, self.basis).tocsr()
        return B @ a

    def point_force_load(self, points, forces, snap: str | None = "top") -> np.ndarray:
        """Per-radian nodal loads f = P^T F_rad of point forces (n, 2) at points (n, 2) =
        (r, z), F_rad the forces per radian (:func:`per_radian` of ``force_convention``):
        sum_nodes f_c = sum_points F_rad,c exactly."""
        return super().point_force_load(
            points, per_radian(points, forces, self.force_convention), snap=snap)

    def _result(self, u, f, dT, info) -> AxisymmetricResult:
        return AxisymmetricResult(self, u, f, dT, info)
