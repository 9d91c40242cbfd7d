"""The sub-grid contact-line friction of Cox (1986) (sphfem.fluid.contact_line_cox1986)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from test_axisymmetric_damper_and_wall import DX, _film_on_wall

from sphfem.fluid.axisymmetric import AxisymmetricFluid
from sphfem.fluid.contact_line_cox1986 import (
    contact_line_factor,
    contact_line_factors,
    secant_ratio,
    subgrid_friction,
    wedge_function,
    wedge_slope,
)
from sphfem.fluid.wall_layer import plug_traction_constant
from sphfem.particles import FLUID


def test_wedge_function_is_voinovs_law_at_small_angles_and_its_slope_is_g_prime():
    """g(theta) -> theta^3 / 9 (Voinov 1976) for small angles (to 1e-4 relative at 0.05 rad);
    g' is the derivative of g (central difference, 1e-6 relative) at 30, 90 and 150 deg."""
    for th in (0.01, 0.05):
        assert wedge_function(th) == pytest.approx(th**3 / 9.0, rel=1e-3 * th / 0.05 + 1e-6)
    for deg in (30.0, 90.0, 150.0):
        th, e = math.radians(deg), 1e-4
        num = (wedge_function(th + e) - wedge_function(th - e)) / (2 * e)
        assert wedge_slope(th) == pytest.approx(num, rel=1e-6)
    assert wedge_slope(math.pi / 2) == pytest.approx(math.pi / 4, rel=1e-15)
    with pytest.raises(ValueError, match="contact angle"):
        wedge_function(math.pi)


def test_secant_ratio_solves_cox_law_and_linearises_to_four_over_pi():
    """phi(c) of eq. (3'): at c -> 0 it is sin / g' = 4 / pi at 90 deg; at c > 0 it equals
    (cos theta_s - cos theta_D) / c with theta_D solved from g(theta_D) = g(theta_s) + c
    directly (root finder; 1e-4 relative over the table's interpolation); it falls with c
    (the linearisation over-states the force) and saturates at (1 + cos theta_s) / c."""
    assert secant_ratio(0.0)[()] == pytest.approx(4.0 / math.pi, rel=1e-12)
    g0 = wedge_function(math.pi / 2)
    for c in (0.01, 0.1, 0.3, 1.0, 3.0):
        th = brentq(lambda t, c=c: wedge_function(t) - g0 - c, math.pi / 2, math.pi - 1e-9)
        assert secant_ratio(c)[()] == pytest.approx(-math.cos(th) / c, rel=1e-4)
    phi = secant_ratio(np.linspace(0.0, 2.0, 41))
    assert np.all(np.diff(phi) < 0.0)
    assert secant_ratio(1e4)[()] == pytest.approx(1.0 / 1e4, rel=1e-12)
    for deg in (60.0, 120.0):  # another static angle: the same check
        th_s = math.radians(deg)
        gs = wedge_function(th_s)
        th = brentq(lambda t, gs=gs: wedge_function(t) - gs - 0.2, th_s, math.pi - 1e-9)
        assert secant_ratio(0.2, deg)[()] == pytest.approx(
            (math.cos(th_s) - math.cos(th)) / 0.2, rel=1e-4)


def test_subgrid_friction_is_the_wedge_between_the_slip_length_and_the_grid():
    """zeta / mu = (4 / pi) ln(Delta / lambda) at 90 deg; 0 once the grid resolves lambda;
    f_cl = zeta / (S mu) with Delta = dx / 2; the secant factors reduce to it at rest."""
    assert subgrid_friction(90.0, 1e-6, 1e-9) == pytest.approx(4 / math.pi * math.log(1e3))
    assert subgrid_friction(90.0, 1e-9, 1e-8) == 0.0
    S = plug_traction_constant("wendland_c2", 3.0)
    f = contact_line_factor(S, 2e-6, 1e-9)
    assert f == pytest.approx(4 / math.pi * math.log(1e3) / S)
    fs = contact_line_factors(np.array([0.0, 1.0, -1.0, 10.0]), S, 2e-6, 1e-9, 1e-3, 0.07)
    assert fs[0] == pytest.approx(f, rel=1e-12)
    assert fs[1] == fs[2] and fs[3] < fs[1] < fs[0]
    with pytest.raises(ValueError, match="slip_length"):
        subgrid_friction(90.0, 1e-6, 0.0)
    with pytest.raises(ValueError, match="surface tension"):
        contact_line_factors(np.zeros(2), S, 2e-6, 1e-9, 1e-3, 0.0)


