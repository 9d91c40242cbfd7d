"""The unresolved wall layer of sphfem.fluid.wall_layer: its lattice constant against the
solver's wall term, its thickness equation against exact solutions, and Stokes' first problem
at a spacing coarser than the layer."""

import math

import numpy as np
import pytest

from sphfem.fluid.axisymmetric import AxisymmetricFluid
from sphfem.fluid.wall_layer import (
    advance_layer,
    contact_line_weight,
    friction_factor,
    plug_traction_constant,
)
from sphfem.fluid.wcsph import FluidParams
from sphfem.particles import FLUID, WALL

RHO, U = 1000.0, 0.5


def channel(N=12, dx=1e-6):
    """Fluid r in (0, N dx), three wall columns beyond, z periodic over N dx; the fluid
    slides at U along z (planar mode: the axis is a symmetry plane)."""
    r = (np.arange(N + 3) + 0.5) * dx
    z = (np.arange(N) + 0.5) * dx
    rr, zz = np.meshgrid(r, z, indexing="ij")
    x = np.column_stack([rr.ravel(), zz.ravel()])
    kind = np.where(x[:, 0] < N * dx, FLUID, WALL).astype(np.int8)
    v = np.zeros_like(x)
    v[kind == FLUID, 1] = U
    nrm = np.zeros_like(x)
    nrm[kind == WALL, 0] = -1.0
    return x, v, kind, nrm, N * dx


def solver(x, v, kind, nrm, Lz, dx, mu, friction):
    pa = FluidParams(rho0=RHO, c0=10.0, mu=mu, delta=0.0)
    n = len(x)
    return AxisymmetricFluid(x, v, np.full(n, RHO), kind, RHO * dx * dx, dx * dx, 3 * dx, pa,
                             planar=True, periodic_z=(0.0, Lz), wall_normals=nrm,
                             wall_friction=friction)


def test_plug_constant_is_the_solver_wall_term():
    """Eq. (1): the solver's summed wall term on a plug over the wall, per unit wall length,
    is S mu U / dx with S of plug_traction_constant (to round-off: both are the same lattice
    sum; the Adami ghost velocity of a uniform fluid is -U)."""
    dx, mu = 1e-6, 1e-3
    x, v, kind, nrm, Lz = channel(dx=dx)
    s = solver(x, v, kind, nrm, Lz, dx, mu, "viscous")
    s.evaluate()
    fl = kind == FLUID
    traction = -(RHO * dx * dx * s.acc[fl, 1]).sum() / Lz
    S = plug_traction_constant("wendland_c2", 3.0, s.params.eps_visc)
    assert traction == pytest.approx(S * mu * U / dx, rel=1e-9)
    assert S == pytest.approx(1.682, abs=1e-3)


def test_free_slip_wall_keeps_the_plug():
    """``wall_friction = "none"``: a plug sliding along the wall keeps its momentum to
    round-off (no viscous or artificial term on wall pairs), while the no-slip term slows it."""
    dx, mu = 1e-6, 1e-3
    x, v, kind, nrm, Lz = channel(dx=dx)
    fl = kind == FLUID
    lost = {}
    for friction in ("none", "viscous"):
        s = solver(x, v, kind, nrm, Lz, dx, mu, friction)
        s.evaluate()
        for _ in range(20):
            s.step(s.stable_dt())
        lost[friction] = 1.0 - s.v[fl, 1].mean() / U
    assert abs(lost["none"]) < 1e-12
    assert lost["viscous"] > 1e-3


