"""The CSF's pull on the end of a flat liquid film, against the line force it should have.

    python examples/axisymmetric/film_edge_force.py [--rows 1 2 3 4 6 8] [--film]

A film k particle rows thick (planar mode of :class:`sphfem.fluid.axisymmetric.
AxisymmetricFluid`, the (r, z) plane far from the axis, R = 3 dx) ends 40 dx from the
symmetry plane, free or lying on three wall rows.  The total surface-tension force on the
particles of its outer half is, by the Frenet formulas (the integral of kappa n along the
free surface is the change of its tangent), a line force per unit length of the edge of

    2 sigma               free film (both faces end at the edge),
    sigma (1 - cos theta) film on a wall (90 degrees for the CSF's wall colour: sigma),

whatever the film's thickness and the shape of its end.  The script prints the CSF's
force over that line force for a square end and for a rounded one.  This is the pull that
stops a spreading lamella's rim (Taylor 1959, Culick 1960): a film thinner than the kernel
support gets much less of it, so a lamella one or two particles thick runs out too far.
Measured (R = 3 dx, Wendland C2), for 1 / 2 / 3 / 4 / 6 / 8 rows: on a wall 0.12 / 0.76 /
1.10 / 1.03 / 0.98 / 0.98 of sigma with a square end, 0.12 / 0.36 / 0.74 / 0.67 / 0.67 /
0.79 with a quarter-disc end; free films 0 for one row, then 1.25-1.35 (square end) and
1.10-1.35 (half-disc end) of 2 sigma.  So the film's edge force is off by 20-35 % at any
thickness (the CSF is a field force, not a divergence: its integral over a region is not
the flux through the region's boundary), and it all but vanishes below two rows.

``--film``: with the CSF's thin-film model (``[fluid] film_tension``; sphfem.fluid.
axisymmetric_surface_tension, "Thin films"): 0.994 for 1 / 2 / 3 / 4 rows in all four
columns; 5 rows and more are the CSF's (0.988 / 0.702 / 1.308 / 1.143 for 5, the 6 and 8 rows
as above).
"""

from __future__ import annotations

import argparse

import numpy as np


def film_edge_force(rows: int, wall: bool, rounded: bool, sigma: float = 0.072,
                    dx: float = 1e-6, length: int = 40, film: bool = False) -> float:
    """The CSF force on the outer half of the film over the edge's line force (module
    docstring; 1 is exact)."""
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.wcsph import FluidParams
    from sphfem.particles import FLUID, WALL

    t = rows * dx
    pts = []
    for i in range(length):
        for j in range(rows):
            x, z = (i + 0.5) * dx, (j + 0.5) * dx
            if rounded:  # a half disc (free) or a quarter disc (on the wall) of radius t / 2
                a = 0.5 * t if not wall else t
                xc, zc = length * dx - a, (0.5 * t if not wall else 0.0)
                if x > xc and (x - xc) ** 2 + (z - zc) ** 2 > a * a:
                    continue
            pts.append((x, z))
    fl = np.array(pts)
    wl = (np.array([((i + 0.5) * dx, -(j + 0.5) * dx) for i in range(length + 12)
                    for j in range(3)]) if wall else np.zeros((0, 2)))
    x = np.vstack([fl, wl])
    n, nf = len(x), len(fl)
    kind = np.r_[np.full(nf, FLUID), np.full(len(wl), WALL)].astype(np.int8)
    normals = np.zeros((n, 2))
    normals[nf:, 1] = 1.0
    pa = FluidParams(rho0=1000.0, c0=5.0, mu=1e-3, delta=0.1, alpha=0.0, gravity=(0.0, 0.0))
    acc = []
    for s in (sigma, 0.0):  # the surface tension's part of the acceleration
        f = AxisymmetricFluid(x, np.zeros((n, 2)), np.full(n, 1000.0), kind, 1000.0 * dx * dx,
                              dx * dx, 3.0 * dx, pa, planar=True, surface_tension=s,
                              wall_normals=normals if wall else None, film_tension=film)
        f.evaluate()
        acc.append(f.acc.copy())
    force = (acc[0] - acc[1])[:nf] * 1000.0 * dx * dx  # planar masses: N per m of depth
    pull = -force[fl[:, 0] > 0.5 * length * dx, 0].sum()
    return pull / (sigma if wall else 2.0 * sigma)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 2, 3, 4, 6, 8])
    ap.add_argument("--film", action="store_true", help="with the CSF's thin-film model")
    a = ap.parse_args(argv)
    print("rows   on a wall: square  rounded   free: square  rounded   (1 = exact)")
    for k in a.rows:
        w = [film_edge_force(k, True, r, film=a.film) for r in (False, True)]
        f = [film_edge_force(k, False, r, film=a.film) for r in (False, True)]
        print(f"{k:4d}   {w[0]:14.3f} {w[1]:8.3f}   {f[0]:12.3f} {f[1]:8.3f}")


if __name__ == "__main__":
    main()
