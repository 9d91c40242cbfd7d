"""FEM substrate validation: ``fem-thermal`` (issue 5).

Linear thermo-elasticity, sigma = lam tr(eps) I + 2G eps - (3 lam + 2G) alpha dT I, on
gmsh meshes of a block refined under the top centre (tetrahedra P1/P2 and hexahedra Q1):

* free-dT      -- no support (3-2-1 pins only), uniform dT: sigma = 0, u = alpha dT x
                  up to a rigid motion;
* clamped-dT   -- every face clamped: sigma = -E alpha dT / (1 - 2 nu) I;
* uniaxial-dT  -- rollers on the sides and bottom, free top: sigma_xx = sigma_yy =
                  -E alpha dT / (1 - nu), sigma_zz = 0;
* pressure     -- uniform pressure p on the top of a block on rollers: sigma_zz = -p, the
                  bottom reaction is p A;
* mms-P1/P2    -- manufactured u = c sin(pi x) sin(pi y) sin(pi z) on the clamped unit
                  cube with dT = 100 x y z and the matching body force: observed L2 order;
* conservation -- nodal loads of sensor point forces and of a non-uniform facet traction
                  sum to the applied total / the traction integral.

Errors are relative (L2 over the nodal values, L-inf over elements) to the scale of the
exact field.  ``resolution`` is the nominal mesh size h, and for the manufactured solution
the effective size (V / n_elements)^(1/3), so that the order does not depend on how well
gmsh meets its target size on coarse meshes.
"""

from __future__ import annotations

import math

import numpy as np

from sphfem.validation import CaseResult, Criterion, Run, Timer, register

E, NU, ALPHA, DT = 300e9, 0.21, 7.0e-6, 100.0  # alumina-like substrate, 100 K heating
BLOCK = dict(size=(1.0, 0.8, 0.3), origin=(0.0, 0.0, 0.0), refine_center=(0.5, 0.4, 0.3),
             refine_radius=0.15)
ALL_FACES = ["left", "right", "front", "back", "bottom", "top"]
ROLLERS = {"left": "x", "right": "x", "front": "y", "back": "y", "bottom": "z"}
PATCH_TOL = 1e-8


def _block(element: str, h: float):
    from sphfem.fem.meshing import substrate_block

    return substrate_block(h_fine=h, h_coarse=2.5 * h, element=element, **BLOCK)