def test_layer_equation_exact_solutions():
    """Eq. (2) for constant a: a = 0 gives delta^2 = pi nu t (Stokes' first problem) and
    a > 0 relaxes to pi nu / (2 a); both to round-off from the exact step; a row entering
    the band takes its band neighbours' kernel average; one leaving forgets its layer."""
    nu, dt = 1e-6, 1e-7
    x = np.array([[0.0, 0.0], [0.5, 0.0], [5.0, 0.0]])
    offsets = np.array([0, 1, 2, 3])
    indices = np.array([1, 0, 2])
    Rp = np.ones(3)
    from sphfem import kernels

    kc = kernels.kernel_code("wendland_c2")
    for a_val, exact in ((0.0, lambda t: math.pi * nu * t),
                         (2e4, lambda t: math.pi * nu / 4e4 * (1 - math.exp(-4e4 * t)))):
        d2 = np.array([0.0, -1.0, 0.0])
        band = np.array([1, 0, 1], np.int8)
        a = np.full(3, a_val)
        for _ in range(200):
            advance_layer(d2, band, a, nu, dt, 1.0, x, offsets, indices, Rp, kc)
        assert d2[0] == pytest.approx(exact(200 * dt), rel=1e-9)
        assert d2[1] == -1.0
    d2 = np.array([3e-12, -1.0, 1e-12])
    advance_layer(d2, np.array([1, 1, 0], np.int8), np.zeros(3), nu, dt, 1.0, x, offsets,
                  indices, Rp, kc)
    assert d2[1] == pytest.approx(3e-12, rel=1e-12)  # entered: its band neighbour's layer
    assert d2[2] == -1.0  # left the band


def test_friction_factor_limits():
    """f = dx / (S delta) while the layer is thinner than dx / S, 1 beyond and outside the
    band, capped by the viscous step limit."""
    dx, S, nu, h = 1e-6, 1.66, 1e-6, 1.5e-6
    d2 = np.array([-1.0, (0.1 * dx) ** 2, dx**2, 0.0])
    f = friction_factor(d2, dx, S, nu, 1e-12, h, 0.125)
    assert f[0] == 1.0 and f[2] == 1.0
    assert f[1] == pytest.approx(1.0 / (0.1 * S))
    assert f[3] == pytest.approx(dx / (S * math.sqrt(0.25 * math.pi * nu * 1e-12)))
    dt = 0.25 * dx * dx / nu  # the cap (1.125) below the floor's factor (2.4)
    assert friction_factor(d2, dx, S, nu, dt, h, 0.125)[3] == pytest.approx(
        0.125 * h * h / (nu * dt))


def stokes_deficit(friction, t_end, nu, dx=1e-6):
    x, v, kind, nrm, Lz = channel(dx=dx)
    s = solver(x, v, kind, nrm, Lz, dx, RHO * nu, friction)
    s.evaluate()
    t = 0.0
    while t < t_end - 1e-18:
        dt = min(s.stable_dt(), t_end - t)
        s.step(dt)
        t += dt
    fl = kind == FLUID
    return (RHO * dx * dx * (U - s.v[fl, 1])).sum() / Lz


@pytest.mark.parametrize("layer_dx", [0.3, 1.0])
def test_stokes_first_problem_below_the_spacing(layer_dx):
    """Fluid sliding at U over a wall at rest from t = 0: the momentum it loses per unit wall
    area is 2 rho U sqrt(nu t / pi) (Rayleigh; Schlichting & Gersten 2017, sec. 5.3.1).  At
    sqrt(pi nu t) = 0.3 dx and 1 dx the layer model gets it within 15 % (measured 0.947 and
    0.875 of it; at 3 dx 1.107); the plain no-slip wall term, a layer ~0.6 dx thick, gets
    0.247 and 0.687 of it."""
    dx, nu = 1e-6, 1e-8
    t_end = (layer_dx * dx) ** 2 / (math.pi * nu)
    exact = 2 * RHO * U * math.sqrt(nu * t_end / math.pi)
    layer = stokes_deficit("layer", t_end, nu, dx)
    plain = stokes_deficit("viscous", t_end, nu, dx)
    assert layer / exact == pytest.approx(1.0, abs=0.15)
    assert plain / exact < 0.75
    assert abs(layer / exact - 1.0) < abs(plain / exact - 1.0)


