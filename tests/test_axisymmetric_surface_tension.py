"""Axisymmetric CSF surface tension (sphfem.fluid.axisymmetric_surface_tension): the kernels
on prescribed fields (sphere, cylinder, slab; the axis treatment), then the hooked-up fluid
(Laplace pressure of a droplet at rest, Rayleigh's l = 2 oscillation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.axisymmetric import axis_mirrors
from sphfem.fluid.axisymmetric import KEEP, MIRROR_FLUID
from sphfem.fluid.axisymmetric_surface_tension import (
    AxisymmetricCSF,
    half_disc_arcs,
    hoop_curvature,
    mirror_normals,
    mirror_scalar,
)
from sphfem.neighbors import build_neighbor_list
from sphfem.particles import FLUID


def _csf(x, area, dx, Lz=0.0, band=None, sigma=1.0, axis_curvature=False, smoothing=1.0):
    """The CSF passes on real rings ``x`` (meridian areas ``area``, rho = 1) and their axis
    mirrors; support R = 3 dx.  Returns (AxisymmetricCSF, CSF state, acceleration)."""
    n, R = len(x), 3 * dx
    xm, src = axis_mirrors(x, R)
    xa = np.vstack([x, xm])
    kind = np.r_[np.full(n, FLUID), np.full(len(src), MIRROR_FLUID)].astype(np.int8)
    A = np.r_[area, area[src]]
    lo, hi = xa.min(0) - R, xa.max(0) + R
    period = np.zeros(2)
    if Lz:
        lo[1], hi[1], period[1] = 0.0, Lz, Lz
    nl = build_neighbor_list(xa, R, lo, hi, period, kind=kind, keep=KEEP)
    kw = dict(axis_curvature=axis_curvature, curvature_smoothing=smoothing)
    csf = (AxisymmetricCSF(sigma, **kw) if band is None
           else AxisymmetricCSF(sigma, axis_band=band, **kw))
    acc = np.zeros((n, 2))
    st = csf.accumulate(xa, A, np.ones(len(xa)), kind, nl.offsets, nl.indices, n,
                        src.astype(np.int64), np.zeros(len(src), np.int8), R, Lz, acc)
    return csf, st, acc


def test_mirror_normals_parity():
    """Axis images negate g_r, wall-plane images g_z; a mirror of a mirror chains."""
    g = np.zeros((5, 2))
    g[:2] = [[1.0, 2.0], [3.0, 4.0]]
    om = np.r_[0.5, 1.0, 0.0, 0.0, 0.0]
    mirror_normals(2, np.array([0, 1, 3]), np.array([0, 1, 0], np.int8), g, om)
    np.testing.assert_array_equal(g[2:], [[-1.0, 2.0], [3.0, -4.0], [-3.0, -4.0]])
    np.testing.assert_array_equal(om[2:], [0.5, 1.0, 1.0])


def test_mirror_scalar_copies_in_order():
    """A mirror of a mirror takes the value its source got."""
    a = np.r_[1.0, 2.0, 0.0, 0.0]
    mirror_scalar(2, np.array([1, 2]), a)
    np.testing.assert_array_equal(a, [1.0, 2.0, 2.0, 2.0])


def test_planar_mode_equals_the_2d_csf():
    """planar=True with surface tension (no hoop part, the axis mirrors a symmetry plane)
    reproduces the 2D FluidSolver with surface_tension = "csf" on the full symmetric disc (R0
    = 0.5 mm, R0/dx = 10, a strain v = V (x, -y) / R0, 100 steps): positions agree to 1e-10
    dx (measured 3e-15; 0.04 dx if the axisymmetric run leaves the CSF out): normals,
    weights and curvatures cross the symmetry plane with the right parity."""
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.wcsph import FluidParams, FluidSolver
    from sphfem.particles import ParticleSet

    R0, dx, V = 0.5e-3, 0.05e-3, 0.05
    half, a = half_disc_arcs(R0, dx)
    nf = len(half)
    pa = FluidParams(rho0=1000.0, c0=5.0, mu=1e-3, delta=0.1, alpha=0.02, gravity=(0.0, 0.0),
                     surface_tension="csf", sigma=0.072)
    v = V * half * [1.0, -1.0] / R0
    ax = AxisymmetricFluid(half, v, np.full(nf, 1000.0), np.full(nf, FLUID), 1000.0 * a, 0.0,
                           3 * dx, pa, planar=True, surface_tension=0.072)
    ps = ParticleSet.from_arrays(np.vstack([half, half * [-1, 1]]), rho=1000.0,
                                 vol=np.r_[a, a], kind=np.full(2 * nf, FLUID).astype(np.int8))
    ps.add_field("v", 2)[:] = np.vstack([v, v * [-1, 1]])
    s2 = FluidSolver(ps, 3 * dx, [-2 * R0] * 2, [2 * R0] * 2, params=pa)
    dt = 0.5 * ax.stable_dt()
    for _ in range(100):
        ax.step(dt)
        s2.step(dt)
    x2 = s2.p.x[np.argsort(s2.p.id)][:nf]
    assert np.abs(ax.x - half).max() > 0.1 * dx  # it moved
    assert np.abs(ax.x - x2).max() < 1e-10 * dx


def test_hoop_curvature_blend():
    """-n_r / r away from the axis, kappa_m at the axis, the smoothstep between."""
    r = np.array([0.1, 1.0, 2.0, 3.0])
    g = np.array([[-0.6, 0.8]] * 4)
    km = np.full(4, 7.0)
    out = np.zeros(4)
    hoop_curvature(r, g, np.r_[1.0, 1.0, 1.0, 0.0], km, 0.5, 1.5, out)
    np.testing.assert_allclose(out, [7.0, 0.5 * 0.6 + 0.5 * 7.0, 0.3, 0.0])


@pytest.mark.parametrize("nr", [10, 20, 40])
def test_sphere_curvature_needs_the_hoop_part(nr):
    """Sphere R0 = 1 as concentric arcs (outer arc at rho1 = R0 - dx/2): on the outer arc the
    total curvature is 2/rho1 within 1 % at every particle (measured max 0.9 / 0.6 / 0.6 %
    at R0/dx = 10 / 20 / 40), the meridian (planar) part alone 1/rho1: half of it, so the
    hoop part is needed.  The outer arc's (ring-weighted) mean is 2/rho1 within 0.5 %
    (measured 0.29 / 0.07 / 0.02 %), so against the droplet's 2/R0 it is off by the
    first-order layer offset dx/(2 R0); the band curvature kbar that the force
    uses (outer two arcs) within 1.5 % of 2/rho1."""
    dx = 1.0 / nr
    x, a = half_disc_arcs(1.0, dx)
    csf, st, acc = _csf(x, a, dx)
    n = len(x)
    rr = np.linalg.norm(x, axis=1)
    outer = rr > 1.0 - dx
    rho1 = 1.0 - 0.5 * dx
    assert (st.omega[:n][outer] > 0).all() and not (st.omega[:n][rr < 1.0 - 2 * dx] > 0).any()
    k = st.kappa[:n][outer] * rho1 / 2
    np.testing.assert_allclose(k, 1.0, atol=0.01)
    km = csf.kappa_m[:n][outer] * rho1
    np.testing.assert_allclose(km, 1.0, atol=0.015)  # the planar part: 1/rho1, not 2/rho1
    kmean = np.average(st.kappa[:n][outer], weights=x[outer, 0]) / 2  # ring-area weights
    assert abs(kmean * rho1 - 1.0) < 0.005
    assert kmean - 1.0 == pytest.approx(0.5 * dx, rel=0.25)  # vs 2/R0: the layer offset
    band = rr > 1.0 - 2 * dx
    np.testing.assert_allclose(st.kbar[:n][band] * rho1 / 2, 1.0, atol=0.015)


def test_sphere_force_integrates_to_the_laplace_jump():
    """Total radial force sum_i M_i a_i . (-e) / (4 pi R0^2) vs 2 sigma / R0: errors 4.6 /
    2.5 / 1.4 % at R0/dx = 10 / 20 / 40 (first order, observed 0.9 / 0.8: the surface
    layer's offset), net axial force 0 by symmetry."""
    errs = []
    for nr in (10, 20, 40):
        dx = 1.0 / nr
        x, a = half_disc_arcs(1.0, dx)
        _, _, acc = _csf(x, a, dx)
        M = 2 * math.pi * x[:, 0] * a
        rr = np.linalg.norm(x, axis=1)
        fr = -(acc * x).sum(1) / rr
        errs.append(abs((M * fr).sum() / (4 * math.pi) / 2.0 - 1.0))
        assert abs((M * acc[:, 1]).sum()) < 1e-12 * (M * np.abs(fr)).sum()
    assert errs[2] < 0.02
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 0.7), orders


