"""Transient heat conduction in the substrate with scikit-fem: rho c dT/dt = div(k grad T).

Weak form (Galerkin, Lagrange elements, homogeneous material)::

    M dT/dt + K T = F,   M_ab = int rho c N_a N_b dV,   K_ab = int k grad N_a . grad N_b dV

(M lumped to its row sums by default, see :class:`TransientHeat`)

with dV = dx dy (dz) on planar 2D / 3D meshes and dV = 2 pi r dr dz on axisymmetric
(r, z) meshes (x[0] = r >= 0; the r-weighted forms, e.g. Zienkiewicz & Taylor, *The
Finite Element Method* vol. 1, sec. 9.2; the 2 pi makes every figure that of the whole
ring: energy in J, power in W).  F is the heat entering through the flux group (the
coupled surface) as nodal powers [W]; every other boundary is insulated unless named in
``dirichlet`` (fixed temperature).

Time stepping (theta method, theta = 1 backward Euler, 1/2 Crank-Nicolson)::

    (M/dt + theta K + H0) T^{n+1} = (M/dt - (1 - theta) K + H0) T^n + P + H (T_ext - T^n)   (1)

P are prescribed nodal powers (explicit), H = diag(h_a A_a) [W/K] an exchange with an
external temperature T_ext at the surface nodes (a Robin condition), and H0 the exchange
conductance built into the factorised matrix.  The heat the surface takes in during the
step is

    F = P + H (T_ext - T^n) - H0 (T^{n+1} - T^n)                                      (2)

so with H0 = H the exchange is implicit (backward Euler in T) and with H0 = 0 explicit;
for H <= H0 + C/dt (C the node's heat capacity) the update of an isolated node is
monotone (T never overshoots T_ext).  Against the implicit update, an isolated node's
increment is off by the factor (C/dt + H)/(C/dt + H0), so the lag is bounded by
|H - H0| / (C/dt + H0).  The matrix of (1) is symmetric positive definite and is
factorised once per (theta, dt, H0) and re-used: by a banded Cholesky factorisation
(LAPACK dpbtrf) in the reverse Cuthill-McKee order when that order's half-bandwidth is at
most ``BAND_MAX`` (the tensor grids of :func:`graded_mesh` in 2D: the depth's node count,
~20; n w^2 flops; the bands of M and K are taken once, so a new (theta, dt, H0) costs a
band sum and dpbtrf: 3.6-5.6 CPU-ms per step against 20 with SuperLU on the droplet
job's 8.5k-node heat mesh, w = 22), or else by SuperLU (symmetric-mode minimum-degree
ordering);
:class:`TransientHeat` sets H0 = H (a new factorisation) only when some node has
|H - H0| > ``robin_tol`` (C/dt + H0), or H = 0 < H0 (a node that stopped exchanging
must take in nothing), see :meth:`step`.

Conservation: K 1 = 0 (constants lie in the kernel of the conduction form) and K is
symmetric, so with no Dirichlet nodes 1^T M (T^{n+1} - T^n) = dt 1^T F exactly: the
energy E = 1^T M T gains sum(F) dt per step to round-off (the ``energy`` ledger).  With
fixed-temperature nodes the heat through them (the reaction) is booked separately.

The surface weights A_a = int N_a dS (2 pi r dS axisymmetric) turn a flux density
q [W/m^2] given per surface node into nodal powers P_a = q_a A_a (lumped, conservative:
sum_a P_a dt is the energy) or P = S q (consistent: S_ab = int N_a N_b dS).

Graded meshes: :func:`graded_coordinates` (geometric growth from a sub-um first cell at
the surface) and :func:`graded_mesh` (tensor-product quads / hexes, planar or
axisymmetric) resolve the thermal layer sqrt(alpha t) well below the particle spacing.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from skfem import Basis, BilinearForm, FacetBasis, LinearForm
from skfem.helpers import dot, grad

logger = logging.getLogger(__name__)

__all__ = ["graded_coordinates", "graded_mesh", "TransientHeat", "ierfc",
           "semi_infinite_flux", "semi_infinite_step"]


# ----------------------------------------------------------------------------- meshes


def graded_coordinates(depth: float, h_surface: float, growth: float = 1.2,
                       h_max: float | None = None) -> np.ndarray:
    """Node depths 0 = z_0 < z_1 < ... < z_n = ``depth`` with cells h_surface * growth^i
    (capped at ``h_max``); the last cell is stretched or merged so that z_n = depth."""
    if not (depth > 0 and h_surface > 0 and growth >= 1.0):
        raise ValueError("graded_coordinates: need depth > 0, h_surface > 0, growth >= 1")
    h_max = depth if h_max is None else h_max
    z = [0.0]
    h = h_surface
    while z[-1] + h < depth * (1 - 1e-12):
        z.append(z[-1] + h)
        h = min(h * growth, h_max)
    if len(z) > 1 and depth - z[-1] < 0.5 * (z[-1] - z[-2]):
        z[-1] = depth  # a sliver cell: merge it into the previous one
    else:
        z.append(depth)
    return np.asarray(z)


def graded_mesh(lateral, depth: float, h_surface: float, growth: float = 1.2,
                h_lateral: float | None = None, h_max: float | None = None,
                axisymmetric: bool = False, simplex: bool = True):
    """Tensor-product mesh of the body below the plane z = 0 (last axis), graded in depth.

    ``lateral`` = [(lo, hi)] per lateral axis (one for 2D / axisymmetric, two for 3D;
    axisymmetric: (0, R) in r), ``h_lateral`` the uniform lateral size (default: the
    depth grading's largest cell).  Triangles / tetrahedra of the tensor grid
(``simplex``, default) or quads / hexes, with facet groups ``top``
    (z = 0, the coupled surface), ``bottom``, and per lateral axis ``xmin``/``xmax``
    (``ymin``/``ymax``); axisymmetric meshes name r = 0 ``axis`` (zero flux by symmetry).
    """
    from skfem import MeshHex1, MeshQuad1, MeshTet1, MeshTri1

    zc = -graded_coordinates(depth, h_surface, growth, h_max)[::-1]
    hl = h_lateral if h_lateral is not None else float(np.max(np.diff(zc)))
    axes = []
    for lo, hi in lateral:
        n = max(1, int(math.ceil((hi - lo) / hl - 1e-9)))
        axes.append(np.linspace(lo, hi, n + 1))
    dim = len(axes) + 1
    if axisymmetric and dim != 2:
        raise ValueError("graded_mesh: an axisymmetric mesh has one lateral axis (r)")
    kinds = {(2, True): MeshTri1, (3, True): MeshTet1, (2, False): MeshQuad1,
             (3, False): MeshHex1}
    mesh = kinds[(dim, simplex)].init_tensor(*axes, zc)
    span = max(float(np.ptp(a)) for a in axes + [zc])
    tol = 1e-9 * span
    groups = {"top": lambda x: np.abs(x[-1]) < tol,
              "bottom": lambda x: np.abs(x[-1] - zc[0]) < tol}
    for a, (lo, hi) in enumerate(lateral):
        name = "xyz"[a]
        groups[f"{name}max"] = (lambda x, a=a, hi=hi: np.abs(x[a] - hi) < tol)
        if axisymmetric and a == 0 and abs(lo) < tol:
            groups["axis"] = (lambda x, a=a: np.abs(x[a]) < tol)
        else:
            groups[f"{name}min"] = (lambda x, a=a, lo=lo: np.abs(x[a] - lo) < tol)
    return mesh.with_boundaries(groups)


# ----------------------------------------------------------------------------- solver

#: largest half-bandwidth (in the reverse Cuthill-McKee order) factorised as a band
BAND_MAX = 64
FACTORS = ("auto", "banded", "splu")


def band_order(A) -> tuple[np.ndarray, int]:
    """Reverse Cuthill-McKee order of the symmetric sparse matrix ``A`` (Cuthill & McKee
    1969; George & Liu 1981, ch. 4) and the half-bandwidth w = max |i - j| over its
    nonzeros in that order."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    A = sp.csr_matrix(A)
    perm = reverse_cuthill_mckee(A, symmetric_mode=True)
    P = A[perm][:, perm].tocoo()
    w = int(np.max(np.abs(P.row - P.col))) if P.nnz else 0
    return np.asarray(perm, np.int64), w


def lower_band(A, perm: np.ndarray, w: int) -> np.ndarray:
    """The lower band (w + 1, n) of the symmetric sparse matrix ``A`` in the order
    ``perm``, LAPACK's storage: ab[i - j, j] = A[perm[i], perm[j]] for 0 <= i - j <= w."""
    P = sp.csr_matrix(A)[perm][:, perm].tocoo()
    low = P.row >= P.col
    if P.nnz and int(np.max(P.row[low] - P.col[low])) > w:
        raise ValueError(f"lower_band: the matrix reaches beyond the half-bandwidth {w}")
    ab = np.zeros((w + 1, A.shape[0]))
    ab[P.row[low] - P.col[low], P.col[low]] = P.data[low]
    return ab


class BandedCholesky:
    """A = L L^T of a symmetric positive definite matrix given by its lower band ``ab``
    (:func:`lower_band`) in the order ``perm`` (:func:`band_order`): LAPACK dpbtrf
    (n (w + 1) storage, ~n w^2 flops), ``solve`` by dpbtrs.  Raises
    ``np.linalg.LinAlgError`` when A is not positive definite."""

    def __init__(self, ab: np.ndarray, perm: np.ndarray):
        from scipy.linalg.lapack import dpbtrf

        self.cb, info = dpbtrf(ab, lower=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"BandedCholesky: matrix not positive definite "
                                        f"(dpbtrf info {info})")
        self.perm = perm

    def solve(self, b) -> np.ndarray:
        from scipy.linalg.lapack import dpbtrs

        x, info = dpbtrs(self.cb, np.asarray(b, float)[self.perm], lower=1)
        if info != 0:  # pragma: no cover - only for malformed arguments
            raise ValueError(f"BandedCholesky.solve: dpbtrs info {info}")
        out = np.empty_like(x)
        out[self.perm] = x
        return out


class TransientHeat:
    """Implicit transient conduction on a scikit-fem mesh (module docstring, eq. 1-2).

    ``k`` [W/(m K)], ``rho`` [kg/m^3], ``c`` [J/(kg K)] (one material), ``T0`` [K] the
    initial temperature, ``flux_group`` the facet group of the coupled surface,
    ``dirichlet`` {group: T [K]} fixed-temperature faces, ``theta`` in [1/2, 1],
    ``startup`` Crank-Nicolson steps replaced by two backward-Euler half steps
    (Rannacher), ``element`` a scikit-fem element (default: the mesh's P1/Q1),
    ``factor``: "auto" (banded Cholesky when the reverse Cuthill-McKee half-bandwidth is
    <= ``BAND_MAX``, else SuperLU; module docstring), "banded" or "splu".
    ``lumped``: the capacity matrix lumped to its row sums (default).  Lumping keeps
    1^T M T (the energy) and the second-order accuracy of P1/Q1, and removes the
    undershoot of the consistent mass on the first steps of a suddenly heated surface
    (the layer sqrt(alpha dt) thinner than the elements).  With P1 on the simplices of
    :func:`graded_mesh` (tensor-grid triangles / tetrahedra: every off-diagonal of K is
    <= 0 at any aspect ratio) and theta = 1, M/dt + K is an M-matrix and the scheme keeps
    the discrete maximum principle; stretched Q1 quads do not (positive diagonal
    couplings: measured undershoot 25 % of the peak under a heated strip,
    tests/test_heat_transient.py).
    """

    def __init__(self, mesh, k: float, rho: float, c: float, T0: float = 0.0, *,
                 axisymmetric: bool = False, flux_group: str = "top", dirichlet=None,
                 theta: float = 1.0, startup: int = 1, element=None,
                 robin_tol: float = 0.1, lumped: bool = True, factor: str = "auto"):
        if not 0.5 <= theta <= 1.0:
            raise ValueError(f"TransientHeat: theta must lie in [0.5, 1], got {theta}")
        if factor not in FACTORS:
            raise ValueError(f"TransientHeat: factor must be one of {FACTORS}, got {factor!r}")
        self.mesh = mesh
        self.flux_group = flux_group
        self.k, self.rho, self.c = float(k), float(rho), float(c)
        self.alpha = self.k / (self.rho * self.c)
        self.axisymmetric = axisymmetric
        self.theta = float(theta)
        self.startup = startup if theta < 1.0 else 0
        self.robin_tol = float(robin_tol)
        self.basis = Basis(mesh, element if element is not None else mesh.elem())
        if flux_group not in (mesh.boundaries or {}):
            raise ValueError(f"TransientHeat: mesh has no facet group {flux_group!r}")
        self.fbasis = FacetBasis(mesh, self.basis.elem, facets=mesh.boundaries[flux_group])
        ring = _ring_weight(axisymmetric)
        kk, rc = self.k, self.rho * self.c

        @BilinearForm
        def conduction(u, v, w):
            return kk * dot(grad(u), grad(v)) * ring(w)

        @BilinearForm
        def capacity(u, v, w):
            return rc * u * v * ring(w)

        @LinearForm
        def unit(v, w):
            return v * ring(w)

        @BilinearForm
        def surface_mass(u, v, w):
            return u * v * ring(w)

        self.K = conduction.assemble(self.basis).tocsr()
        self.M = capacity.assemble(self.basis).tocsr()
        self.lumped = lumped
        if lumped:  # row sums on the diagonal: the same energy 1^T M T, a maximum principle
            self.M = sp.diags(np.asarray(self.M.sum(axis=1)).ravel()).tocsr()
        area = unit.assemble(self.fbasis)
        self.surface_dofs = self.basis.get_dofs(flux_group).all()
        #: lumped surface weights int N_a dS [m^2] of the surface dofs (ring: 2 pi r dS)
        self.surface_area = area[self.surface_dofs]
        self.surface_mass = surface_mass.assemble(self.fbasis).tocsr()[self.surface_dofs][
            :, self.surface_dofs]
        #: lumped heat capacity of each surface dof [J/K] (row sums of M)
        self.capacity_lumped = np.asarray(self.M.sum(axis=1)).ravel()
        self.dirichlet = dict(dirichlet or {})
        D = [self.basis.get_dofs(g).all() for g in self.dirichlet]
        self.D = np.unique(np.concatenate(D)) if D else np.zeros(0, np.int64)
        self.T_D = np.zeros(self.basis.N)
        for g, val in self.dirichlet.items():
            self.T_D[self.basis.get_dofs(g).all()] = val
        self.I = self.basis.complement_dofs(self.D)
        if np.intersect1d(self.D, self.surface_dofs).size:
            raise ValueError("TransientHeat: the flux group must not share dofs with a "
                             "fixed-temperature group")
        self.T = np.full(self.basis.N, float(T0))
        self.T[self.D] = self.T_D[self.D]
        self.t = 0.0
        self.steps = 0
        self.factorisations = 0
        self._lu: dict = {}
        # the matrix of (1) has the pattern of |K| + |M| + I whatever theta, dt, H0 (K alone
        # may lack couplings: right-angled P1 triangles have K_ab = 0 across the hypotenuse)
        pattern = abs(self.K) + abs(self.M) + sp.eye(self.basis.N, format="csr")
        perm, w = band_order(pattern[self.I][:, self.I])
        if factor == "auto":
            factor = "banded" if w <= BAND_MAX else "splu"
        #: "banded" (:class:`BandedCholesky`) or "splu"; ``bandwidth`` its RCM half-bandwidth
        self.factor, self.bandwidth, self._perm = factor, w, perm
        self._bands = None
        self._MID = self.M[self.I][:, self.D]
        self._KID = self.K[self.I][:, self.D]
        self.H0 = np.zeros(self.surface_dofs.size)
        self._h0_key = 0
        self.heat_in = 0.0         #: sum of F dt over the steps [J] (eq. 2)
        self.heat_dirichlet = 0.0  #: heat through the fixed-temperature nodes [J]
        self.e0 = self.energy()
        logger.info("TransientHeat: %d dofs, %d surface dofs, %s", self.basis.N,
                    self.surface_dofs.size, "axisymmetric" if axisymmetric else
                    f"{mesh.dim()}D planar")

    # -- figures -------------------------------------------------------------------------
    @property
    def n_surface(self) -> int:
        return int(self.surface_dofs.size)

    def surface_points(self) -> np.ndarray:
        """(n_surface, dim) positions of the surface dofs."""
        return self.basis.doflocs[:, self.surface_dofs].T.copy()

    def surface_temperature(self) -> np.ndarray:
        return self.T[self.surface_dofs].copy()

    def energy(self) -> float:
        """E = int rho c T dV = 1^T M T [J] (of the whole ring when axisymmetric)."""
        return float(np.sum(self.M @ self.T))

    def energy_residual(self) -> float:
        """E - E0 - (heat in through the surface) - (heat through Dirichlet nodes) [J]."""
        return self.energy() - self.e0 - self.heat_in - self.heat_dirichlet

    def nodal_power(self, q, consistent: bool = False) -> np.ndarray:
        """Nodal powers [W] of a flux density ``q`` [W/m^2] given at the surface dofs:
        q_a A_a (lumped) or S q (consistent); both sum to int q_h dS."""
        q = np.broadcast_to(np.asarray(q, float), (self.n_surface,))
        return self.surface_mass @ q if consistent else q * self.surface_area

    def probe(self, points) -> np.ndarray:
        """Temperatures at ``points`` (n, dim)."""
        P = self.basis.probes(np.atleast_2d(np.asarray(points, float)).T)
        return P @ self.T

    # -- stepping ------------------------------------------------------------------------
    def _factor(self, theta: float, dt: float):
        key = (theta, dt, self._h0_key)
        lu = self._lu.get(key)
        if lu is None:
            if len(self._lu) >= 4:
                self._lu.pop(next(iter(self._lu)))
            # A = M/dt + theta K + H0 (H0 on the surface diagonal, no dof of D): its
            # I x D block is M_ID/dt + theta K_ID
            AID = self._MID / dt + theta * self._KID if self.D.size else None
            if self.factor == "banded":  # the bands of M and K taken once (_band_parts)
                bM, bK, diag_s = self._band_parts()
                ab = bM / dt  # + theta bK, in place (theta = 1: bK itself, the same sum)
                ab += bK if theta == 1.0 else theta * bK
                ab[0, diag_s] += self.H0
                lu = (BandedCholesky(ab, self._perm), AID)
            else:
                s, n = self.surface_dofs, self.basis.N
                A = (self.M / dt + theta * self.K
                     + sp.csr_matrix((self.H0, (s, s)), shape=(n, n))).tocsr()
                lu = (splu(A[self.I][:, self.I].tocsc(), permc_spec="MMD_AT_PLUS_A",
                           options={"SymmetricMode": True}), AID)
            self._lu[key] = lu
            self.factorisations += 1
        return lu

    def _band_parts(self):
        """(band of M_II, band of K_II, band column of each surface dof's diagonal) in the
        order ``_perm``, made on first use."""
        if self._bands is None:
            MII, KII = self.M[self.I][:, self.I], self.K[self.I][:, self.I]
            where = np.empty(self.I.size, np.int64)
            where[self._perm] = np.arange(self.I.size)
            self._bands = (lower_band(MII, self._perm, self.bandwidth),
                           lower_band(KII, self._perm, self.bandwidth),
                           where[np.searchsorted(self.I, self.surface_dofs)])
        return self._bands

    def _set_h0(self, H) -> None:
        self.H0 = np.array(H, float)
        self._h0_key += 1
        self._lu = {k: v for k, v in self._lu.items() if k[2] == self._h0_key}

    def _robin_band(self, H, dt) -> bool:
        """True when the factorised H0 may stay: |H - H0| <= robin_tol (C/dt + H0) on
        every surface dof, and no dof with H = 0 < H0."""
        C = self.capacity_lumped[self.surface_dofs]
        near = np.abs(H - self.H0) <= self.robin_tol * (C / dt + self.H0)
        dried = (H == 0.0) & (self.H0 > 0.0)
        return bool(np.all(near & ~dried))

    def _substep(self, theta, dt, P, H, T_ext) -> np.ndarray:
        s = self.surface_dofs
        lu, AID = self._factor(theta, dt)
        Tn = self.T
        rhs = self.M @ Tn / dt
        if theta < 1.0:
            rhs -= (1.0 - theta) * (self.K @ Tn)
        F_expl = np.zeros(self.n_surface)
        if P is not None:
            F_expl += P
        if H is not None:
            F_expl += H * (T_ext - Tn[s])
        rhs[s] += F_expl + self.H0 * Tn[s]
        T = Tn.copy()
        T[self.D] = self.T_D[self.D]
        b = rhs[self.I] - AID @ T[self.D] if self.D.size else rhs[self.I]
        T[self.I] = lu.solve(b)
        F = F_expl - self.H0 * (T[s] - Tn[s])  # eq. (2)
        if self.D.size:  # reaction: heat through the fixed nodes
            r = (self.M @ (T - Tn) / dt + self.K @ (theta * T + (1 - theta) * Tn))
            r[s] -= F
            self.heat_dirichlet += dt * float(r[self.D].sum())
        self.T = T
        self.heat_in += dt * float(F.sum())
        return F * dt

    def step(self, dt: float, power=None, robin=None) -> np.ndarray:
        """Advance by ``dt``; return the heat [J] each surface dof took in (eq. 2).

        ``power``: nodal powers P [W] at the surface dofs (explicit), e.g.
        :meth:`nodal_power` of a flux density.  ``robin``: ``(H, T_ext)`` with H [W/K] per
        surface dof (h_a A_a) and the external temperature(s) [K]: the exchange
        H (T_ext - T) is taken implicitly through the factorised H0, which is reset to H
        (one new factorisation) when |H - H0| > robin_tol (C/dt + H0) on some dof or a
        dof's H fell to 0.
        """
        H = T_ext = None
        if robin is not None:
            H = np.broadcast_to(np.asarray(robin[0], float), (self.n_surface,)).copy()
            T_ext = np.broadcast_to(np.asarray(robin[1], float), (self.n_surface,))
            if np.any(H < 0):
                raise ValueError("TransientHeat.step: exchange conductances must be >= 0")
            if not self._robin_band(H, dt):
                self._set_h0(H)
        elif np.any(self.H0):
            self._set_h0(np.zeros(self.n_surface))
        P = None if power is None else np.broadcast_to(np.asarray(power, float),
                                                        (self.n_surface,))
        if self.steps < self.startup:
            q = self._substep(1.0, 0.5 * dt, P, H, T_ext)
            q = q + self._substep(1.0, 0.5 * dt, P, H, T_ext)
        else:
            q = self._substep(self.theta, dt, P, H, T_ext)
        self.steps += 1
        self.t += dt
        return q


def _ring_weight(axisymmetric: bool):
    if axisymmetric:
        return lambda w: 2.0 * np.pi * w.x[0]
    return lambda w: 1.0


# ----------------------------------------------------------------------------- exact


def ierfc(x):
    """Integrated complementary error function ierfc(x) = exp(-x^2)/sqrt(pi) - x erfc(x)
    (Carslaw & Jaeger 1959, appendix II)."""
    from scipy.special import erfc

    x = np.asarray(x, float)
    xs = np.minimum(x, 26.0)  # ierfc(26) < 1e-296: beyond, 0 (and no inf * 0)
    return np.where(x < 26.0, np.exp(-xs * xs) / math.sqrt(math.pi) - xs * erfc(xs), 0.0)


def semi_infinite_flux(z, t, q, k, alpha):
    """Temperature rise of a semi-infinite body z >= 0 (depth) under a constant surface
    flux q [W/m^2] from t = 0: (2 q sqrt(alpha t) / k) ierfc(z / (2 sqrt(alpha t)))
    (Carslaw & Jaeger 1959, sec. 2.9, eq. 2.9(4)); at z = 0: 2 q sqrt(alpha t / pi) / k."""
    s = math.sqrt(alpha * t)
    return 2.0 * q * s / k * ierfc(np.asarray(z, float) / (2.0 * s))


def semi_infinite_step(z, t, T_surface, T0, alpha):
    """Semi-infinite body at T0 whose surface is held at T_surface from t = 0:
    T = T_surface + (T0 - T_surface) erf(z / (2 sqrt(alpha t))) (Carslaw & Jaeger sec. 2.4)."""
    from scipy.special import erf

    return T_surface + (T0 - T_surface) * erf(np.asarray(z, float) /
                                              (2.0 * math.sqrt(alpha * t)))
