"""How the droplet's sampling reads to the CSF: the curvature of a static sphere (3D) or
disc (2D) of radius 1 filled by each ``sampling`` of a block (lattice, Poisson, shells),
at the surface particles (the outermost 0.6 dx), against the exact 2 / R (3D) or 1 / R (2D).

    python examples/droplet_impact/sampling_curvature.py [--per-radius N N ...]

A lattice's staircase and a Poisson sample's roughness read as curvature of order 1 / dx
at the scale of the spacing; the CSF's smoothing leaves a bias (the mean) and noise (the
rms): docs/validation/droplet_impact/README.md, session 27.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from sphfem import kernels
from sphfem.fluid.passes import filter_rows
from sphfem.fluid.setup import make_particles
from sphfem.fluid.surface_tension_csf import CSFState
from sphfem.geometry import Shape, lattice_points, poisson_points, shell_points
from sphfem.neighbors import build_neighbor_list


def surface_curvature(x: np.ndarray, dx: float, dim: int) -> np.ndarray:
    """kappa R / (dim - 1) of the outermost particles (within 0.6 dx of the largest radius)
    of the unit ball ``x`` (1 where exact), from the CSF passes with R = 3 dx."""
    n = len(x)
    R = 3.0 * dx
    ps = make_particles(x, None, dx, 1.0)
    vol = math.pi if dim == 2 else 4.0 / 3.0 * math.pi
    V = np.full(n, vol / n)
    nl = build_neighbor_list(x, R, [-2.0] * dim, [2.0] * dim)
    off, idx = filter_rows(nl.offsets, nl.indices, ps.kind)
    st = CSFState(n, dim)
    st.accumulate(x, V, np.ones(n), ps.kind, off, idx, R, kernels.kernel_sigma(0, dim, R), 0,
                  np.zeros(dim), 1.0, np.zeros((n, dim)))
    rr = np.linalg.norm(x, axis=1)
    return st.kappa[rr > rr.max() - 0.6 * dx] / (dim - 1)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-radius", type=int, nargs="+", default=[8, 12])
    a = ap.parse_args(argv)
    print("dim  R/dx  sampling   n      mean   rms err  max |err|   (kappa R / (dim - 1))")
    for dim in (2, 3):
        for nr in a.per_radius:
            dx = 1.0 / nr
            s = Shape.sphere((0.0,) * dim, 1.0)
            for name, x in (("lattice", lattice_points(s, dx, dim)),
                            ("poisson", poisson_points(s, dx, dim, seed=[1, 1])),
                            ("shells", shell_points(s, dx, dim))):
                k = surface_curvature(x, dx, dim)
                print(f"{dim:3d} {nr:5d}  {name:8s} {len(x):6d}  {k.mean():6.3f}  "
                      f"{np.sqrt(((k - 1) ** 2).mean()):7.3f}  {np.abs(k - 1).max():8.3f}")


if __name__ == "__main__":
    main()
