"""Taylor-Culick retraction of a free liquid film: the rim's pull, against the exact speed.

    python examples/axisymmetric/taylor_culick.py [--rows 4 8] [--meridian csf pair]

A flat film h thick (``rows`` particles across), at rest, ends at x = L (the planar mode of
:class:`sphfem.fluid.axisymmetric.AxisymmetricFluid`: the (r, z) plane without hoop terms,
a symmetry plane at x = 0).  Surface tension pulls its end back; the fluid gathers into a
rim that moves, once it has gathered more than its own start, at the speed of Taylor (1959)
and Culick (1960),

    V_TC = sqrt(2 sigma / (rho h)),

whatever the viscosity (momentum: d(m V)/dt = 2 sigma with m = rho h x).  Water-like film
h = 8 um, sigma = 0.072 N/m, mu = 1e-3 Pa s (Oh = 0.04), c0 = 10 V_TC, the impact scene's
fluid options; the speed is the slope of the retracted length over the second half of the
run (10-20 h / V_TC), and the film's x momentum is compared with 2 sigma t (the exact line
force's impulse: a force of the right size gives it whatever the rim's shape).

Measured (this machine, 2026-12-04, the command above):

* CSF (``csf``): the film's end is yanked back into the film, its rows are wedged apart,
  the rim forms hollow and sprays: 0.59 V_TC at 4 rows and slowing (0.30 over 12-24 h /
  V_TC); at 8 rows the retraction stops at 4.7 h and spray then flies outward (speed
  -1.7).  Its momentum is 1.29-1.74 x 2 sigma t at 4 rows: the CSF's total force is not
  the line force (it comes from the curvature of the few rings at the film's end and at
  the neck) and the surplus goes into spray.
* pair force (``pair``, :mod:`sphfem.fluid.axisymmetric_pair_tension`): the rim is a
  compact disc and the speed steady, 0.84 / 0.83 V_TC at 4 / 8 rows (retracted 16.0 / 16.1
  h by 20 h / V_TC); momentum 0.86-0.91 x 2 sigma t at 4 rows.
* The planar solver (``surface_tension = "csf"``) shows the same failure of the CSF; its
  Akinci model a compact rim at 0.85 / 0.88 / 0.70 V_TC at 4 / 8 / 16 rows.

Session 19 (2026-12-05, ``--length 20 --t-end 8``; the film's end now the 99th percentile
of x, so spray ahead of the rim does not count): the hollow rim is the lattice's rows
carried into the rim as strings, which the shifting (projected on the surface for every
ring of a thin film, lambda < 0.75) cannot undo.  CSF at 4 rows: 1.01 V_TC but momentum
1.48-1.74 x 2 sigma t, hollow; ``--film --shifting 5 --surface-lambda 0.5``: 0.84 V_TC,
momentum 1.01-1.10, compact filled rim; CSF at 8 rows with ``--shifting 5
--surface-lambda 0.5``: 0.73 V_TC, 0.68-1.14, a compact disc
(docs/validation/droplet_impact/README.md, "Session 19").

On a wall (``--wall``, session 22): the film lies on three free-slip wall rows
(``wall_friction = "none"``) and dewets at 90 degrees; the end's line force is then sigma
(the top face's; sigma_sl = sigma_sv), the film's momentum sigma t exactly for a force of
the right size, the speed of inertial dewetting sqrt(sigma / (rho h)) (Culick's balance
with one free face).  Measured with ``--length 20 --t-end 8 --drift removed --mu 1e-3 --c0
30`` (momentum / (sigma t) over t >= 2, speed over sqrt(sigma / (rho h))): CSF 0.42-0.89
at 4 rows (mu 1e-4, c0 10), 0.53-0.77 / speed 0.58 at 8, 0.57-0.88 / 0.33 at 16; pair force
1.03-1.18 / 0.96 at 4 (mu 1e-4), 1.12-1.22 / 0.94 at 8, 1.23-1.69 / 1.05 at 16; the surface
stress (``--meridian stress``, sphfem.fluid.axisymmetric_surface_stress, with its
artificial stress and gain) 0.96-0.98 / 0.79 at 4 rows and 0.93-0.97 / 0.86 at 8, the rim
compact and on the wall (without the artificial stress the 8-row rim is unstable).  The CSF
and the pair force do not get the rim's pull within 10 % at 4-16 rows.  c0 must
exceed the capillary wave speed sqrt(2 pi sigma / (rho R / 2)) (24.6 m/s at 16 rows, h = 8
um): ``--c0 10`` (30 m/s) is marginal there.
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def retraction(rows: int, meridian: str = "pair", h: float = 8e-6, length: float = 40.0,
               t_end: float = 20.0, sigma: float = 0.072, rho0: float = 1000.0,
               mu: float = 1e-3, c0_factor: float = 10.0, film: bool = False,
               shifting: float = 5.0 / 3.0, surface_lambda: float = 0.75,
               wall: bool = False, drift: str = "kept"):
    """Run the free film (module docstring) to ``t_end`` h / V_TC; returns (times in
    h / V_TC, retracted length in h, speed / V_TC over the second half, the solver,
    the film's x momentum / (2 sigma t) at each time).  ``film``: the thin-film line
    tension (``[fluid] film_tension``); ``shifting``, ``surface_lambda``: the shifting's
    A and ``[fluid] shifting_surface_lambda``, ``drift`` its ``shifting_drift``.  The
    retracted length is that of the film's body: its end is the 99th percentile of x (a
    ring of spray does not count).  ``wall``: the film lies on three free-slip wall rows
    (module docstring, "On a wall"); speed and momentum are then over sqrt(sigma / (rho h))
    and sigma t, and a sixth array is returned: the rim's lift, the height [h] of the
    lowest fluid row within 2 h of the film's end above the first row's.
    """
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.wcsph import FluidParams
    from sphfem.particles import FLUID, WALL

    dx = h / rows
    line = sigma if wall else 2.0 * sigma  # the end's line force (90 degrees on the wall)
    V = math.sqrt(line / (rho0 * h))
    L = length * h
    nx = int(round(L / dx))
    z0 = 0.0 if wall else 20 * dx
    x = [((i + 0.5) * dx, z0 + (j + 0.5) * dx) for i in range(nx) for j in range(rows)]
    nf = len(x)
    if wall:  # three rows, reaching a support beyond the film's end
        x += [((i + 0.5) * dx, -(j + 0.5) * dx) for i in range(nx + 4) for j in range(3)]
    x = np.array(x)
    n = len(x)
    kind = np.full(n, FLUID, np.int8)
    kind[nf:] = WALL
    pa = FluidParams(rho0=rho0, c0=c0_factor * V, mu=mu, delta=0.1, alpha=0.02,
                     gravity=(0.0, 0.0))
    f = AxisymmetricFluid(x, np.zeros((n, 2)), np.full(n, rho0), kind,
                          np.where(kind == FLUID, rho0 * dx * dx, 0.0), dx * dx, 3.0 * dx, pa,
                          planar=True, surface_tension=sigma, wall_tension=False,
                          free_surface_no_tension=meridian == "csf", fragment_hoop=False,
                          csf_curvature_smoothing=2.0, shifting=shifting,
                          csf_meridian=meridian, film_tension=film,
                          shift_surface_lambda=surface_lambda, shift_drift=drift,
                          wall_friction="none" if wall else "sph",
                          stress_plane=0.0 if wall else None)
    tc = h / V
    rec = []

    def record(s):
        # the retraction is the only x momentum source: P(t) = -line t exactly for a
        # force of the right size, whatever the rim's shape
        xf = s.x[s.fluid]
        P = float(np.dot(s.M[s.fluid], s.v[s.fluid, 0]))
        end = np.percentile(xf[:, 0], 99.0)
        rim = xf[:, 0] > end - 2.0 * h
        rec.append((s.t / tc, (L - end) / h, -P / (line * s.t) if s.t > 0 else np.nan,
                    (xf[rim, 1].min() - 0.5 * dx) / h))

    f.run(t_end * tc, callback=record, every=tc)
    a = np.array(rec)
    late = a[:, 0] >= 0.5 * a[-1, 0]
    out = (a[:, 0], a[:, 1], float(np.polyfit(a[late, 0], a[late, 1], 1)[0]), f, a[:, 2])
    return out + (a[:, 3],) if wall else out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[4, 8])
    ap.add_argument("--meridian", nargs="+", default=["csf", "pair"],
                    choices=("csf", "pair", "stress"))
    ap.add_argument("--film", action="store_true", help="[fluid] film_tension = true")
    ap.add_argument("--shifting", type=float, default=5.0 / 3.0, help="shifting's A")
    ap.add_argument("--surface-lambda", type=float, default=0.75,
                    help="[fluid] shifting_surface_lambda")
    ap.add_argument("--length", type=float, default=40.0, help="film length [h]")
    ap.add_argument("--t-end", type=float, default=20.0, help="end time [h / V_TC]")
    ap.add_argument("--wall", action="store_true",
                    help="the film on a free-slip wall (dewetting at 90 degrees)")
    ap.add_argument("--drift", default="kept", choices=("kept", "removed"),
                    help="[fluid] shifting_drift")
    ap.add_argument("--mu", type=float, default=1e-3, help="viscosity [Pa s]")
    ap.add_argument("--c0", type=float, default=10.0,
                    help="speed of sound over the retraction speed (it must exceed the "
                         "capillary wave speed sqrt(2 pi sigma / (rho R / 2)))")
    a = ap.parse_args(argv)
    unit, force = ("sqrt(sigma/(rho h))", "sigma t") if a.wall else ("V_TC", "2 sigma t")
    print(f"rows  meridian  speed / {unit}   retracted (h) at 1/4, 1/2, 3/4, 1 of t_end   "
          f"momentum / ({force}) min-max" + ("   rim lift (h) max" if a.wall else ""))
    for k in a.rows:
        for m in a.meridian:
            r = retraction(k, m, length=a.length, t_end=a.t_end, film=a.film,
                           shifting=a.shifting, surface_lambda=a.surface_lambda,
                           wall=a.wall, drift=a.drift, mu=a.mu,
                           c0_factor=a.c0)
            t, d, s, _, mom = r[:5]
            at = [d[np.argmin(abs(t - q * a.t_end))] for q in (0.25, 0.5, 0.75, 1.0)]
            late = mom[t >= 2.0]
            print(f"{k:4d}  {m:8s}  {s:12.3f}   " + " / ".join(f"{v:.2f}" for v in at)
                  + f"   {late.min():.2f}-{late.max():.2f}"
                  + (f"   {r[5].max():.2f}" if a.wall else ""), flush=True)


if __name__ == "__main__":
    main()
