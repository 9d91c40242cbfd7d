"""Axisymmetric FEM substrate validation: ``fem-axisymmetric`` (issue 16).

The (r, z) substrate (:mod:`sphfem.fem.axisymmetric`) against exact solutions:

* lame-P1/P2     -- thick-walled cylinder a < r < b under internal pressure, plane strain
                    (u_z = 0 on the ends), gmsh triangles of size h (Timoshenko & Goodier,
                    Theory of Elasticity, 3rd ed., sec. 28);
* radial-T-P1/P2 -- long solid cylinder, T - T0 = T1 (r/b)^2, plane strain, free surface
                    (T & G sec. 150), uniform triangles;
* mms-P1/P2      -- manufactured u_r, u_z with all four strains, a temperature field and the
                    matching body force, clamped on r = b, z = 0, z = L; uniform triangles;
* love-P2        -- uniform pressure p on r < a of a half-space (a clamped block 100 a
                    wide and deep) against Love's stresses on the axis (Johnson, Contact
                    Mechanics, 1985, sec. 3.4); graded quadrilaterals, error relative to p;
* free-dT        -- uniform temperature rise on a graded gmsh (r, z) mesh: zero stress,
                    u = alpha dT x.

Errors: ``error_l2`` the relative r-weighted L2 error of the displacement (love-P2: the
largest error of the four stresses on the axis over p), ``error_linf`` the largest vertex
error of u over max |u|; ``stress_l2`` (extra) the relative r-weighted L2 error of
(sigma_rr, sigma_zz, sigma_tt, sigma_rz).  ``resolution`` is the mesh size h (gmsh meshes:
sqrt(area / vertices)).  Expected orders: p + 1 for u, p for the stress.
"""

from __future__ import annotations

import math

import numpy as np

from sphfem.validation import CaseResult, Criterion, Run, Timer, observed_order, register

E, NU, ALPHA = 200e9, 0.3, 1.2e-5
PATCH_TOL = 1e-9

# ----------------------------------------------------------------------------- exact
A_IN, B_OUT, LEN, P_IN = 1.0, 2.0, 0.5, 1e8


def lame_exact(r):
    """Plane-strain thick cylinder, internal pressure P_IN: (u_r, s_rr, s_tt, s_zz)."""
    c = P_IN * A_IN**2 / (B_OUT**2 - A_IN**2)
    u = (1 + NU) * c / E * ((1 - 2 * NU) * r + B_OUT**2 / r)
    return u, c * (1 - B_OUT**2 / r**2), c * (1 + B_OUT**2 / r**2), 2 * NU * c + 0 * r


RB, T1 = 1.0, 80.0


def radial_exact(r):
    """Long solid cylinder of radius RB, T - T0 = T1 (r/RB)^2, plane strain, free surface:
    sigma_rr = C (1 - q), sigma_tt = C (1 - 3 q), q = r^2/b^2, C = alpha E T1 / (4 (1 - nu)),
    sigma_zz = nu (sigma_rr + sigma_tt) - alpha E T1 q, u_r = r eps_tt.  Returns
    (u_r, s_rr, s_tt, s_zz)."""
    C = ALPHA * E * T1 / (4 * (1 - NU))
    q = (r / RB) ** 2
    u = (1 + NU) * ALPHA * T1 * r * ((1 - 2 * NU) + q) / (4 * (1 - NU))
    srr, stt = C * (1 - q), C * (1 - 3 * q)
    return u, srr, stt, NU * (srr + stt) - ALPHA * E * T1 * q


MB, ML, MA, MBB, MT = 1.0, 1.5, 1e-3, 7e-4, 60.0


