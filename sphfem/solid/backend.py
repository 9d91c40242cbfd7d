"""TL-SPH substrate: the same job as :class:`sphfem.fem.FEMSubstrate`, with particles.

>>> sub = TLSPHSubstrate(lo=(-1e-3, -1e-3), hi=(1e-3, 0.0), dx=25e-6, E=300e9, nu=0.21,
...                      alpha=7e-6, clamps=["bottom"])
>>> res = sub.solve(dT_nodal=dT, tractions={"top": t}, point_forces=(x_s, F_s))
>>> res.u, res.stress, res.von_mises, res.probe(points)

The body is the cell-centred lattice of the box [lo, hi] (spacing dx).  Faces are named as
in the gmsh recipes: 2D ``left``/``right`` (x), ``bottom``/``top`` (y); 3D ``left``/``right``
(x), ``front``/``back`` (y), ``bottom``/``top`` (z).  A clamped face gets ``clamp_layers``
rows of held particles outside the box (so the face itself carries the kernel support of
the first real rows, as a clamped FE boundary does).  A roller that holds the face normal
(``{"bottom": "z"}``, also ``"xz"``) is a symmetry plane: ``clamp_layers`` rows of mirror
ghosts outside the face follow their images inside (:meth:`SolidBody.mirror`; held
components odd, free ones even), so the particles near the face see the full support of
the symmetric continuation -- a uniform temperature rise with rollers on every face gives
u = 0 and the exact hydrostatic stress to round-off.  (Holding the normal component of the
particle layers instead is not exact: the stress divergence of the free particles within
2R of the face sees the truncated B0 of the held ones, 0.5 % stress error with 3 layers.)
A roller holding only tangential components holds them on ``roller_layers`` layers.
:meth:`TLSPHSubstrate.solve` brings the body to the
quasi-static state under the given loads, warm-started from the previous solution:
``solver="newton"`` (default) by Newton-Krylov (:func:`sphfem.solid.implicit.static_solve`),
``"relax"`` by dynamic relaxation (:func:`sphfem.solid.integrate.relax`).

Loads: ``dT_nodal`` / ``T_nodal`` -- scalar, callable of the reference coordinates
(dim, n) as in FEMSubstrate, or an array with one value per body particle (``X``);
``tractions`` -- ``{face: t}`` with t constant (dim,) or callable of (dim, n) coordinates,
applied as t * dx^(dim-1) on the outermost layer of the face; ``point_forces`` --
``(points, forces)``, each force acting on the nearest particle of the ``snap`` face
(total force conserved exactly).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from sphfem import kernels
from sphfem.loads import at_points, scalar_at
from sphfem.quasistatic import QuasiStaticSubstrate
from sphfem.solid.body import SolidBody, _components
from sphfem.solid.constitutive import lame
from sphfem.solid.integrate import relax
from sphfem.solid.lattice import box_lattice


def face_axes(dim: int) -> dict[str, tuple[int, int]]:
    """Face name -> (axis, side) with side -1 (min) or +1 (max)."""
    if dim == 2:
        return {"left": (0, -1), "right": (0, 1), "bottom": (1, -1), "top": (1, 1)}
    return {"left": (0, -1), "right": (0, 1), "front": (1, -1), "back": (1, 1),
            "bottom": (2, -1), "top": (2, 1)}


def _mirror_images(X, lo, hi, faces, mirrored, tol):
    """Ghosts of the roller planes in ``mirrored`` ({face: held components}) among the
    lattice points ``X`` and their partners: a point beyond a mirrored face is reflected
    across it (repeatedly, for a body between two mirrored faces) until it lies within the
    body's extent on that axis.  Each reflection flips the reference coordinate (X_sign)
    and the held components of the displacement (u_sign: odd in the held components, even
    in the free ones -- zero shear traction on the plane).  Returns ``(ghost, partner,
    u_sign, X_sign)``; ``partner`` is -1 where the image is not a lattice point."""
    n, dim = X.shape
    Y = X.copy()
    su = np.ones((n, dim))
    sx = np.ones((n, dim))
    is_ghost = np.zeros(n, bool)
    for _ in range(64):
        moved = False
        for g, comps in mirrored.items():
            ax, side = faces[g]
            edge = hi[ax] if side > 0 else lo[ax]
            out = (Y[:, ax] > edge + tol) if side > 0 else (Y[:, ax] < edge - tol)
            if out.any():
                moved = True
                is_ghost |= out
                Y[out, ax] = 2 * edge - Y[out, ax]
                sx[out, ax] *= -1
                su[np.ix_(out, comps)] *= -1
        if not moved:
            break
    ghost = np.flatnonzero(is_ghost)
    d, j = cKDTree(X).query(Y[ghost])
    partner = np.where(d <= tol, j, -1)
    partner[np.isin(partner, ghost)] = -1
    return ghost, partner, su[ghost], sx[ghost]


@dataclass
class TLSPHResult:
    """One quasi-static solve (values per body particle, clamp layers excluded)."""

    substrate: TLSPHSubstrate
    u: np.ndarray            #: displacement (n, dim)
    stress: np.ndarray       #: Cauchy stress (n, 3, 3)
    dT: np.ndarray           #: temperature change (n,)
    info: dict = field(default_factory=dict)

    @property
    def von_mises(self) -> np.ndarray:
        from sphfem.solid.constitutive import von_mises

        return von_mises(self.stress)

    @property
    def von_mises_nodes(self) -> np.ndarray:
        """Alias of :attr:`von_mises` (the particles are the nodes)."""
        return self.von_mises

    def probe(self, points) -> dict:
        """Displacement, stress, von Mises and dT at ``points`` (n, dim) in the reference
        configuration: Shepard-normalised kernel interpolation over the body particles
        within the support radius (sum_j V_j f_j W_ij / sum_j V_j W_ij)."""
        s = self.substrate
        P = np.atleast_2d(np.asarray(points, float))
        X = s.X
        R = s.body.ref.R
        kernel_code = kernels.kernel_code("wendland_c2")  # the body's kernel
        sigma = kernels.kernel_sigma(kernel_code, s.dim, R)
        idx = s._tree.query_ball_point(P, R)
        out_u = np.zeros((len(P), s.dim))
        out_s = np.zeros((len(P), 3, 3))
        out_t = np.zeros(len(P))
        for q, nb in enumerate(idx):
            nb = np.asarray(nb, dtype=np.int64)
            if nb.size == 0:
                raise ValueError(f"probe: point {P[q]} is farther than R = {R:g} from the "
                                 "TL-SPH body")
            r = np.linalg.norm(X[nb] - P[q], axis=1)
            w = s.vol[nb] * sigma * np.array([kernels.kernel_f(v / R, kernel_code) for v in r])
            w /= w.sum()
            out_u[q] = w @ self.u[nb]
            out_s[q] = np.einsum("n,nij->ij", w, self.stress[nb])
            out_t[q] = w @ self.dT[nb]
        from sphfem.solid.constitutive import von_mises

        return {"u": out_u, "stress": out_s, "von_mises": von_mises(out_s), "dT": out_t}


class TLSPHSubstrate(QuasiStaticSubstrate):
    """Quasi-static thermo-elastic TL-SPH substrate on the box [lo, hi] (see the module
    docstring).  ``rho`` only scales the fictitious dynamics of the relaxation.
    ``solve(dT_nodal, tractions, point_forces, body_force, T_nodal, snap)``
    (:meth:`sphfem.quasistatic.QuasiStaticSubstrate.solve`) relaxes to each step's
    state; ``body_force`` [N/m^dim] acts as b V on every body particle."""

    def __init__(self, lo, hi, dx: float, E: float, nu: float, alpha: float,
                 T0: float = 293.15, rho: float = 1000.0, clamps=(), rollers=None,
                 support_factor: float = 3.0, hourglass: float = 10.0,
                 clamp_layers: int | None = None, roller_layers: int | None = None,
                 tol: float = 1e-6,
                 max_steps: int = 200000, solver: str = "newton"):
        t0 = time.perf_counter()
        lo = np.asarray(lo, float)
        hi = np.asarray(hi, float)
        self.dim = lo.size
        self.lo, self.hi, self.dx = lo, hi, float(dx)
        self.E, self.nu, self.alpha, self.T0 = float(E), float(nu), float(alpha), float(T0)
        self.tol, self.max_steps = tol, max_steps
        if solver not in ("newton", "relax"):
            raise ValueError(f"TL-SPH substrate solver {solver!r}: expected \"newton\" or "
                             "\"relax\"")
        self.solver = solver
        faces = face_axes(self.dim)
        clamps = [clamps] if isinstance(clamps, str) else list(clamps)
        rollers = dict(rollers or {})
        for g in list(clamps) + list(rollers):
            if g not in faces:
                raise ValueError(f"unknown face {g!r}; expected one of {sorted(faces)}")
        both = set(clamps) & set(rollers)
        if both:
            raise ValueError(f"faces {sorted(both)} are both clamped and on rollers")
        nl = clamp_layers if clamp_layers is not None else int(math.ceil(support_factor))
        # rollers holding the face normal are symmetry planes: mirror ghosts (exact);
        # rollers holding only tangential components hold them on `roller_layers` layers
        mirrored = {g: _components(c, self.dim) for g, c in rollers.items()
                    if faces[g][0] in _components(c, self.dim)}
        blo, bhi = lo.copy(), hi.copy()
        for g in list(clamps) + list(mirrored):
            ax, side = faces[g]
            if side < 0:
                blo[ax] -= nl * dx
            else:
                bhi[ax] += nl * dx
        Xall = box_lattice(blo, bhi, dx)
        ghost, partner, u_sign, X_sign = _mirror_images(Xall, lo, hi, faces, mirrored,
                                                        1e-6 * dx)
        keep = np.ones(len(Xall), bool)
        keep[ghost[partner < 0]] = False  # images of empty space (body thinner than R)
        if not keep.all():
            new = np.cumsum(keep) - 1
            ok = partner >= 0
            ghost, partner = new[ghost[ok]], new[partner[ok]]
            u_sign, X_sign = u_sign[ok], X_sign[ok]
            Xall = Xall[keep]
        inside = np.all((Xall > lo) & (Xall < hi), axis=1)
        lam, mu = lame(self.E, self.nu)
        self.body = SolidBody(Xall, dx**self.dim, rho, lam, mu, self.alpha, dx,
                              theta0=self.T0, support_factor=support_factor,
                              hourglass=hourglass)
        self.body.theta[:] = self.T0
        self.body.clamp(~inside)
        if ghost.size:
            self.body.mirror(ghost, partner, u_sign, X_sign)
        self.n_mirror = int(ghost.size)
        self.inside = np.flatnonzero(inside)
        self.X = Xall[inside]
        self.vol = np.full(self.X.shape[0], dx**self.dim)
        self._tree = cKDTree(self.X)
        self.faces = faces
        self.face_layer = {}
        for g, (ax, side) in faces.items():
            edge = hi[ax] if side > 0 else lo[ax]
            self.face_layer[g] = np.flatnonzero(inside & (np.abs(Xall[:, ax] - edge)
                                                          < 0.51 * dx))
        self.roller_layers = nl if roller_layers is None else int(roller_layers)
        if self.roller_layers < 1:
            raise ValueError(f"roller_layers must be >= 1, got {roller_layers}")
        for g, comps in rollers.items():
            if g in mirrored:
                continue
            ax, side = faces[g]
            edge = hi[ax] if side > 0 else lo[ax]
            m = inside & (np.abs(Xall[:, ax] - edge) < self.roller_layers * dx)
            self.body.roller(m, comps)
        self.clamps, self.rollers = clamps, rollers
        self.n_solves = 0
        self.timings = {"setup": time.perf_counter() - t0}
        self.relax_steps: list[int] = []

    @property
    def n_particles(self) -> int:
        return self.X.shape[0]

    # -- loads ---------------------------------------------------------------------------
    def _dT_at(self, spec, X) -> np.ndarray:
        """Temperature change at the points X (n, dim): scalar, callable or one value per
        body particle (:func:`sphfem.loads.scalar_at`)."""
        return scalar_at(spec, X.T, self._per_particle)

    def _per_particle(self, a: np.ndarray) -> np.ndarray:
        if a.shape == (self.n_particles,):
            return a.copy()
        raise ValueError(f"dT: expected a scalar, a callable or {self.n_particles} values "
                         f"(one per particle), got shape {a.shape}")

    def _set_loads(self, dT, tractions, point_forces, snap, body_force=None) -> None:
        b = self.body
        b.f_ext[:] = 0.0
        Xall = b.ref.X
        dTi = self._dT_at(dT, self.X)
        b.theta[:] = self.T0
        b.theta[self.inside] = self.T0 + dTi
        # clamp layers: temperature of the nearest body particle
        held = np.setdiff1d(np.arange(b.n), self.inside)
        if held.size:
            _, src = self._tree.query(Xall[held])
            b.theta[held] = self.T0 + dTi[src]
        area = self.dx ** (self.dim - 1)
        for g, t in (tractions or {}).items():
            if g not in self.face_layer:
                raise ValueError(f"unknown face {g!r}; expected one of {sorted(self.faces)}")
            idx = self.face_layer[g]
            b.f_ext[idx] += at_points(t, Xall[idx].T, self.dim) * area
        if body_force is not None:
            b.f_ext[self.inside] += at_points(body_force, self.X.T, self.dim) * \
                self.vol[:, None]
        if point_forces is not None:
            pts, F = (np.atleast_2d(np.asarray(a, float)) for a in point_forces)
            cand = self.face_layer[snap] if snap else self.inside
            _, k = cKDTree(Xall[cand]).query(pts)
            np.add.at(b.f_ext, cand[k], F)

    # -- solve (sphfem.quasistatic.QuasiStaticSubstrate.solve) -------------------------
    def _assemble(self, dT, tractions, point_forces, body_force, snap, load) -> None:
        """Put the step's loads on the body (external forces, temperatures)."""
        if load is not None:
            raise ValueError("TLSPHSubstrate.solve: a ready nodal load vector is for the FEM "
                             "substrate; give point_forces, tractions or body_force")
        self._set_loads(dT, tractions, point_forces, snap, body_force)

    def _respond(self, loads, info: dict) -> np.ndarray:
        """Solve for the quasi-static state (warm-started from the previous one): Newton-
        Krylov (``solver = "newton"``, :func:`sphfem.solid.implicit.static_solve`) or
        dynamic relaxation (``"relax"``), both to ||f_int + f_ext|| <= tol * load; the
        Cauchy stress of the body particles.  ``info``: the solver's figures (``steps``:
        relaxation steps, or force evaluations of the Newton solve)."""
        if self.solver == "newton":
            from sphfem.solid.implicit import static_solve

            r = static_solve(self.body, tol=self.tol)
            r.pop("history")
        else:
            r = relax(self.body, tol=self.tol, max_steps=self.max_steps)
        info.update(r)
        self.relax_steps.append(info["steps"])
        self.body.internal_forces()
        return self.body.cauchy()[self.inside]

    def _result(self, stress, loads, dT, info) -> TLSPHResult:
        b = self.body
        return TLSPHResult(self, b.u[self.inside].copy(), stress,
                           b.theta[self.inside] - self.T0, info)

    def diagnostics(self) -> dict:
        return {"backend": "tlsph", "solver": self.solver, "particles": self.n_particles,
                "held_particles": int(self.body.n - self.n_particles), "dx": self.dx,
                "solves": self.n_solves, "relax_steps": list(self.relax_steps),
                "setup_s": self.timings["setup"], **self.body.diagnostics()}