def test_cylinder_is_hoop_only_and_slab_is_flat():
    """Cylinder r < R0 = 1 periodic in z (dx = 1/20): kappa_m = 0, kappa_h = 1/r at the
    outer column (r = R0 - dx/2) to 1e-3; a flat slab (disc of radius 1, thickness 8 dx):
    kappa = 0 on both faces away from the rim (to round-off), the axis included."""
    dx = 0.05
    rs = (np.arange(20) + 0.5) * dx
    zs = (np.arange(12) + 0.5) * dx
    rr, zz = np.meshgrid(rs, zs, indexing="ij")
    x = np.column_stack([rr.ravel(), zz.ravel()])
    csf, st, _ = _csf(x, np.full(len(x), dx * dx), dx, Lz=12 * dx)
    n = len(x)
    outer = x[:, 0] > 1.0 - dx
    assert (st.omega[:n][outer] > 0).all()
    assert np.abs(csf.kappa_m[:n][outer]).max() < 1e-3
    np.testing.assert_allclose(csf.kappa_h[:n][outer] * x[outer, 0], 1.0, atol=1e-3)
    zs = (np.arange(8) + 0.5) * dx
    rr, zz = np.meshgrid(rs, zs, indexing="ij")
    x = np.column_stack([rr.ravel(), zz.ravel()])
    _, st, acc = _csf(x, np.full(len(x), dx * dx), dx)
    n = len(x)
    inner = (x[:, 0] < 1.0 - 2 * 3 * dx) & (st.omega[:n] > 0)
    assert inner.sum() >= 2 * 10
    assert np.abs(st.kappa[:n][inner]).max() < 1e-9
    assert np.abs(acc[inner]).max() < 1e-9


