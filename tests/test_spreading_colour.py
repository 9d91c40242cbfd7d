"""The colour contact radius of sphfem.fluid.spreading on prescribed particle sets."""

import math

import numpy as np
import pytest

from sphfem.fluid.spreading import colour_contact_radius, wall_colour, wendland_c2_2d
from sphfem.validation.richardson import observed_order, richardson


def slab(a, dx, H, partial=True):
    """Meridian lattice of a fluid cylinder of radius a and height H on the wall z = 0
    (rings at (i + 1/2) dx with area dx^2); ``partial``: a last column of width
    a - floor(a / dx) dx at its centre with that share of the area, so the fluid's edge is
    at r = a exactly; otherwise the edge is floor(a / dx) dx."""
    n = int(math.floor(a / dx))
    w = a - n * dx
    r, A = list((np.arange(n) + 0.5) * dx), [dx * dx] * n
    if partial and w > 1e-12 * dx:
        r.append(n * dx + 0.5 * w)
        A.append(w * dx)
    z = (np.arange(int(round(H / dx))) + 0.5) * dx
    rr, zz = np.meshgrid(r, z, indexing="ij")
    return rr.ravel(), zz.ravel(), np.repeat(np.asarray(A)[:, None], len(z), 1).ravel()


def test_kernel_integrates_to_one():
    R = 0.7
    g = np.linspace(-R, R, 801)
    xx, yy = np.meshgrid(g, g)
    integral = wendland_c2_2d(np.hypot(xx, yy), R).sum() * (g[1] - g[0]) ** 2
    assert integral == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("axis_mirror", [True, False])
@pytest.mark.parametrize("n", [8, 16, 32])
def test_lattice_edge_without_dx_offset(n, axis_mirror):
    """A lattice of cells dx wide ends at N dx: the crossing lies there to 0.005 dx (the
    lattice-sum error of the kernel), with or without the images in the axis."""
    a, dx = 1.0, 1.0 / (n + 0.3)
    r, z, A = slab(a, dx, 0.5, partial=False)
    edge = math.floor(a / dx) * dx
    rc = colour_contact_radius(r + (0.0 if axis_mirror else 3.0), z, A, 0.0, 3 * dx,
                               axis_mirror=axis_mirror) - (0.0 if axis_mirror else 3.0)
    assert abs(rc - edge) < 5e-3 * dx


def test_colour_is_one_under_thick_fluid_and_zero_outside():
    dx = 1.0 / 20.3
    r, z, A = slab(1.0, dx, 0.5, partial=False)
    c = wall_colour([0.0, 0.3, 0.6, 1.0 + 3 * dx], r, z, A, 0.0, 3 * dx)
    assert np.allclose(c[:3], 1.0, atol=1e-2) and c[3] == 0.0


def test_partial_cell_edge_converges_to_the_radius():
    """Edge at r = a inside a cell: error -0.020 dx, first order; the Richardson limit of
    four spacings is a to 1e-5 a."""
    a = 1.0
    hs = [1.0 / (n + 0.3) for n in (8, 16, 32, 64)]
    f = [colour_contact_radius(*slab(a, h, 0.5), 0.0, 3 * h) for h in hs]
    err = np.abs(np.array(f) - a) / np.array(hs)
    assert err.max() < 0.03
    p = observed_order(hs[-3:], f[-3:])
    assert p == pytest.approx(1.0, abs=0.05)
    assert richardson(hs, f).value == pytest.approx(a, rel=1e-5)


def test_film_thinner_than_a_fifth_of_R_reads_dry():
    """c = 2 int_0^t m(z) dz for a film of thickness t (m the kernel's marginal): above
    1/2 for t = R / 3, below for t = R / 10 (no crossing: radius 0)."""
    R = 1.0
    dx = R / 30
    for t, wet in ((R / 3, True), (R / 10, False)):
        r, z, A = slab(5.0, dx, t, partial=False)
        rc = colour_contact_radius(r, z, A, 0.0, R)
        assert (rc > 4.0) == wet
        assert rc == 0.0 or wet


def test_no_fluid_near_the_wall():
    assert colour_contact_radius([1.0], [5.0], [0.01], 0.0, 1.0) == 0.0