def mms_fields(x, lam, mu, beta):
    """Manufactured solution on [0, MB] x [0, ML], k = pi / ML:
    u_r = A r (b - r) sin(kz), u_z = B (b^2 - r^2) sin(kz), dT = T1 (1 + r^2/b^2) cos(kz).
    Returns (u (2, ...), dT, sigma (rr, zz, tt, rz), body force (2, ...)) with
    f_r = -(d_r s_rr + d_z s_rz + (s_rr - s_tt)/r), f_z = -(d_r s_rz + d_z s_zz + s_rz/r)
    (derived by hand, checked symbolically)."""
    r, z = x[0], x[1]
    k = np.pi / ML
    s, c = np.sin(k * z), np.cos(k * z)
    b, A, B = MB, MA, MBB
    u = np.array([A * r * (b - r) * s, B * (b**2 - r**2) * s])
    dT = MT * (1 + r**2 / b**2) * c
    err, ett, ezz = A * (b - 2 * r) * s, A * (b - r) * s, B * (b**2 - r**2) * k * c
    g = A * (b * r - r**2) * k * c - 2 * B * r * s
    tr = err + ett + ezz
    sig = np.array([lam * tr + 2 * mu * err - beta * dT, lam * tr + 2 * mu * ezz - beta * dT,
                    lam * tr + 2 * mu * ett - beta * dT, mu * g])
    dtr_r = -3 * A * s - 2 * B * k * r * c
    dtr_z = A * (2 * b - 3 * r) * k * c - B * k**2 * (b**2 - r**2) * s
    ddT_r, ddT_z = MT * 2 * r / b**2 * c, -MT * (1 + r**2 / b**2) * k * s
    fr = -(lam * dtr_r - 4 * mu * A * s - beta * ddT_r
           + mu * (-A * (b * r - r**2) * k**2 * s - 2 * B * r * k * c) - 2 * mu * A * s)
    fz = -(mu * (A * (b - 2 * r) * k * c - 2 * B * s) + lam * dtr_z
           - 2 * mu * B * k**2 * (b**2 - r**2) * s - beta * ddT_z
           + mu * (A * (b - r) * k * c - 2 * B * s))
    return u, dT, sig, np.array([fr, fz])


def love_axis(z, p, a, nu=NU):
    """Uniform pressure p on r < a of a half-space, stresses on the axis at depth z (Love
    1929; Johnson 1985, sec. 3.4): sigma_zz = -p (1 - q^3), sigma_rr = sigma_tt =
    -p/2 ((1 + 2 nu) - 2 (1 + nu) q + q^3), q = z / sqrt(a^2 + z^2).  The centre deflection
    is 2 (1 - nu^2) p a / E."""
    q = z / np.sqrt(a * a + z * z)
    return -p * (1 - q**3), -0.5 * p * ((1 + 2 * nu) - 2 * (1 + nu) * q + q**3)


# ----------------------------------------------------------------------------- helpers
def rl2(sub, err_qp, ref_qp) -> float:
    """Relative r-weighted L2 norm of quadrature fields (ncomp, nelems, nqp) of ``sub``."""
    return math.sqrt(float((np.sum(np.square(err_qp), axis=0) * sub.rdx).sum()
                           / (np.sum(np.square(ref_qp), axis=0) * sub.rdx).sum()))


def mesh_size(mesh) -> float:
    """sqrt(area / vertices) of a 2D mesh."""
    return float(np.sqrt(np.prod(np.ptp(mesh.p, axis=1)) / mesh.nvertices))


def _errors(sub, res, u_qp, sig_qp, u_vertices):
    """(u L2, u max at vertices, stress L2); sig_qp = (rr, zz, tt, rz) at the quadrature
    points, u_qp (2, ...) and u_vertices (2, nvertices)."""
    uh = np.asarray(sub.basis.interpolate(res.dofs))
    S = res.stress_qp
    eu = rl2(sub, uh - u_qp, u_qp)
    es = rl2(sub, [S[0, 0] - sig_qp[0], S[1, 1] - sig_qp[1], S[2, 2] - sig_qp[2],
                   S[0, 1] - sig_qp[3]], sig_qp)
    einf = float(np.abs(res.u.T - u_vertices).max() / np.abs(u_vertices).max())
    return eu, einf, es


def _run(variant, h, sub, res, t, errs) -> Run:
    eu, einf, es = errs
    return Run(variant, h, int(sub.n_dofs), eu, einf, t.s,
               {"stress_l2": es, "assemble_K_s": sub.timings["assemble_K"],
                "factorize_s": sub.timings["factorize"], "solve_s": res.info["solve_s"]})


# ----------------------------------------------------------------------------- runs
def lame_run(element: str, h: float) -> Run:
    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate
    from sphfem.fem.meshing import substrate_rect
    from sphfem.fem.substrate import load_mesh

    mesh = load_mesh(substrate_rect(size=(B_OUT - A_IN, LEN), origin=(A_IN, 0.0), h_fine=h,
                                    h_coarse=h, refine_radius=h))
    with Timer() as t:
        s = AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element=element,
                                     rollers={"top": "z", "bottom": "z"})
        res = s.solve(tractions={"left": (P_IN, 0.0)})
    u, srr, stt, szz = lame_exact(s.r_qp)
    uv = np.array([lame_exact(mesh.p[0])[0], 0 * mesh.p[0]])
    errs = _errors(s, res, np.array([u, 0 * u]), np.array([srr, szz, stt, 0 * u]), uv)
    return _run(f"lame-{element}", mesh_size(mesh), s, res, t, errs)


