"""The surface-stress model of sphfem.fluid.axisymmetric_surface_stress: the pull on the end
of a flat film is the exact line force whatever its thickness and end shape (2 sigma free,
sigma on a 90-degree wall), and a retracting free film gains exactly that impulse."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from sphfem.fluid.axisymmetric import AxisymmetricFluid
from sphfem.fluid.wcsph import FluidParams
from sphfem.particles import FLUID, WALL

SIGMA, DX, LENGTH = 0.072, 1e-6, 40


def end_pull(rows, wall, rounded):
    """Surface force on the outer half of a film `rows` thick over its exact line force."""
    t = rows * DX
    pts = []
    for i in range(LENGTH):
        for j in range(rows):
            x, z = (i + 0.5) * DX, (j + 0.5) * DX
            if rounded:  # half disc (free) or quarter disc (on the wall) of radius t / 2, t
                a = 0.5 * t if not wall else t
                xc, zc = LENGTH * DX - a, (0.5 * t if not wall else 0.0)
                if x > xc and (x - xc) ** 2 + (z - zc) ** 2 > a * a:
                    continue
            pts.append((x, z))
    fl = np.array(pts)
    wl = (np.array([((i + 0.5) * DX, -(j + 0.5) * DX) for i in range(LENGTH + 12)
                    for j in range(3)]) if wall else np.zeros((0, 2)))
    x = np.vstack([fl, wl])
    n, nf = len(x), len(fl)
    kind = np.r_[np.full(nf, FLUID), np.full(len(wl), WALL)].astype(np.int8)
    pa = FluidParams(rho0=1000.0, c0=5.0, mu=1e-3, delta=0.1, alpha=0.0, gravity=(0.0, 0.0))
    acc = []
    for s in (SIGMA, 0.0):
        f = AxisymmetricFluid(x, np.zeros((n, 2)), np.full(n, 1000.0), kind, 1000.0 * DX * DX,
                              DX * DX, 3.0 * DX, pa, planar=True, surface_tension=s,
                              csf_meridian="stress", wall_friction="none",
                              stress_plane=0.0 if wall else None)
        f.evaluate()
        acc.append(f.acc.copy())
    force = (acc[0] - acc[1])[:nf] * 1000.0 * DX * DX
    out = fl[:, 0] > 0.5 * LENGTH * DX
    line = SIGMA if wall else 2.0 * SIGMA
    return -force[out, 0].sum() / line, force.sum(axis=0) / line


@pytest.mark.parametrize("rows", [1, 2, 4, 8])
@pytest.mark.parametrize("wall", [False, True])
@pytest.mark.parametrize("rounded", [False, True])
def test_film_end_pull_is_the_line_force(rows, wall, rounded):
    """The line force for any thickness and end shape, where the CSF gets 0.12-1.35
    (film_edge_force.py): 0.994 without the artificial stress (the 1D quadrature of the
    kernel at R = 3 dx), 0.955-0.977 with it (eps = 0.3, its lattice gain; 0.887 for a free
    film one row thick); free, the whole film's force is the flux through its symmetry
    plane x = 0 (the same line force: the stress divergence is antisymmetric) and none
    across it."""
    from sphfem.fluid import axisymmetric_surface_stress as ss

    pull, total = end_pull(rows, wall, rounded)
    lo = 0.88 if rows == 1 else 0.95
    assert lo <= pull <= 1.0
    if not wall:
        assert abs(total[0]) == pytest.approx(pull, abs=0.005)
        assert abs(total[1]) < 1e-9
    eps, ss.ART_EPS = ss.ART_EPS, 0.0
    try:
        assert end_pull(rows, wall, rounded)[0] == pytest.approx(0.994, abs=0.005)
    finally:
        ss.ART_EPS = eps


def test_retracting_film_impulse():
    """Taylor-Culick retraction of a free film 4 rows thick: its x momentum is a constant
    fraction of 2 sigma t (the static pull's, within 1 %) at every frame: the end is pulled
    by the line force however the rim deforms."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples" / "axisymmetric"))
    import taylor_culick

    t, d, speed, _, mom = taylor_culick.retraction(4, "stress", length=10, t_end=3,
                                                   drift="removed", c0_factor=30)
    pull = end_pull(4, False, False)[0]
    assert np.all(np.abs(mom[t > 0] - pull) < 0.01 * pull)
    assert d[-1] > 1.0  # it retracts
    assert math.isfinite(speed)


def test_dewetting_wall_film_impulse():
    """A film 4 rows thick dewetting a free-slip wall at 90 degrees (taylor_culick.py
    --wall): its end is pulled by sigma, so its momentum is sigma t; measured 0.96-0.98 of it
    (length 20 h, to 8 h / V; the CSF 0.42-0.89, the pair force 1.03-1.18), within 8 % here
    from 2 h / V on, and the rim stays on the wall (lift below a quarter of h)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples" / "axisymmetric"))
    import taylor_culick

    t, d, speed, _, mom, lift = taylor_culick.retraction(
        4, "stress", length=10, t_end=4, wall=True, drift="removed", c0_factor=30)
    late = t >= 2.0
    assert np.all(np.abs(mom[late] - 1.0) < 0.08), mom
    assert lift.max() < 0.25
    assert d[-1] > 1.0