def test_axis_limit_tames_normal_noise():
    """Arcs with positions jittered by +-0.1 dx (R0/dx = 40, 5 seeds): the normal's angle
    noise delta turns into a hoop error ~ delta R0 / r, largest at the axis.  On the outer
    arc within 1.5 R of the axis the pointwise -n_r / r errs by 2.8 (rms, relative;
    measured) against 1/|x|, the axis limit (kappa_m below 0.5 R, blended up to 1.5 R) by
    1.4, the level of the meridian curvature's own noise (1.3)."""
    dx = 1.0 / 40
    e_pt, e_ax, e_m = [], [], []
    for seed in range(5):
        x, a = half_disc_arcs(1.0, dx)
        x = x + np.random.default_rng(seed).uniform(-0.1, 0.1, x.shape) * dx
        x[:, 0] = np.abs(x[:, 0])
        rr = np.linalg.norm(x, axis=1)
        outer = rr > 1.0 - dx
        near = outer & (x[:, 0] < 4.5 * dx)
        for band, out in (((0.0, 1e-12), e_pt), (None, e_ax)):
            csf, st, _ = _csf(x, a, dx, band=band)
            n = len(x)
            out += list(csf.kappa_h[:n][near] * rr[near] - 1.0)
        e_m += list(csf.kappa_m[:n][outer] * rr[outer] - 1.0)
    rms = [float(np.sqrt(np.mean(np.square(e)))) for e in (e_pt, e_ax, e_m)]
    assert rms[1] < 0.6 * rms[0], rms
    assert rms[1] < 1.25 * rms[2], rms