def radial_run(element: str, n: int) -> Run:
    from skfem import MeshTri

    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate

    mesh = MeshTri.init_tensor(np.linspace(0, RB, n + 1),
                               np.linspace(0, 0.5, n // 2 + 1)).with_defaults()
    with Timer() as t:
        s = AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element=element,
                                     rollers={"top": "z", "bottom": "z"})
        res = s.solve(dT_nodal=lambda x: T1 * (x[0] / RB) ** 2)
    u, srr, stt, szz = radial_exact(s.r_qp)
    uv = np.array([radial_exact(mesh.p[0])[0], 0 * mesh.p[0]])
    errs = _errors(s, res, np.array([u, 0 * u]), np.array([srr, szz, stt, 0 * u]), uv)
    return _run(f"radial-T-{element}", RB / n, s, res, t, errs)


def mms_run(element: str, n: int) -> Run:
    from skfem import MeshTri

    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate

    mesh = MeshTri.init_tensor(np.linspace(0, MB, n + 1),
                               np.linspace(0, ML, int(1.5 * n) + 1)).with_defaults()
    with Timer() as t:
        s = AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element=element,
                                     clamps=["right", "top", "bottom"])
        beta = (3 * s.lam + 2 * s.mu) * ALPHA

        def fields(x):
            return mms_fields(x, s.lam, s.mu, beta)

        res = s.solve(dT_nodal=lambda x: fields(x)[1], body_force=lambda x: fields(x)[3])
    xq = np.asarray(s.basis.global_coordinates())
    u, _, sig, _ = fields(xq)
    errs = _errors(s, res, u, sig, fields(mesh.p)[0])
    return _run(f"mms-{element}", MB / n, s, res, t, errs)


def love_run(n: int, size: float = 100.0) -> Run:
    """P2 quads, h = a/n within 3a; error: max over the axis z in [0, 3a] of the four
    stress errors / p; ``extra``: the centre deflection's relative error and the peak von
    Mises on the axis against Love's."""
    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, graded_tensor_rz

    p, a = 1e8, 1.0
    mesh = graded_tensor_rz(size * a, size * a, a / n, 3 * a, growth=1.2)
    with Timer() as t:
        s = AxisymmetricFEMSubstrate(mesh, E, NU, 0.0, element="P2", clamps=["bottom"])
        res = s.solve(tractions={"top": lambda x: np.array([0 * x[0], -p * (x[0] < a)])})
    zs = np.linspace(0.0, 3 * a, 241)
    pr = res.probe(np.column_stack([0 * zs, -zs]))
    szz, srr = love_axis(zs, p, a)
    S = pr["stress"]
    err = max(float(np.abs(S[:, 1, 1] - szz).max()), float(np.abs(S[:, 0, 0] - srr).max()),
              float(np.abs(S[:, 2, 2] - srr).max()), float(np.abs(S[:, 0, 1]).max())) / p
    uz = -2 * (1 - NU**2) * p * a / E
    vm = np.abs(szz - srr)
    return Run("love-P2", a / n, int(s.n_dofs), err, err, t.s,
               {"centre_deflection_rel_err": float(pr["u"][0, 1] / uz - 1),
                "peak_vm_rel_err": float(pr["von_mises"].max() / vm.max() - 1),
                "peak_vm_depth_err_a": float(zs[np.argmax(pr["von_mises"])]
                                             - zs[np.argmax(vm)]) / a,
                "reaction_rel_err": float(res.reaction("bottom")[1] / (p * np.pi * a**2) - 1),
                "solve_s": res.info["solve_s"]})


def free_dT_run(element: str, el: str) -> tuple[Run, float, int]:
    """Free disc on a graded gmsh (r, z) mesh, uniform dT: returns (run, max |sigma| /
    (E alpha dT), factorisations after two solves)."""
    from sphfem.fem.axisymmetric import AxisymmetricFEMSubstrate, substrate_rz

    dT = 150.0
    mesh = substrate_rz(radius=1.0, depth=0.3, h_fine=0.02, h_coarse=0.1, refine_radius=0.1,
                        element=element)
    with Timer() as t:
        s = AxisymmetricFEMSubstrate(mesh, E, NU, ALPHA, element=el)
        res = s.solve(dT_nodal=dT)
        s.solve(dT_nodal=2 * dT)
    scale = E * ALPHA * dT
    stress = max(float(np.abs(res.stress_qp).max()), float(np.abs(res.stress_nodes).max()))
    r, z = s.mesh.p
    uex = ALPHA * dT * np.array([r, z - z.min()])
    eu = float(np.abs(res.u.T - uex).max() / np.abs(uex).max())
    run = Run(f"free-dT {element}-{el}", 0.02, int(s.n_dofs), eu, eu, t.s,
              {"stress_rel": stress / scale})
    return run, stress / scale, s.n_factorizations