def _rigid_fit_residual(x: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Remove the best-fitting rigid motion (least squares) from the vector field e (n, 3)."""
    xc = x - x.mean(axis=0)
    n = len(x)
    cols = []
    for c in range(3):
        t = np.zeros((n, 3))
        t[:, c] = 1.0
        cols.append(t.ravel())
    for a, b in ((0, 1), (1, 2), (2, 0)):
        r = np.zeros((n, 3))
        r[:, a] = -xc[:, b]
        r[:, b] = xc[:, a]
        cols.append(r.ravel())
    B = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(B, e.ravel(), rcond=None)
    return (e.ravel() - B @ coef).reshape(n, 3)


def _stress_errors(res, exact: np.ndarray, scale: float) -> tuple[float, float, float]:
    """Relative L2 (nodal projection) and L-inf (elements, nodes) stress errors."""
    en = res.stress_nodes - exact
    ee = res.stress_elem - exact
    l2 = math.sqrt(float(np.mean(np.sum(en**2, axis=(1, 2))))) / scale
    return l2, float(np.abs(ee).max()) / scale, float(np.abs(en).max()) / scale


def _patch_runs(quick: bool):
    """Free, clamped, uniaxial-strain and pressure patch tests on three element types."""
    from sphfem.fem.substrate import FEMSubstrate

    runs = []
    worst = {"free-dT": 0.0, "free-u": 0.0, "clamped-dT": 0.0, "uniaxial-dT": 0.0,
             "pressure": 0.0, "reaction": 0.0}
    n_fact = []
    p = 1e6
    configs = [("tet", "P1", 0.06), ("tet", "P2", 0.12), ("hex", "P1", 0.08)]
    for mesh_el, el, h in configs:
        path = _block(mesh_el, h)
        tag = f"{mesh_el}-{el}"
        # free block, uniform dT
        with Timer() as t:
            s = FEMSubstrate(path, E, NU, ALPHA, element=el)
            r = s.solve(dT_nodal=DT)
            x = s.mesh.p.T
            e = _rigid_fit_residual(x, r.u - ALPHA * DT * x)
            ue = ALPHA * DT * np.linalg.norm(x - x.mean(axis=0), axis=1).max()
            scale = E * ALPHA * DT
            l2, li_e, li_n = _stress_errors(r, np.zeros((3, 3)), scale)
        u_err = float(np.abs(e).max()) / ue
        runs.append(Run(f"free-dT {tag}", h, s.n_dofs, l2, max(li_e, li_n), t.s,
                        {"stress_max_over_EaDT": max(li_e, li_n), "u_err_rigid_removed": u_err,
                         "pins": "3-2-1", "solve_s": r.info["solve_s"]}))
        worst["free-dT"] = max(worst["free-dT"], li_e, li_n)
        worst["free-u"] = max(worst["free-u"], u_err)
        # fully clamped
        with Timer() as t:
            s = FEMSubstrate(s.mesh, E, NU, ALPHA, element=el, clamps=ALL_FACES)
            r = s.solve(dT_nodal=DT)
            sig = -E * ALPHA * DT / (1 - 2 * NU)
            l2, li_e, li_n = _stress_errors(r, sig * np.eye(3), abs(sig))
        runs.append(Run(f"clamped-dT {tag}", h, s.n_dofs, l2, max(li_e, li_n), t.s,
                        {"sigma_exact": sig, "solve_s": r.info["solve_s"]}))
        worst["clamped-dT"] = max(worst["clamped-dT"], li_e, li_n)
        # uniaxial strain: rollers, free top
        with Timer() as t:
            s = FEMSubstrate(s.mesh, E, NU, ALPHA, element=el, rollers=ROLLERS)
            r = s.solve(dT_nodal=DT)
            sig = -E * ALPHA * DT / (1 - NU)
            l2, li_e, li_n = _stress_errors(r, np.diag([sig, sig, 0.0]), abs(sig))
        runs.append(Run(f"uniaxial-dT {tag}", h, s.n_dofs, l2, max(li_e, li_n), t.s,
                        {"sigma_exact": sig, "solve_s": r.info["solve_s"]}))
        worst["uniaxial-dT"] = max(worst["uniaxial-dT"], li_e, li_n)
        # uniform pressure on the top of the same rollered block (same factorisation)
        with Timer() as t:
            r = s.solve(tractions={"top": [0.0, 0.0, -p]})
            lat = -NU / (1 - NU) * p
            l2, li_e, li_n = _stress_errors(r, np.diag([lat, lat, -p]), p)
            area = BLOCK["size"][0] * BLOCK["size"][1]
            Rz = float(r.reaction("bottom")[2])
        rel_R = abs(Rz - p * area) / (p * area)
        runs.append(Run(f"pressure {tag}", h, s.n_dofs, l2, max(li_e, li_n), t.s,
                        {"reaction_z": Rz, "pA": p * area, "reaction_rel_err": rel_R,
                         "solve_s": r.info["solve_s"]}))
        worst["pressure"] = max(worst["pressure"], li_e, li_n)
        worst["reaction"] = max(worst["reaction"], rel_R)
        n_fact.append((s.n_factorizations, s.n_solves))
    return runs, worst, n_fact


# --- manufactured solution on the unit cube ---------------------------------------------
_C = np.array([1.0, 2.0, 3.0]) * 1e-4


def mms_u(x: np.ndarray) -> np.ndarray:
    ph = np.sin(np.pi * x[0]) * np.sin(np.pi * x[1]) * np.sin(np.pi * x[2])
    return _C.reshape((3,) + (1,) * (x.ndim - 1)) * ph


def mms_dT(x: np.ndarray) -> np.ndarray:
    return 100.0 * x[0] * x[1] * x[2]


def mms_body_force(lam: float, mu: float, alpha: float):
    """f = -div sigma = -(lam + mu) grad div u - mu lap u + (3 lam + 2 mu) alpha grad dT."""
    beta = (3 * lam + 2 * mu) * alpha

    def f(x):
        S, C = np.sin(np.pi * x), np.cos(np.pi * x)
        ph = S[0] * S[1] * S[2]
        H = np.empty((3, 3) + x.shape[1:])
        for i in range(3):
            for j in range(3):
                H[i, j] = -np.pi**2 * ph if i == j else np.pi**2 * C[i] * C[j] * S[3 - i - j]
        graddiv = np.einsum("ij...,j->i...", H, _C)
        lap = -3 * np.pi**2 * ph * _C.reshape((3,) + (1,) * (x.ndim - 1))
        gT = 100.0 * np.stack([x[1] * x[2], x[0] * x[2], x[0] * x[1]])
        return -(lam + mu) * graddiv - mu * lap + beta * gT

    return f


def mms_run(element: str, h: float) -> Run:
    from skfem import Basis, Functional

    from sphfem.fem.meshing import substrate_block
    from sphfem.fem.substrate import FEMSubstrate

    path = substrate_block(size=(1, 1, 1), origin=(0, 0, 0), h_fine=h, h_coarse=h)
    with Timer() as t:
        s = FEMSubstrate(path, E, NU, ALPHA, element=element, clamps=ALL_FACES)
        r = s.solve(dT_nodal=mms_dT, body_force=mms_body_force(s.lam, s.mu, s.alpha))

    @Functional
    def err2(w):
        return ((w.uh - mms_u(w.x)) ** 2).sum(axis=0)

    @Functional
    def ref2(w):
        return (mms_u(w.x) ** 2).sum(axis=0)

    b = Basis(s.mesh, s.basis.elem, intorder=6)
    l2 = math.sqrt(err2.assemble(b, uh=b.interpolate(r.dofs)) / ref2.assemble(b))
    linf = float(np.abs(r.u - mms_u(s.mesh.p).T).max() / np.abs(_C).max())  # at vertices
    h_eff = s.mesh.t.shape[1] ** (-1.0 / 3.0)
    return Run(f"mms-{element}", h_eff, s.n_dofs, l2, linf, t.s,
               {"h_nominal": h, "assemble_K_s": s.timings["assemble_K"],
                "factorize_s": s.timings["factorize"], "solve_s": r.info["solve_s"]})


def _ls_order(runs) -> float:
    h = np.log([r.resolution for r in runs])
    e = np.log([r.error_l2 for r in runs])
    return float(np.polyfit(h, e, 1)[0])


def _conservation():
    """Sensor point forces and a non-uniform traction on the top: nodal-load sums."""
    from sphfem.fem.substrate import FEMSubstrate

    runs, worst = [], 0.0
    for mesh_el, el in (("tet", "P1"), ("tet", "P2"), ("hex", "P1")):
        with Timer() as t:
            s = FEMSubstrate(_block(mesh_el, 0.08), E, NU, ALPHA, element=el, clamps=["bottom"])
            rng = np.random.default_rng(5)
            n = 200
            X = np.column_stack([rng.uniform(0, 1.0, n), rng.uniform(0, 0.8, n),
                                 0.3 + rng.uniform(-1e-6, 1e-6, n)])  # a little off the surface
            F = rng.normal(size=(n, 3))
            fp = s.point_force_load(X, F, snap="top")
            sums = np.array([fp[d].sum() for d in s.component_dofs])
            e_pt = float(np.abs(sums - F.sum(axis=0)).max() / np.abs(F).sum())

            # traction t = (tau x, 0, -p (1 + x y)) on the top z = 0.3, [0,1] x [0,0.8]
            tau, p = 2e5, 1e6

            def traction(x, tau=tau, p=p):
                return np.stack([tau * x[0], 0 * x[0], -p * (1 + x[0] * x[1])])

            ft = s.traction_load({"top": traction})
            tsum = np.array([ft[d].sum() for d in s.component_dofs])
            exact = np.array([tau * 0.5 * 0.8, 0.0, -p * (0.8 + 0.5 * 0.32)])
            e_tr = float(np.abs(tsum - exact).max() / np.abs(exact).max())
            r = s.solve(point_forces=(X, F))
            R = r.reaction("bottom")
            e_R = float(np.abs(R + F.sum(axis=0)).max() / np.abs(F).sum())
        err = max(e_pt, e_tr)
        worst = max(worst, err, e_R)
        runs.append(Run(f"conservation {mesh_el}-{el}", 0.08, s.n_dofs, err, err, t.s,
                        {"point_sum_err": e_pt, "traction_sum_err": e_tr,
                         "reaction_balance_err": e_R}))
    return runs, worst


@register("fem-thermal")
def fem_thermal(quick: bool) -> CaseResult:
    """FEM substrate: thermal patch tests, pressure, manufactured solution, conservation."""
    runs, worst, n_fact = _patch_runs(quick)
    crit = {
        "free-dT stress": Criterion("free block: max |sigma| / (E alpha dT)",
                                    worst["free-dT"], PATCH_TOL),
        "free-dT displacement": Criterion(
            "free block: max |u - alpha dT x| (rigid motion removed) / max |u|",
            worst["free-u"], PATCH_TOL),
        "clamped-dT": Criterion("clamped: max |sigma + E alpha dT/(1-2nu) I| relative",
                                worst["clamped-dT"], PATCH_TOL),
        "uniaxial-dT": Criterion("uniaxial strain: max |sigma - diag(s, s, 0)| relative, "
                                 "s = -E alpha dT/(1-nu)", worst["uniaxial-dT"], PATCH_TOL),
        "pressure stress": Criterion("pressure on rollers: max |sigma_zz + p| (and lateral) / p",
                                     worst["pressure"], PATCH_TOL),
        "pressure reaction": Criterion("pressure on rollers: |R_z - p A| / (p A)",
                                       worst["reaction"], 1e-10),
    }
    mms_h = {"P1": (0.25, 0.125, 0.0625) if quick else (0.25, 0.125, 0.0625, 0.045),
             "P2": (0.4, 0.2, 0.1) if quick else (0.4, 0.2, 0.1, 0.08)}
    target = {"P1": 2.0, "P2": 3.0}
    notes = []
    for el, hs in mms_h.items():
        rs = [mms_run(el, h) for h in hs]
        runs += rs
        rs_sorted = sorted(rs, key=lambda r: r.resolution)
        f, c = rs_sorted[0], rs_sorted[1]
        order = math.log(c.error_l2 / f.error_l2) / math.log(c.resolution / f.resolution)
        crit[f"mms-{el} order"] = Criterion(
            f"manufactured solution, {el}: observed L2 order (two finest) >= {target[el] - 0.2}"
            f" (expected {target[el]:.0f})", order, target[el] - 0.2, ">=")
        notes.append(f"mms-{el}: least-squares L2 order over {len(rs)} meshes "
                     f"{_ls_order(rs):.2f}; finest {f.n_particles} dofs, "
                     f"error {f.error_l2:.2e} in {f.wall_s:.2f} s")
    c_runs, c_worst = _conservation()
    runs += c_runs
    crit["conservation"] = Criterion(
        "sum of nodal loads vs applied point forces / traction integral / reactions, relative",
        c_worst, 1e-12)
    nf = max(f for f, _ in n_fact)
    crit["factorise once"] = Criterion(
        "factorisations of K per substrate over its solves (uniaxial + pressure)", nf, 1)
    notes.append("free block held by 3-2-1 pins (statically determinate); stress errors are "
                 "the max over element averages and L2-projected nodal values")
    notes.append(f"material E={E:g} Pa, nu={NU}, alpha={ALPHA:g} 1/K, dT={DT:g} K; block "
                 f"{BLOCK['size']} refined r={BLOCK['refine_radius']} under the top centre")
    return CaseResult("fem-thermal", runs, crit, notes, resolution_label="h",
                      extra_columns={"solve_s": "solve s"})