@pytest.mark.parametrize("nr", [20, 40])
def test_axis_curvature_from_the_band_edge(nr):
    """axis_curvature: the axis band takes its curvature from the band's outer edge.  On the
    sphere's arcs the outer arc keeps 2/rho1 within 1 % (measured 0.56 / 0.57 %, as
    without); with the positions jittered by +-0.1 dx (4 seeds) the outer arc within
    4.5 dx of the axis errs by rms 0.21 / 0.63 (R0/dx = 20 / 40; measured) against 0.63 /
    1.41 without: the level of the rest of the arc (0.37 / 0.67).  The flat-film version
    (a lamella's centre): examples/axisymmetric/csf_axis_noise.py."""
    dx = 1.0 / nr
    x, a = half_disc_arcs(1.0, dx)
    n = len(x)
    rr = np.linalg.norm(x, axis=1)
    outer = rr > 1.0 - dx
    _, st, _ = _csf(x, a, dx, axis_curvature=True)
    np.testing.assert_allclose(st.kappa[:n][outer] * (1.0 - 0.5 * dx) / 2, 1.0, atol=0.01)
    err = {False: [], True: []}
    rest = []
    for seed in range(1, 5):
        xj = x + np.random.default_rng(seed).uniform(-0.1, 0.1, x.shape) * dx
        xj[:, 0] = np.abs(xj[:, 0])
        rj = np.linalg.norm(xj, axis=1)
        out = rj > 1.0 - dx
        near = out & (xj[:, 0] < 4.5 * dx)
        for flag in (False, True):
            _, st, _ = _csf(xj, a, dx, axis_curvature=flag)
            e = st.kappa[:n] * rj / 2 - 1.0
            err[flag] += list(e[near])
        rest += list(e[out & ~near])
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in err.items()}
    rms_rest = float(np.sqrt(np.mean(np.square(rest))))
    assert rms[True] < 0.6 * rms[False], rms
    assert rms[True] < 1.1 * rms_rest, (rms, rms_rest)


def test_axis_lambda_gate_drops_bulk_normals_in_the_band():
    """axis_lambda_gate: rings of the axis band whose lambda_min reaches the gate lose their
    normal (omega = 0); rings outside the band and those below the gate keep theirs."""
    dx = 1.0 / 20
    x, a = half_disc_arcs(1.0, dx)
    n, R = len(x), 3 * dx
    csf, st, _ = _csf(x, a, dx)
    om0 = st.omega[:n].copy()
    lam = np.where(np.linalg.norm(x, axis=1) > 1.0 - dx, 0.5, 0.9)  # surface 0.5, bulk 0.9
    lam[(x[:, 0] < 0.6 * R)] = 0.95  # pretend the whole band's first column is bulk
    xm, src = axis_mirrors(x, R)
    xa = np.vstack([x, xm])
    kind = np.r_[np.full(n, FLUID), np.full(len(src), MIRROR_FLUID)].astype(np.int8)
    nl = build_neighbor_list(xa, R, xa.min(0) - R, xa.max(0) + R, np.zeros(2), kind=kind,
                             keep=KEEP)
    gated = AxisymmetricCSF(1.0)
    gated.axis_lambda_gate = 0.8
    st = gated.accumulate(xa, np.r_[a, a[src]], np.ones(len(xa)), kind, nl.offsets,
                          nl.indices, n, src.astype(np.int64), np.zeros(len(src), np.int8), R,
                          0.0, np.zeros((n, 2)), lam=lam)
    band = x[:, 0] < gated.axis_band[1] * R
    assert np.all(st.omega[:n][band & (lam >= 0.8)] == 0.0)
    np.testing.assert_array_equal(st.omega[:n][~band], om0[~band])
    np.testing.assert_array_equal(st.omega[:n][band & (lam < 0.8)], om0[band & (lam < 0.8)])
    assert (om0[band & (lam >= 0.8)] > 0).any()  # the gate removed some valid normals


# ----------------------------------------------------------------- the hooked-up fluid


