"""Normal droplet impact, fluid only, on a rigid wall: axisymmetric (r, z) run against the
3D solver at equal spacing (issue 16).

Water droplet D = 0.1 mm at 10 m/s (We = rho v^2 D / sigma = 139 with water's sigma, but
surface tension is off in both runs: the comparison is of the two solvers, not of the
physics), mu = 1e-3 Pa s (Re = 1000), c0 = 100 m/s, delta = 0.1, alpha = 0.02, no gravity.
Both runs: the droplet is the set of lattice points (i + 1/2) dx inside the sphere, its
surface a support radius R = 3 dx above the wall top z = 0; the wall is 3 layers of Adami
particles.  Time t_c = D / v.  Recorded every 0.1 t_c: the spread diameter 2 max r over the
fluid particles and the mass-weighted radius sqrt(sum m r^2 / sum m).

Axisymmetric options (all on by default; flags turn them off): the Shepard-averaged hoop
term v_r / r in the continuity (``--pointwise-hoop``: the particle's own, which blows up
near the axis at ~0.9 t_c), the free-slip ghost velocity of the wall plane (normal e_z) in
the continuity's divergence (``--no-wall-normals``: rings sink through the wall layers and
the spread is 20-25 % short), h_i ~ sqrt(A_i) (``--fixed-h``).

    python examples/axisymmetric/droplet_crosscheck.py axi --dx 6.25e-6 --out axi.json
    python examples/axisymmetric/droplet_crosscheck.py 3d  --dx 6.25e-6 --out 3d.json
    python examples/axisymmetric/droplet_crosscheck.py compare axi.json 3d.json
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

D, V, RHO, MU, C0 = 1.0e-4, 10.0, 1000.0, 1.0e-3, 100.0
T_C = D / V


def params():
    from sphfem.fluid.wcsph import FluidParams

    return FluidParams(rho0=RHO, c0=C0, mu=MU, delta=0.1, alpha=0.02)


def lattice_sphere(dx, dim):
    """Lattice points (i + 1/2) dx inside the sphere of diameter D (3D) or its meridian
    half-disc (axisymmetric, r > 0), centred so its surface lies R = 3 dx above z = 0."""
    n = int(math.ceil(0.5 * D / dx)) + 1
    g = (np.arange(-n, n) + 0.5) * dx
    zc = 3.0 * dx + 0.5 * D
    if dim == 2:
        r = g[g > 0]
        rr, zz = np.meshgrid(r, g, indexing="ij")
        pts = np.column_stack([rr.ravel(), zz.ravel()])
    else:
        pts = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    pts = pts[(pts**2).sum(axis=1) <= (0.5 * D) ** 2]
    pts[:, -1] += zc
    return pts


def wall(dx, dim, half_width, layers=3):
    g = (np.arange(-int(round(half_width / dx)), int(round(half_width / dx))) + 0.5) * dx
    zl = -(np.arange(layers) + 0.5) * dx
    if dim == 2:
        rr, zz = np.meshgrid(g[g > 0], zl, indexing="ij")
        return np.column_stack([rr.ravel(), zz.ravel()])
    xx, yy, zz = np.meshgrid(g, g, zl, indexing="ij")
    return np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])


#: columns of a history row
COLUMNS = ("t/tc", "2 max r/D", "r_rms/D", "2 r50/D", "2 r90/D", "2 r99/D", "2 r_wall/D",
           "h_top/D", "max|v|/V", "z_min/dx", "p_min/(rho V^2)")


def record(t, r, z, m, v, dx, p):
    """One history row (:data:`COLUMNS`): radii over the fluid's mass (r_rms = sqrt(sum m r^2
    / sum m); rq the radius holding q % of the mass), r_wall the largest r of a particle within
    1.5 dx of the wall (z < 1.5 dx), h_top the largest z (droplet top)."""
    o = np.argsort(r)
    cm = np.cumsum(m[o]) / m.sum()
    rq = [r[o][min(np.searchsorted(cm, q), len(r) - 1)] for q in (0.5, 0.9, 0.99)]
    near = z < 1.5 * dx
    rw = r[near].max() if near.any() else 0.0
    return (t / T_C, 2 * r.max() / D, math.sqrt((m * r * r).sum() / m.sum()) / D,
            *(2 * q / D for q in rq), 2 * rw / D, z.max() / D,
            float(np.sqrt((v * v).sum(axis=1)).max()) / V, z.min() / dx, p.min() / (RHO * V * V))


def run_axi(dx, t_end_tc, half_width, smooth_hoop=True, wall_normals=True,
            adaptive_h=True):
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.particles import FLUID, WALL

    xf, xw = lattice_sphere(dx, 2), wall(dx, 2, half_width)
    x = np.vstack([xf, xw])
    kind = np.r_[np.full(len(xf), FLUID), np.full(len(xw), WALL)].astype(np.int8)
    v = np.zeros_like(x)
    v[: len(xf), 1] = -V
    M = np.r_[2 * math.pi * xf[:, 0] * RHO * dx * dx, np.zeros(len(xw))]
    t0 = time.perf_counter()
    nrm = None
    if wall_normals:  # the wall plane z = 0: n = e_z
        nrm = np.zeros_like(x)
        nrm[len(xf):, 1] = 1.0
    f = AxisymmetricFluid(x, v, np.full(len(x), RHO), kind, M, dx * dx, 3 * dx, params(),
                          smooth_hoop=smooth_hoop, wall_normals=nrm, adaptive_h=adaptive_h)
    hist = []

    def rec(s):
        fl = s.fluid
        hist.append(record(s.t, s.x[fl, 0], s.x[fl, 1], s.M[fl], s.v[fl], dx, s.p[fl]))

    rec(f)
    f.run(t_end_tc * T_C, rec, every=0.1 * T_C)
    return dict(mode="axi", smooth_hoop=smooth_hoop, wall_normals=wall_normals,
                adaptive_h=adaptive_h, dx=dx, fluid=int(len(xf)), wall=int(len(xw)),
                steps=f.step_count,
                seconds=time.perf_counter() - t0, history=hist)


def run_3d(dx, t_end_tc, half_width):
    from sphfem.fluid.wcsph import FluidSolver
    from sphfem.particles import FLUID, WALL, ParticleSet

    xf, xw = lattice_sphere(dx, 3), wall(dx, 3, half_width)
    x = np.vstack([xf, xw])
    kind = np.r_[np.full(len(xf), FLUID), np.full(len(xw), WALL)].astype(np.int8)
    ps = ParticleSet.from_arrays(x, rho=RHO, vol=dx**3, kind=kind)
    lo = [-half_width - 3 * dx] * 2 + [-4 * dx]
    hi = [half_width + 3 * dx] * 2 + [D + 8 * dx]
    ps.add_field("v", 3)[kind == FLUID, 2] = -V
    t0 = time.perf_counter()
    s = FluidSolver(ps, 3 * dx, lo, hi, params=params())
    hist = []

    def rec(sol):
        fl = sol.p.kind == FLUID
        x = sol.p.x[fl]
        hist.append(record(sol.t, np.hypot(x[:, 0], x[:, 1]), x[:, 2], sol.p.m[fl],
                           sol.p.v[fl], dx, sol.p.p[fl]))

    rec(s)
    s.run(t_end_tc * T_C, rec, every=0.1 * T_C)
    return dict(mode="3d", dx=dx, fluid=int(len(xf)), wall=int(len(xw)), steps=s.step_count,
                seconds=time.perf_counter() - t0, history=hist)


def compare(a, b, cols=(2, 4, 5, 6, 7)):
    """Print the two histories side by side every 0.5 t_c and the largest relative
    differences over t >= t_c of the columns ``cols``."""
    ha, hb = np.array(a["history"]), np.array(b["history"])
    k = min(len(ha), len(hb))
    for r in (a, b):
        print(f"{r['mode']}: dx {r['dx']:.3g} m, {r['fluid']} fluid + {r['wall']} wall "
              f"particles, {r['steps']} steps, {r['seconds']:.0f} s")
    print("  t/tc  " + "  ".join(f"{COLUMNS[c]:>17s}" for c in cols))
    for i in range(0, k, 5):
        print(f"  {ha[i, 0]:4.1f}  " + "  ".join(
            f"{ha[i, c]:6.3f} {hb[i, c]:6.3f} {100 * (ha[i, c] / hb[i, c] - 1):+4.0f}%"
            for c in cols))
    late = ha[:k, 0] >= 1.0
    for c in cols:
        d = np.abs(ha[:k, c] / hb[:k, c] - 1)[late]
        print(f"  t >= tc: {COLUMNS[c]}: max |difference| {100 * d.max():.1f} %")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["axi", "3d", "compare"])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--dx", type=float, default=6.25e-6)
    ap.add_argument("--tc", type=float, default=4.0, help="end time in t_c")
    ap.add_argument("--half-width", type=float, default=0.3e-3)
    ap.add_argument("--out")
    ap.add_argument("--pointwise-hoop", action="store_true",
                    help="axi: the hoop term v_r,i / r_i of the particle itself (old default)")
    ap.add_argument("--no-wall-normals", action="store_true",
                    help="axi: the wall's own velocity in the continuity (not the free-slip "
                         "ghost)")
    ap.add_argument("--fixed-h", action="store_true", help="axi: h fixed (not ~ sqrt(A_i))")
    a = ap.parse_args()
    if a.mode == "compare":
        compare(*(json.load(open(f)) for f in a.files))
        return
    if a.mode == "axi":
        res = run_axi(a.dx, a.tc, a.half_width, not a.pointwise_hoop, not a.no_wall_normals,
                      not a.fixed_h)
    else:
        res = run_3d(a.dx, a.tc, a.half_width)
    print(json.dumps({k: v for k, v in res.items() if k != "history"}))
    if a.out:
        with open(a.out, "w") as fh:
            json.dump(res, fh)


if __name__ == "__main__":
    main()