# ----------------------------------------------------------------------------- case
@register("fem-axisymmetric")
def fem_axisymmetric(quick: bool) -> CaseResult:
    """Axisymmetric FEM substrate: Lame, radial temperature, manufactured solution, Love's
    pressure patch, free thermal expansion."""
    runs: list[Run] = []
    crit: dict[str, Criterion] = {}
    notes: list[str] = []
    target = {"P1": 2.0, "P2": 3.0}
    sizes = {
        "lame": {"P1": (0.1, 0.05, 0.025, 0.0125), "P2": (0.2, 0.1, 0.05, 0.025)},
        "radial": {"P1": (8, 16, 32, 64), "P2": (4, 8, 16, 32)},
        "mms": {"P1": (8, 16, 32, 64), "P2": (4, 8, 16, 32)},
    }
    if quick:  # the two middle meshes of each (the two coarsest unstructured Lame meshes
        # are pre-asymptotic: P2 order 2.6 on one gmsh mesh pair, 3.2 on another)
        sizes = {k: {el: hs[1:3] for el, hs in per.items()} for k, per in sizes.items()}
    makers = {"lame": lame_run, "radial": radial_run, "mms": mms_run}
    for name, per in sizes.items():
        for el, hs in per.items():
            rs = [makers[name](el, h) for h in hs]
            runs += rs
            v = rs[0].variant
            f, c = rs[-1], rs[-2]
            order_u = math.log(c.error_l2 / f.error_l2) / math.log(c.resolution / f.resolution)
            order_s = math.log(c.extra["stress_l2"] / f.extra["stress_l2"]) / \
                math.log(c.resolution / f.resolution)
            crit[f"{v} order u"] = Criterion(
                f"{v}: observed L2 order of u (two finest) >= {target[el] - 0.2} "
                f"(expected {target[el]:.0f})", order_u, target[el] - 0.2, ">=")
            crit[f"{v} order stress"] = Criterion(
                f"{v}: observed L2 order of the stress (two finest) >= {target[el] - 1.2} "
                f"(expected {target[el] - 1:.0f})", order_s, target[el] - 1.2, ">=")
            ls = observed_order(rs, v)
            notes.append(f"{v}: least-squares order of u over {len(rs)} meshes "
                         f"{ls if ls is not None else math.nan:.2f}; finest {f.n_particles} "
                         f"dofs, u error {f.error_l2:.2e}, stress error "
                         f"{f.extra['stress_l2']:.2e}, {f.wall_s:.2f} s")
    love = [love_run(n) for n in ((8,) if quick else (4, 8, 16))]
    runs += love
    f = love[-1]
    crit["love axis stress"] = Criterion(
        "love-P2 (finest): max |sigma - sigma_Love| / p on the axis, z in [0, 3a]",
        f.error_l2, 1e-2)
    crit["love centre deflection"] = Criterion(
        "love-P2 (finest): |u_z(0) / u_Love - 1| (block 100 a: about a/L from the "
        "truncation)", abs(f.extra["centre_deflection_rel_err"]), 1e-2)
    crit["love peak von Mises"] = Criterion(
        "love-P2 (finest): |peak von Mises on the axis / Love's - 1|",
        abs(f.extra["peak_vm_rel_err"]), 1e-2)
    crit["love reaction"] = Criterion("love-P2: |R_z / (p pi a^2) - 1|",
                                      max(abs(r.extra["reaction_rel_err"]) for r in love),
                                      1e-10)
    worst, nfact = 0.0, 0
    for element, el in (("tri", "P1"), ("tri", "P2"), ("quad", "P1")):
        run, st, nf = free_dT_run(element, el)
        runs.append(run)
        worst = max(worst, st, run.error_l2)
        nfact = max(nfact, nf)
    crit["free-dT"] = Criterion("free disc, uniform dT: max |sigma| / (E alpha dT) and max "
                                "|u - alpha dT x| / max |u|", worst, PATCH_TOL)
    crit["factorise once"] = Criterion("factorisations of K over two solves", nfact, 1)
    notes.append(f"material E={E:g} Pa, nu={NU}, alpha={ALPHA:g} 1/K; lame a={A_IN}, "
                 f"b={B_OUT}, p={P_IN:g} Pa; radial T1={T1} K on b={RB}")
    notes.append("error_l2: relative r-weighted L2 of u (love-P2: max axis stress error / p);"
                 " stress_l2: the same for (s_rr, s_zz, s_tt, s_rz)")
    return CaseResult("fem-axisymmetric", runs, crit, notes, resolution_label="h",
                      extra_columns={"stress_l2": "stress L2", "solve_s": "solve s"})