def _droplet(nr, packing="arcs", v_mode=0.0, R0=1e-3, sigma=0.072, rho0=1000.0, mu=1e-3,
             alpha=0.0, c0_factor=1.0):
    """Axisymmetric droplet of radius R0 (arcs or the half-disc lattice, R = 3 dx), zero
    gravity, CSF on, started at the density of the Laplace pressure 2 sigma / R0 with c0 from
    :func:`~sphfem.validation.fluid.droplet_c0` (1 % density change under it, c0 >= 10 |v|),
    (times ``c0_factor``), and the l = 2 velocity field v = V (-r/2, z) / R0 of amplitude
    V = ``v_mode``."""
    from sphfem.axisymmetric import half_disc_lattice
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.fluid.eos import density
    from sphfem.fluid.wcsph import FluidParams
    from sphfem.validation.fluid import droplet_c0

    dx = R0 / nr
    if packing == "arcs":
        x, a = half_disc_arcs(R0, dx)
    else:
        x = half_disc_lattice(R0, dx)
        a = np.full(len(x), dx * dx)
    n = len(x)
    c0 = c0_factor * droplet_c0(3, sigma, rho0, R0, v_mode)
    rho = density(2 * sigma / R0, rho0, c0, 7.0)
    v = v_mode * np.column_stack([-0.5 * x[:, 0], x[:, 1]]) / R0
    par = FluidParams(rho0=rho0, c0=c0, mu=mu, delta=0.1, alpha=alpha, gravity=(0.0, 0.0))
    return AxisymmetricFluid(x, v, np.full(n, rho), np.full(n, FLUID),
                             2 * math.pi * x[:, 0] * rho * a, 0.0, 3 * dx, par,
                             surface_tension=sigma)


def _run(f, t_end, every, sample, sigma=0.072):
    """Step ``f`` to ``t_end`` with min(its stable step, the capillary limit); ``sample(f)``
    every ``every`` seconds."""
    from sphfem.fluid.axisymmetric_surface_tension import capillary_dt

    dtc = capillary_dt(f.params.rho0, 0.5 * f.R, sigma)
    nxt = every
    while f.t < t_end * (1 - 1e-12):
        f.step(min(f.stable_dt(), dtc, t_end - f.t))
        if f.t >= nxt * (1 - 1e-12):
            sample(f)
            nxt += every


def _static(nr, packing, R0=1e-3, sigma=0.072, mu=0.01, hoop=True):
    """Droplet at rest over 10 acoustic times R0 / c0: the time-averaged, mass-weighted mean
    pressure of the inner half (|x - x_c| < R0 / 2) over the second half of the run (the
    start's breathing mode averages out) over 2 sigma / R0, and the largest speed over the
    second half over sigma / mu (spurious currents).  ``hoop=False``: the planar CSF only."""
    f = _droplet(nr, packing, R0=R0, sigma=sigma, mu=mu)
    if not hoop:
        f.csf = AxisymmetricCSF(sigma, f.kcode, hoop=False)
    c0 = f.params.c0
    t_end = 10.0 * R0 / c0
    ps, vs = [], []

    def sample(s):
        if s.t < 0.5 * t_end:
            return
        zc = np.average(s.x[:, 1], weights=s.M)
        inner = np.hypot(s.x[:, 0], s.x[:, 1] - zc) < 0.5 * R0
        ps.append(np.average(s.p[inner], weights=s.M[inner]))
        vs.append(np.hypot(*s.v.T).max())

    _run(f, t_end, t_end / 100, sample, sigma)
    return float(np.mean(ps)) / (2 * sigma / R0), max(vs) / (sigma / mu)