def test_film_edge_rings_carry_the_cox_friction_and_the_middle_is_unchanged():
    """A film sliding along a wall with the layer friction: the rings at its end (contact-line
    weight 1) carry f_cl of their speed, the rings under its middle the layer's own factor
    (as without the option); the option needs the layer friction and surface tension."""
    nf, nw = 24, 34
    x, kind, _, nrm, pa = _film_on_wall(nf, nw)
    rho = np.full(len(x), 1000.0)
    M = rho * DX * DX * 2.0 * np.pi * x[:, 0]
    v = np.where((kind == FLUID)[:, None], [0.01, 0.0], 0.0)
    lam, sigma = 1e-9, 0.072
    runs = {}
    for slip_length in (0.0, lam):
        f = AxisymmetricFluid(x, v, rho, kind, M, DX * DX, 3 * DX, pa, wall_normals=nrm,
                              wall_friction="layer", surface_tension=sigma,
                              contact_line_slip_length=slip_length)
        f.step(1e-5)
        runs[slip_length] = f
    f = runs[lam]
    fl = kind == FLUID
    cl = f.contact_line
    full = fl & (cl == 1.0)
    assert full.sum() >= 2  # the end ring of each of the film's two rows
    ut = np.hypot(f.v[full, 0], f.v[full, 1])
    expect = contact_line_factors(ut, f.wall_S, f.wall_dx, lam, pa.mu, sigma)
    # the factor takes the speed inside the step (the layer's update), not the step's end
    assert np.allclose(f.fw[full], expect, rtol=1e-4)
    assert np.all(expect > 1.0)  # stickier than the plain no-slip term at this spacing
    mid = fl & (cl == 0.0)
    assert np.array_equal(f.fw[mid], runs[0.0].fw[mid])
    with pytest.raises(ValueError, match="wall_friction"):
        AxisymmetricFluid(x, v, rho, kind, M, DX * DX, 3 * DX, pa, wall_normals=nrm,
                          surface_tension=sigma, contact_line_slip_length=lam)
    with pytest.raises(ValueError, match="surface tension"):
        AxisymmetricFluid(x, v, rho, kind, M, DX * DX, 3 * DX, pa, wall_normals=nrm,
                          wall_friction="layer", contact_line_slip_length=lam)


def test_scene_keys_need_the_layer_friction_and_a_positive_slip_length():
    """``[fluid] contact_line`` other than "no-slip" without ``wall_friction = "layer"`` is
    refused with its key named, as is a slip length <= 0; the axisymmetric scene takes
    "cox-voinov" with the default slip length of 1 nm."""
    import tomllib
    from importlib import resources

    from sphfem.errors import SceneError
    from sphfem.scene import parse_scene

    ax = tomllib.loads(resources.files("sphfem.scenes").joinpath(
        "droplet_impact_axisymmetric.toml").read_text())
    ax["fluid"]["contact_line"] = "cox-voinov"
    fl = parse_scene(ax, source="axisymmetric").fluid
    assert (fl.contact_line, fl.contact_line_slip_length) == ("cox-voinov", 1e-9)
    ax["fluid"]["contact_line_slip_length"] = 0.0
    with pytest.raises(SceneError, match="fluid.contact_line_slip_length"):
        parse_scene(ax, source="axisymmetric")
    del ax["fluid"]["contact_line_slip_length"]
    ax["fluid"]["wall_friction"] = "viscous"
    with pytest.raises(SceneError, match="fluid.contact_line"):
        parse_scene(ax, source="axisymmetric")