def test_scene_key_is_axisymmetric_only():
    """`[fluid] wall_friction` other than "sph" in a 3D scene is refused with its key named;
    the axisymmetric scene takes it."""
    import tomllib
    from importlib import resources
    from pathlib import Path

    from sphfem.errors import SceneError
    from sphfem.scene import parse_scene

    root = Path(__file__).resolve().parents[1]
    d = tomllib.loads((root / "examples/droplet_impact/droplet_impact.toml").read_text())
    d["fluid"]["wall_friction"] = "layer"
    with pytest.raises(SceneError, match="fluid.wall_friction"):
        parse_scene(d, source="3d")
    ax = tomllib.loads(resources.files("sphfem.scenes").joinpath(
        "droplet_impact_axisymmetric.toml").read_text())
    assert parse_scene(ax, source="axisymmetric").fluid.wall_friction == "layer"  # default
    ax["fluid"]["wall_friction"] = "viscous"
    assert parse_scene(ax, source="axisymmetric").fluid.wall_friction == "viscous"


def _lists(x, R):
    from scipy.spatial import cKDTree

    nb = cKDTree(x).query_ball_point(x, 1.1 * R)
    off = np.zeros(len(x) + 1, np.int64)
    off[1:] = np.cumsum([len(b) for b in nb])
    return off, np.concatenate([np.sort(b) for b in nb]).astype(np.int64)


def test_contact_line_weight_marks_the_end_of_each_wall_row():
    """A 12 x 3 lattice film (wall normal +z): the end column of each row has weight 1, every
    other ring 0 (one ring behind the end s = 0.09 < 0.35); a ring alone in its layer 1;
    rows off the band 0."""
    from sphfem import kernels

    x = np.array([(i + 0.5, j + 0.5) for i in range(12) for j in range(3)]
                 + [(30.0, 0.5)])
    n, R = len(x), 3.0
    off, ind = _lists(x, R)
    band = np.ones(n, np.int8)
    band[1] = 0
    out = np.zeros(n)
    contact_line_weight(x, np.ones(n, bool), off, ind, band, np.tile([0.0, 1.0], (n, 1)), n,
                        np.full(n, R), kernels.kernel_code("wendland_c2"), 0.75,
                        np.zeros(2), out)
    w = out[:-1].reshape(12, 3)
    assert np.all(w[[0, -1], :].ravel()[[0, 2, 3, 4, 5]] == 1.0)  # (0, 1) is off the band
    assert out[1] == 0.0
    assert np.all(w[1:-1] == 0.0)
    assert out[-1] == 1.0


def test_layer_friction_is_lifted_at_the_contact_line():
    """A film 12 x 3 rings sliding at U over a wall (planar, not periodic): after the first
    steps the young layer brakes the film's interior (f > 1) while the rings at the film's
    two ends along the wall, its contact lines, feel the plain wall term (f = 1)."""
    dx, nu = 1e-6, 1e-6
    N = 12
    xf = np.array([((i + 10.5) * dx, (j + 0.5) * dx) for i in range(N) for j in range(3)])
    xw = np.array([((i + 0.5) * dx, -(j + 0.5) * dx) for i in range(N + 20) for j in range(3)])
    x = np.vstack([xf, xw])
    kind = np.r_[np.full(len(xf), FLUID), np.full(len(xw), WALL)].astype(np.int8)
    v = np.zeros_like(x)
    v[kind == FLUID, 0] = U
    nrm = np.zeros_like(x)
    nrm[kind == WALL, 1] = 1.0
    pa = FluidParams(rho0=RHO, c0=10.0, mu=RHO * nu, delta=0.0)
    s = AxisymmetricFluid(x, v, np.full(len(x), RHO), kind, RHO * dx * dx, dx * dx, 3 * dx,
                          pa, planar=True, wall_normals=nrm, wall_friction="layer")
    s.evaluate()
    for _ in range(3):
        s.step(0.2 * s.stable_dt())
    ends = np.isin(np.round(xf[:, 0] / dx - 0.5).astype(int), (10, 10 + N - 1))
    bottom = xf[:, 1] < dx
    assert np.all(s.contact_line[:len(xf)][ends & bottom] > 0.99)
    assert np.all(s.fw[:len(xf)][ends & bottom] == 1.0)
    assert np.all(s.contact_line[:len(xf)][~ends] == 0.0)
    assert np.all(s.fw[:len(xf)][~ends & bottom] > 1.5)