def test_laplace_pressure_of_a_droplet_at_rest():
    """Static droplet (R0 = 1 mm, water's sigma, mu = 0.01 Pa s), arcs at R0/dx = 10, 20: the
    inner pressure is sigma kappa of the outer arc, 2 sigma / (R0 - dx/2), within 0.3 %
    (measured 0.06 / 0.08 %; 0.04 % at R0/dx = 40), so against Laplace's 2 sigma / R0 it
    errs by the first-order layer offset (5.2 / 2.5 %; 1.2 % at 40; observed order 1.07,
    1.01); spurious currents max |v| / (sigma / mu) < 1e-3 (measured 4.3e-4 / 3.1e-4).
    Started from the staircase lattice (R0/dx = 20) the droplet relaxes to within 3 % of
    2 sigma / R0 (measured 2.3 %) with spurious currents < 0.02 sigma / mu (measured
    0.010).  The planar CSF alone (no hoop part) holds half the pressure: sigma / rho1 within
    3 % of 2 sigma / R0 at R0/dx = 10 (measured 0.537 against 0.526)."""
    errs = []
    for nr in (10, 20):
        p, v = _static(nr, "arcs")
        assert p * (1.0 - 0.5 / nr) == pytest.approx(1.0, abs=0.003)
        assert v < 1e-3
        errs.append(p - 1.0)
    assert math.log2(errs[0] / errs[1]) > 0.9
    p, _ = _static(10, "arcs", hoop=False)
    assert p == pytest.approx(0.5 / (1.0 - 0.05), abs=0.03)
    p, v = _static(20, "lattice")
    assert p == pytest.approx(1.0, abs=0.03)
    assert v < 0.02


def _oscillation(nr, eps=0.1, periods=1.6, R0=1e-3, sigma=0.072, rho0=1000.0, c0_factor=1.0):
    """Droplet (arcs, R0 = 1 mm, water) started with Rayleigh's l = 2 velocity field of
    amplitude V = eps omega R0; the shape moment D = <(z - z_c)^2 - r^2 / 2> (ring-mass
    weighted: the 3D <z^2 - (x^2 + y^2)/2>) oscillates as sin(omega t); returns the period
    (twice the mean spacing of its zero crossings) over Rayleigh's and D_min / D_max."""
    from sphfem.validation.fluid import rayleigh_period

    T = rayleigh_period(3, sigma, rho0, R0)
    f = _droplet(nr, v_mode=eps * 2 * math.pi / T * R0, R0=R0, sigma=sigma, rho0=rho0,
                 alpha=0.02, c0_factor=c0_factor)
    ts, Ds = [0.0], [0.0]

    def sample(s):
        zc = np.average(s.x[:, 1], weights=s.M)
        ts.append(s.t)
        Ds.append(np.average((s.x[:, 1] - zc) ** 2 - 0.5 * s.x[:, 0] ** 2, weights=s.M))

    _run(f, periods * T, T / 100, sample, sigma)
    t, D = np.array(ts), np.array(Ds)
    k = np.flatnonzero(D[1:-1] * D[2:] < 0) + 1
    z = t[k] - D[k] * (t[k + 1] - t[k]) / (D[k + 1] - D[k])
    assert len(z) >= 2
    return 2 * float(np.mean(np.diff(z))) / T, D.min() / D.max()


def test_rayleigh_oscillation_of_a_droplet():
    """l = 2 oscillation (eps = 0.1, R0/dx = 10, water, alpha = 0.02): the period within 2 %
    of Rayleigh's 2 pi / sqrt(8 sigma / (rho R0^3)) (measured -0.50 %; slow test: finer
    spacings), and the shape passes through the sphere to the other side (D_min / D_max <
    -0.5)."""
    ratio, dmin = _oscillation(10)
    assert ratio == pytest.approx(1.0, abs=0.02)
    assert dmin < -0.5


@pytest.mark.slow
def test_rayleigh_oscillation_convergence():
    """As above at R0/dx = 10, 20, 40: T / T_Rayleigh - 1 = -0.50, -0.59 % at 10, 20
    (measured; 40: not measured to the end yet), within 1 % at every spacing, but not
    falling with dx: the error is the run's weak compressibility (c0 = 3.8 m/s, 1 % density
    change under the Laplace pressure).  With c0 doubled it is -0.36 / -0.16 % at R0/dx =
    10 / 20; extrapolated to c0 -> inf (error ~ 1/c0^2) -0.31 / -0.01 %: the spatial error
    falls below the compressibility error by R0/dx = 20."""
    errs = [_oscillation(nr)[0] - 1.0 for nr in (10, 20, 40)]
    assert max(abs(e) for e in errs) < 0.01, errs
    e2 = [_oscillation(nr, c0_factor=2.0)[0] - 1.0 for nr in (10, 20)]
    inc = [(4 * b - a) / 3 for a, b in zip(errs[:2], e2, strict=True)]  # c0 -> inf
    assert abs(e2[1]) < 0.5 * abs(errs[1]) and abs(inc[1]) < abs(inc[0]), (e2, inc)


