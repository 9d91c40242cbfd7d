"""Newton-Krylov solves of a TL-SPH body: the quasi-static equilibrium and an implicit
(trapezoidal / Newmark average-acceleration) time step, at any step size.

Both solve a nonlinear system G(x) = 0 on the free displacement components by Newton's
method; each Newton correction solves J du = G with restarted GMRES, the Jacobian products
by a forward difference of the force pipeline (one force evaluation each),

    K v ~ -(f_int(x + e v) - f_int(x)) / e ,

so the stress divergence, hourglass control, mirror ghosts and thermal strain enter
exactly as in :meth:`SolidBody.internal_forces` (the hourglass forces make K slightly
unsymmetric: GMRES, not CG).  The preconditioner is a sparse *pair stiffness* of the
reference configuration, a nearest-neighbour (distance-1) consistent discretisation of the
Navier operator mu lap u + (lam + mu) grad div u,

    (K_p u)_i = -V_i sum_j V_j |gW_ij| / |X_ij| [ (mu - lam) I + (d + 2)(lam + mu) e e^T ]
                (u_j - u_i),          e = X_ij / |X_ij| ,

(per pair the mean of the two particles' moduli; (mu - lam) floored at 0.05 mu so it stays
positive definite for nu > 1/4): for a smooth field sum_j V_j |gW| / r (u_j - u_i) ->
lap u / 2 and sum_j V_j |gW| / r e e^T (u_j - u_i) -> (lap u + 2 grad div u) / (2 (d + 2)).
The exact TL-SPH tangent couples particles two supports apart (F_i reads N_i, f_i reads the
P_j of N_i), ~900 neighbours per particle in 3D, too many to assemble; K_p has the ~110 of
one support.  Held components are removed, mirror ghosts folded onto their partners (with
their signs).  K_p (plus 4 kappa M / dt^2 for the dynamic step) is factorised once per
body (and step size) and reused: a sparse LU below ``direct_max`` unknowns, otherwise a
smoothed-aggregation AMG V-cycle (pyamg, rigid-body modes as near-null space).

* :func:`static_solve` -- quasi-static equilibrium f_int(x) + f_ext = 0 (replaces dynamic
  relaxation; converged on the same relative residual as :func:`~sphfem.solid.integrate.
  relax`, ||f_int + f_ext|| <= tol * load).
* :func:`newmark_step` -- one implicit trapezoidal step (the same equations as
  :func:`~sphfem.solid.integrate.trapezoid_step`, which iterates them by fixed point and
  therefore only converges below the explicit limit):

      kappa (x - x_t - dt/2 v_t) = dt/2 (v_t + dt/2 (a_t + g(x))),  kappa = 1 + c dt / 2,
      g(x) = (f_int(x) + f_ext) / m,   v = (v_t + dt/2 (a_t + g(x))) / kappa ,

  i.e. G(x) = f_int + f_ext - (4/dt^2) M [kappa (x - x_t - dt/2 v_t) - dt/2 v_t - dt^2/4
  a_t] = 0, Jacobian K + (4 kappa / dt^2) M.  Converged when the position error the
  residual can cause, max_i |G_i| dt^2 / (4 kappa m_i) (an upper bound per mode: K >= 0),
  is <= tol dx.  Unconditionally stable and energy conserving for a linear undamped body.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numba import njit

from sphfem.neighbors import min_image
from sphfem.solid.forces import stress_forces
from sphfem.solid.integrate import SolidConvergenceError
from sphfem.solid.kinematics import deformation_gradient


@njit(cache=True)
def _hourglass_tangent(x, dx, offsets, indices, dX, hgw, F, dF, E, alpha_hg, period, f):
    """Add the exact linearisation of :func:`~sphfem.solid.forces.hourglass_forces` at
    (x, F) in the direction (dx, dF) to f:  d[(e.r) r / |r|^2] with e = (F_i + F_j) X_ij -
    2 r, r = x_ij."""
    n, dim = x.shape
    c0 = -0.25 * alpha_hg
    r = np.empty(dim)
    dr = np.empty(dim)
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            if hgw[jj] == 0.0:
                continue
            d2 = 0.0
            for k in range(dim):
                r[k] = min_image(x[j, k] - x[i, k], period[k])
                dr[k] = dx[j, k] - dx[i, k]
                d2 += r[k] * r[k]
            if d2 == 0.0:
                continue
            er = 0.0
            der = 0.0
            edr = 0.0
            rdr = 0.0
            for p in range(dim):
                e = -2.0 * r[p]
                de = -2.0 * dr[p]
                for q in range(dim):
                    e += (F[i, p, q] + F[j, p, q]) * dX[jj, q]
                    de += (dF[i, p, q] + dF[j, p, q]) * dX[jj, q]
                er += e * r[p]
                der += de * r[p]
                edr += e * dr[p]
                rdr += r[p] * dr[p]
            c = c0 * hgw[jj] * (E[i] + E[j]) / d2
            a = (der + edr - 2.0 * er * rdr / d2)
            for p in range(dim):
                f[i, p] += c * (a * r[p] + er * dr[p])


def force_differential(body, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """d f_int (n, dim): the exact directional derivative of :meth:`SolidBody.internal_
    forces` at the state of its last evaluation, which was at positions ``x`` (F, S,
    theta), in the direction ``dx`` (n, dim) (mirror ghosts follow their partners).  Linear in
    ``dx``: the Krylov operator (a forward difference of the forces is not linear, and
    its truncation error, ~ |e v| / dx of the pair forces, is amplified by the
    cancellation of smooth fields -- GMRES stagnates on a bent bar)."""
    r = body.ref
    dim = body.dim
    dx = np.array(dx, dtype=float)
    if body._mirror is not None:
        g, p, su, sx = body._mirror
        dx[g] = su * dx[p]
    dF = np.zeros_like(body.F)
    deformation_gradient(dx, r.vol, r.offsets, r.indices, r.gw, r.B, np.zeros(dim), dF)
    if body._mirror is not None:
        dF[g] = su[:, :, None] * dF[p] * sx[:, None, :]
    F = body.F
    S2 = body.S[:, :dim, :dim]
    v = 1.0 + body.alpha * (body.theta - body.theta0)
    dC = np.einsum("nki,nkj->nij", dF, F)
    dE = (dC + dC.transpose(0, 2, 1)) / (2.0 * v * v)[:, None, None]
    tr = np.trace(dE, axis1=1, axis2=2)
    dS = v[:, None, None] * (body.lam[:, None, None] * tr[:, None, None] * np.eye(dim)
                             + 2.0 * body.mu[:, None, None] * dE)
    dP = np.ascontiguousarray(dF @ S2 + F @ dS)
    df = np.zeros_like(dx)
    stress_forces(r.vol, r.offsets, r.indices, r.gw, r.B, dP, df)
    if body.hourglass > 0.0:
        _hourglass_tangent(x, dx, r.offsets, r.indices, r.dX, r.hgw, F, dF,
                           body.young, body.hourglass, r.period, df)
    return df


@njit(cache=True)
def _pair_stiffness_coo(offsets, indices, gw, dX, vol, lam, mu, floor):
    """COO triplets of the pair stiffness K_p (dofs i*dim + p)."""
    n = offsets.shape[0] - 1
    dim = dX.shape[1]
    npair = indices.shape[0]
    nnz = npair * dim * dim * 2
    rows = np.empty(nnz, np.int64)
    cols = np.empty(nnz, np.int64)
    vals = np.empty(nnz)
    e = np.empty(dim)
    k = 0
    for i in range(n):
        for jj in range(offsets[i], offsets[i + 1]):
            j = indices[jj]
            r2 = 0.0
            g2 = 0.0
            for q in range(dim):
                r2 += dX[jj, q] * dX[jj, q]
                g2 += gw[jj, q] * gw[jj, q]
            if r2 == 0.0:
                continue
            r = np.sqrt(r2)
            for q in range(dim):
                e[q] = dX[jj, q] / r
            lm = 0.5 * (lam[i] + lam[j])
            mm = 0.5 * (mu[i] + mu[j])
            a = max(mm - lm, floor * mm)
            b = (dim + 2.0) * (lm + mm)
            w = vol[i] * vol[j] * np.sqrt(g2) / r
            for p in range(dim):
                for q in range(dim):
                    c = w * ((a if p == q else 0.0) + b * e[p] * e[q])
                    # row i: +c on (i, i), -c on (i, j)
                    rows[k] = i * dim + p
                    cols[k] = i * dim + q
                    vals[k] = c
                    k += 1
                    rows[k] = i * dim + p
                    cols[k] = j * dim + q
                    vals[k] = -c
                    k += 1
    return rows[:k], cols[:k], vals[:k]


def pair_stiffness(body, floor: float = 0.05) -> sp.csr_matrix:
    """The pair stiffness K_p (n dim x n dim, symmetric positive semi-definite) of the
    module docstring, on every particle (held ones included)."""
    r = body.ref
    rows, cols, vals = _pair_stiffness_coo(r.offsets, r.indices, r.gw, r.dX, r.vol,
                                           body.lam, body.mu, floor)
    N = body.n * body.dim
    K = sp.coo_matrix((vals, (rows, cols)), shape=(N, N)).tocsr()
    return ((K + K.T) * 0.5).tocsr()


def free_map(body) -> sp.csr_matrix:
    """T (n dim x n_free): the displacement of every component from the free ones --
    identity on free components, u_sign on a mirror ghost's component whose partner
    component is free, 0 on held ones."""
    dim = body.dim
    free = ~body.fixed.ravel()
    col = np.full(free.size, -1, np.int64)
    col[free] = np.arange(int(free.sum()))
    rows = [np.flatnonzero(free)]
    cols = [col[free]]
    vals = [np.ones(int(free.sum()))]
    if body._mirror is not None:
        g, p, su, _ = body._mirror
        gd = (g[:, None] * dim + np.arange(dim)).ravel()
        pd = (p[:, None] * dim + np.arange(dim)).ravel()
        s = su.ravel()
        ok = col[pd] >= 0
        rows.append(gd[ok])
        cols.append(col[pd[ok]])
        vals.append(s[ok])
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                 np.concatenate(cols))),
                         shape=(free.size, int(free.sum()))).tocsr()


def tangent_stiffness(body, x=None) -> sp.csr_matrix:
    """The exact tangent K = -d f_int / d u (free components, mirror ghosts following their
    partners) at positions ``x`` (default the current ones), assembled column by column
    from :func:`force_differential` with colouring: particles whose row sets (the
    particles within two supports of them or of their mirror ghosts) are disjoint share
    one product.  About pi (4R)^2 / dx^2 x dim products in 2D (~900 at R = 3 dx), each as
    dear as a force evaluation -- meant for 2D; in 3D the count (~7000) and the
    ~900-particle rows make it too dear (:func:`pair_stiffness` there)."""
    from scipy.spatial import cKDTree

    x0 = (body.x if x is None else x).copy()
    n, dim = body.n, body.dim
    R = body.ref.R
    free = ~body.fixed.ravel()
    col_of = np.full(n * dim, -1, np.int64)
    col_of[free] = np.arange(int(free.sum()))
    movers = [[p] for p in range(n)]  # p and its mirror ghosts
    if body._mirror is not None:
        g, pp, _, _ = body._mirror
        for gi, pi in zip(g, pp, strict=True):
            movers[pi].append(int(gi))
    Xr = body.ref.X
    tree = cKDTree(Xr)
    reach = 2.0 * R * (1.0 + 1e-9)
    rows_of = [np.unique(np.concatenate([np.asarray(tree.query_ball_point(Xr[q], reach),
                                                    np.int64) for q in movers[p]]))
               for p in range(n)]
    cand = np.flatnonzero(free.reshape(n, dim).any(axis=1))
    colour = np.full(n, -1, np.int64)
    touched: list[set] = []
    for p in cand:  # greedy colouring: particles sharing a row differ
        c = 0
        rp = rows_of[p].tolist()
        while c < len(touched) and not touched[c].isdisjoint(rp):
            c += 1
        if c == len(touched):
            touched.append(set())
        touched[c].update(rp)
        colour[p] = c
    body.internal_forces(x0)
    R_, C_, V_ = [], [], []
    fr = free.reshape(n, dim)
    for c in range(len(touched)):
        ps = cand[colour[cand] == c]
        for comp in range(dim):
            sel = ps[fr[ps, comp]]
            if sel.size == 0:
                continue
            d = np.zeros((n, dim))
            d[sel, comp] = 1.0
            d[~fr] = 0.0
            df = -force_differential(body, x0, d)
            for p in sel:
                r = rows_of[p]
                j = col_of[p * dim + comp]
                for q in range(dim):
                    rr = col_of[r * dim + q]
                    ok = rr >= 0
                    R_.append(rr[ok])
                    C_.append(np.full(int(ok.sum()), j))
                    V_.append(df[r[ok], q])
    nf = int(free.sum())
    return sp.coo_matrix((np.concatenate(V_), (np.concatenate(R_), np.concatenate(C_))),
                         shape=(nf, nf)).tocsr()


class Preconditioner:
    """(K_0 + shift diag(m))^-1 on the free components, K_0 the exact tangent of the
    current state (:func:`tangent_stiffness`, ``kind = "exact"``: 2D) or the pair
    stiffness T^T K_p T (``"pair"``: 3D); sparse LU when the free unknowns are at most
    ``direct_max`` (or K_0 is exact, hence unsymmetric), else a smoothed-aggregation AMG
    V-cycle."""

    def __init__(self, body, shift: float = 0.0, direct_max: int = 10000,
                 kind: str | None = None):
        t0 = time.process_time()
        self.free = ~body.fixed.ravel()
        self.stiffness = kind or ("exact" if body.dim == 2 else "pair")
        if self.stiffness == "exact":
            K = tangent_stiffness(body)
            direct_max = max(direct_max, K.shape[0])
        else:
            T = free_map(body)
            K = (T.T @ pair_stiffness(body) @ T).tocsr()
        if shift > 0.0:
            mf = np.repeat(body.m, body.dim)[self.free]
            K = (K + sp.diags(shift * mf)).tocsr()
        self.n = K.shape[0]
        self.regularised = 0.0  # the mass shift added when K alone is singular
        if self.n <= direct_max:
            self.kind = "splu"
            try:
                lu = spla.splu(K.tocsc(), permc_spec="COLAMD")
            except RuntimeError as err:  # "Factor is exactly singular": a free rigid mode
                if "singular" not in str(err):
                    raise
                # a body held against some rigid motions only (rollers along x leave the
                # y translation free) has a null space the residual never excites; a shift
                # 1e-10 x the mean stiffness diagonal makes it invertible without changing
                # the step in the loaded directions beyond 1e-10 (it only preconditions)
                mf = np.repeat(body.m, body.dim)[self.free]
                reg = 1e-10 * float(np.abs(K.diagonal()).mean()) / float(mf.mean())
                K = (K + sp.diags(reg * mf)).tocsr()
                lu = spla.splu(K.tocsc(), permc_spec="COLAMD")
                self.regularised = reg
            self._apply = lu.solve
        else:
            import pyamg

            self.kind = "amg"
            dim = body.dim
            X = body.ref.X
            B = _rigid_modes(X, dim).reshape(body.n * dim, -1)[self.free]
            ml = pyamg.smoothed_aggregation_solver(K, B=B, symmetry="symmetric",
                                                   max_coarse=2000)
            self._apply = lambda r: ml.solve(r, x0=np.zeros_like(r), tol=1e-30, maxiter=1,
                                             cycle="V")
        self.setup_cpu_s = time.process_time() - t0

    def operator(self) -> spla.LinearOperator:
        return spla.LinearOperator((self.n, self.n), matvec=self._apply, dtype=float)


def _rigid_modes(X, dim):
    """Rigid-body modes (n, dim, k) of the particle positions (AMG near-null space)."""
    n = X.shape[0]
    c = X - X.mean(axis=0)
    if dim == 2:
        B = np.zeros((n, 2, 3))
        B[:, 0, 0] = 1.0
        B[:, 1, 1] = 1.0
        B[:, 0, 2] = -c[:, 1]
        B[:, 1, 2] = c[:, 0]
    else:
        B = np.zeros((n, 3, 6))
        for k in range(3):
            B[:, k, k] = 1.0
        B[:, 1, 3], B[:, 2, 3] = -c[:, 2], c[:, 1]
        B[:, 0, 4], B[:, 2, 4] = c[:, 2], -c[:, 0]
        B[:, 0, 5], B[:, 1, 5] = -c[:, 1], c[:, 0]
    scale = np.abs(c).max() or 1.0
    B[:, :, dim:] /= scale
    return B


def _preconditioner(body, shift: float) -> Preconditioner:
    """The body's cached preconditioner for ``shift`` (rebuilt when the held set or the
    shift changes)."""
    cache = body.__dict__.setdefault("_nk_precond", {})
    key = (float(shift), body.fixed.tobytes())
    if key not in cache:
        if len(cache) >= 2:
            cache.clear()
        cache[key] = Preconditioner(body, shift)
    return cache[key]


def _newton(body, residual, scale_fn, tol, shift, max_newton, gmres_restart, gmres_maxiter):
    """Newton-Krylov on G(x) = ``residual(x)`` (free components, flat), starting at
    body.x; converged when ``scale_fn(G)`` <= tol.  Returns (info, G)."""
    pc = _preconditioner(body, shift)
    M = pc.operator()
    free = pc.free
    mfree = np.repeat(body.m, body.dim)[free]
    x = body.x
    G = residual(x)
    err = scale_fn(G)
    history = [err]
    count = [0]
    evals0 = body.force_evaluations
    lin = {"x": x.copy()}

    def jv(v):
        d = np.zeros(x.size)
        d[free] = v
        out = -force_differential(body, lin["x"], d.reshape(x.shape)).ravel()[free]
        return out + shift * mfree * v if shift > 0.0 else out

    def cb(_):
        count[0] += 1

    A = spla.LinearOperator((pc.n, pc.n), matvec=jv, dtype=float)
    it = 0
    while err > tol and it < max_newton:
        it += 1
        lin["x"] = x.copy()  # residual() left F, S of x in the body
        # inner tolerance: enough to reach tol in this correction, at least 1e-3 relative
        rt = min(1e-3, 0.3 * tol / max(err, 1e-300))
        du, _ = spla.gmres(A, G, rtol=rt, atol=0.0, restart=gmres_restart,
                           maxiter=gmres_maxiter, M=M, callback=cb,
                           callback_type="pr_norm")
        step = np.zeros(x.size)
        step[free] = du
        x[:] = lin["x"] + step.reshape(x.shape)
        G = residual(x)
        err = scale_fn(G)
        history.append(err)
        if not np.isfinite(err):
            break
    krylov = count[0]
    info = {"newton": it, "krylov": krylov, "residual": err, "converged": bool(err <= tol),
            "force_evaluations": body.force_evaluations - evals0, "history": history,
            "preconditioner": pc.kind, "preconditioner_setup_cpu_s": pc.setup_cpu_s}
    return info, G


def load_scale(body) -> float:
    """The load of :func:`~sphfem.solid.integrate.relax`'s relative residual: the
    out-of-balance force of the undeformed body under the current loads, floored at the
    load of a 1e-7 strain (sqrt(n) E dx^(dim-1) 1e-7)."""
    free = ~body.fixed
    f_ref = (body.internal_forces(body.ref.X.copy()) + body.f_ext) * free
    load = float(np.linalg.norm(f_ref))
    floor = 1e-7 * np.sqrt(body.n) * float(body.young.max()) * body.dx ** (body.dim - 1)
    return max(load, floor)


def static_solve(body, tol: float = 1e-6, max_newton: int = 20, gmres_restart: int = 60,
                 gmres_maxiter: int = 20, raise_on_fail: bool = True) -> dict:
    """Quasi-static equilibrium of ``body`` under its current loads and temperature by
    Newton-Krylov, warm-started from ``body.x``; the convergence test and ``residual`` are
    those of :func:`~sphfem.solid.integrate.relax` (||f_int + f_ext|| on free components
    <= tol * load).  Returns newton / krylov iterations, ``steps`` (their sum: one force
    evaluation or one linearised product each), residual, CPU seconds; raises
    :class:`SolidConvergenceError` unless ``raise_on_fail`` is False."""
    t0 = time.process_time()
    w0 = time.perf_counter()
    x_start = body.x.copy()
    load = load_scale(body)
    free = ~body.fixed.ravel()

    def residual(x):
        return (body.internal_forces(x) + body.f_ext).ravel()[free]

    info, _ = _newton(body, residual, lambda G: float(np.linalg.norm(G)) / load, tol, 0.0,
                      max_newton, gmres_restart, gmres_maxiter)
    body.internal_forces()
    body.v[:] = 0.0
    body.a = np.zeros_like(body.x)
    info.update(steps=info["newton"] + info["krylov"], cpu_s=time.process_time() - t0,
                wall_s=time.perf_counter() - w0)
    if not info["converged"]:
        if raise_on_fail:
            body.x[:] = x_start
            body.internal_forces()
            raise SolidConvergenceError(
                f"TL-SPH Newton-Krylov static solve: residual {info['residual']:.3g} > tol "
                f"{tol:g} after {info['newton']} Newton corrections ({info['krylov']} GMRES "
                f"iterations); residual history {info['history']}")
    return info


def newmark_step(body, dt: float, tol: float = 1e-9, max_newton: int = 20,
                 gmres_restart: int = 60, gmres_maxiter: int = 20,
                 step_index: int | None = None) -> dict:
    """One implicit trapezoidal (Newmark average-acceleration) step of size ``dt`` by
    Newton-Krylov (module docstring).  Returns ``{"newton", "krylov", "residual", ...}``;
    on failure restores the state and raises :class:`SolidConvergenceError`."""
    a0 = getattr(body, "a", None)
    if a0 is None or a0.shape != body.x.shape:
        a0 = body.accelerations()
    c = body.damping
    kap = 1.0 + 0.5 * c * dt
    x_t, v_t = body.x.copy(), body.v.copy()
    held = body.fixed
    free = ~held.ravel()
    m = body.m[:, None]
    beta = 4.0 / (dt * dt)
    base = kap * (x_t + 0.5 * dt * v_t) + 0.5 * dt * v_t + 0.25 * dt * dt * a0
    # predictor: the explicit one of trapezoid_step; held components move at v_presc
    x = body.x
    x[:] = x_t + dt * v_t + 0.5 * dt * dt * a0
    x[held] = x_t[held] + dt * body.v_presc[held]
    fe = body.f_ext
    mflat = np.broadcast_to(m, x.shape).ravel()[free]
    pos = 1.0 / (beta * kap * mflat) / body.dx

    def residual(xx):
        return (body.internal_forces(xx) + fe - beta * m * (kap * xx - base)).ravel()[free]

    info, G = _newton(body, residual, lambda G: float(np.max(np.abs(G) * pos)), tol,
                      beta * kap, max_newton, gmres_restart, gmres_maxiter)
    if not info["converged"]:
        body.x[:] = x_t
        body.v[:] = v_t
        body.internal_forces()
        where = f"step {step_index}" if step_index is not None else "implicit step"
        raise SolidConvergenceError(
            f"TL-SPH Newton-Krylov {where} at dt = {dt:.3g} s: position residual "
            f"{info['residual']:.3g} dx > tol {tol:g} after {info['newton']} Newton "
            f"corrections ({info['krylov']} GMRES iterations).  State restored.")
    g = (body.f_int + fe) / m
    v = (v_t + 0.5 * dt * (a0 + g)) / kap
    v[held] = body.v_presc[held]
    body.v[:] = v
    a = g - c * v
    a[held] = 0.0
    body.a = a
    return info