def test_droplet_impact_with_surface_tension_stays_calm():
    """The impact of tests/test_fluid_axisymmetric.py (D = 0.1 mm at 10 m/s onto an Adami
    wall, D/dx = 16, c0 = 100 m/s, fixed h) with water's sigma = 0.072 N/m (We = 139) to
    1 t_c: after the water-hammer transient (t >= 0.4 t_c) |p| < 5 rho V^2 as without
    surface tension (measured [-0.75, 1.52] rho V^2 with sigma, [-0.72, 1.56] without; to
    2 t_c [-4.1, 4.7] and [-4.0, 5.2]), and the CSF acceleration 2 sigma |kbar g| / rho stays
    below the inertial scale V^2 / dx (measured max 0.076 V^2 / dx).  With the
    crosscheck's adaptive h and free-slip wall ghost the pressure peaks are -10 / +23 rho V^2
    by 1 t_c with or without surface tension (a fluid matter, not tested here)."""
    import sys
    from pathlib import Path

    from sphfem.axisymmetric import ring_mass
    from sphfem.fluid.axisymmetric import AxisymmetricFluid
    from sphfem.particles import WALL

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples" / "axisymmetric"))
    import droplet_crosscheck as dc

    dx = dc.D / 16
    xf, xw = dc.lattice_sphere(dx, 2), dc.wall(dx, 2, 3 * dc.D)
    x = np.vstack([xf, xw])
    nf = len(xf)
    kind = np.r_[np.full(nf, FLUID), np.full(len(xw), WALL)].astype(np.int8)
    v = np.zeros_like(x)
    v[:nf, 1] = -dc.V
    M = np.r_[ring_mass(xf[:, 0], dc.RHO, dx * dx), np.zeros(len(xw))]
    f = AxisymmetricFluid(x, v, np.full(len(x), dc.RHO), kind, M, dx * dx, 3 * dx,
                          dc.params(), surface_tension=0.072)
    lo, hi, a_st = math.inf, -math.inf, 0.0
    while f.t < dc.T_C:
        f.step(f.stable_dt())
        st = f.csf.state
        a_st = max(a_st, float((2 * 0.072 * np.abs(st.kbar[:nf]) * np.hypot(*st.g[:nf].T)
                                / f.rho[:nf]).max()))
        if f.t >= 0.4 * dc.T_C:
            lo, hi = min(lo, f.p[:nf].min()), max(hi, f.p[:nf].max())
    q = dc.RHO * dc.V**2
    assert -5.0 * q < lo and hi < 5.0 * q
    assert 0.0 < a_st < dc.V**2 / dx


def test_smooth_curvature_is_the_wendland_mean_of_the_valid_rows():
    """smooth_curvature: kappa_i of the valid real rows becomes sum_j w_ij kappa_j /
    sum_j w_ij over the valid rows within Rs (mirrors included), w_ij = omega_j A_j f(d_ij /
    Rs), f the Wendland C2 shape; brute force to round-off, also with z periodic (minimum
    image), invalid and mirror rows untouched."""
    from sphfem.fluid.axisymmetric_surface_tension import smooth_curvature

    rng = np.random.default_rng(0)
    n, m, Rs = 300, 340, 0.08
    for Lz in (0.0, 1.0):
        x = rng.uniform(0.0, 1.0, (m, 2))
        x[n:, 0] *= -0.05  # mirror rows
        A = rng.uniform(0.5, 1.5, m)
        om = np.where(rng.uniform(size=m) < 0.4, rng.uniform(0.1, 1.0, m), 0.0)
        k = rng.normal(size=m)
        out = k.copy()
        smooth_curvature(x, A, om, out, n, Rs, Lz)
        ref = k.copy()
        val = np.flatnonzero(om > 0)
        for i in val[val < n]:
            dz = x[val, 1] - x[i, 1]
            if Lz:
                dz -= Lz * np.rint(dz / Lz)
            u = np.minimum(np.hypot(x[val, 0] - x[i, 0], dz) / Rs, 1.0)
            w = om[val] * A[val] * (1 - u) ** 4 * (1 + 4 * u)
            ref[i] = (w * k[val]).sum() / w.sum()
        np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12)
        assert np.array_equal(out[n:], k[n:]) and np.array_equal(out[om == 0], k[om == 0])
    with pytest.raises(ValueError, match="curvature_smoothing"):
        AxisymmetricCSF(1.0, curvature_smoothing=0.5)


@pytest.mark.parametrize("nr", [20, 40])
def test_curvature_smoothing_keeps_the_sphere_and_cuts_the_noise(nr):
    """curvature_smoothing = 2 (the curvature averaged over 2 R along the surface), with
    axis_curvature: the sphere's arcs keep 2/rho1 on the outer arc within 1 % (measured
    max 0.47 / 0.51 % at R0/dx = 20 / 40, 0.56 / 0.57 % without); with the positions
    jittered by +-0.1 dx (4 seeds) the outer arc's rms curvature error falls from 0.35 /
    0.66 to 0.10 / 0.19 (measured; the noise of the unsmoothed curvature grows as 1/dx).
    The droplet impact's centre: docs/validation/droplet_impact/README.md."""
    dx = 1.0 / nr
    x, a = half_disc_arcs(1.0, dx)
    n = len(x)
    outer = np.linalg.norm(x, axis=1) > 1.0 - dx
    _, st, _ = _csf(x, a, dx, axis_curvature=True, smoothing=2.0)
    np.testing.assert_allclose(st.kappa[:n][outer] * (1.0 - 0.5 * dx) / 2, 1.0, atol=0.01)
    err = {1.0: [], 2.0: []}
    for seed in range(1, 5):
        xj = x + np.random.default_rng(seed).uniform(-0.1, 0.1, x.shape) * dx
        xj[:, 0] = np.abs(xj[:, 0])
        rj = np.linalg.norm(xj, axis=1)
        out = rj > 1.0 - dx
        for c in err:
            _, st, _ = _csf(xj, a, dx, axis_curvature=True, smoothing=c)
            err[c] += list(st.kappa[:n][out] * rj[out] / 2 - 1.0)
    rms = {c: float(np.sqrt(np.mean(np.square(e)))) for c, e in err.items()}
    assert rms[2.0] < 0.4 * rms[1.0], rms


def test_resting_drop_stays_at_rest():
    """A drop of radius 20 dx at rest with the axisymmetric CSF (examples/axisymmetric/
    resting_drop.py) over 2 capillary times: its pole and equator stay within 0.5 dx of
    their start (measured 0.02-0.2 dx), the spurious current below 0.5 m/s (measured 0.27
    at most; the capillary velocity scale sqrt(sigma / (rho a)) is 1.9 m/s), and the mean
    pressure within a factor 2 of the Laplace jump 2 sigma / a after the start (measured
    0.6-1.7, the acoustic transient of a drop started at rho0).  The surface stress
    (``csf_meridian = "stress"``) fails this: its pole rises 2.3 dx by 0.5 t_cap and the drop
    blows apart by 1.5 t_cap (the script's docstring)."""
    from pathlib import Path

    from builders import load_example

    resting_drop = load_example(Path(__file__).resolve().parents[1] / "examples"
                                / "axisymmetric" / "resting_drop.py", "resting_drop")
    rows = np.array(resting_drop.resting_drop("csf", 20, 2.0))
    assert rows[-1, 0] >= 1.5  # it ran to the end (finite)
    assert np.all(np.abs(rows[:, 1] - 19.5) < 0.5) and np.all(np.abs(rows[:, 2] - 19.5) < 0.5)
    assert rows[:, 3].max() < 0.5
    laplace = 2 * 0.072 / 20e-6
    assert np.all(np.abs(rows[1:, 4] / laplace - 1.0) < 1.0)
