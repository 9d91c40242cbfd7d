"""Toolpath construction (thesis eq. 3.41-3.46): desired paths, normals, waypoint offsets
joined by PCHIP, arc length and the constant nozzle speed."""

import math

import numpy as np
import pytest

from sphfem.diw.toolpath import (
    CASES,
    Arc,
    DesiredPath,
    Line,
    ParameterSpace,
    Toolpath,
    WaypointSpec,
    named_case,
)

SPEED = 0.01  # m/s


@pytest.mark.parametrize("case", sorted(CASES))
def test_naive_toolpath_is_the_desired_path(case):
    """All delta = 0: the nozzle runs on the desired path (distance < 1e-12 m), its length is
    the exact length of the pieces (legs + pi r) and the duration is length / speed."""
    path, _ = named_case(case)
    exact = sum(p.length for p in path.pieces)
    tp = Toolpath.naive(path, SPEED)
    t = np.linspace(0.0, tp.duration, 997)
    d, _, _ = path.project(tp.position(t))
    assert d.max() < 1e-12
    # chord sums of the table under-estimate an arc by (ds)^2 / (24 r^2) relatively
    assert tp.length == pytest.approx(exact, rel=1e-8)
    assert tp.duration == pytest.approx(exact / SPEED, rel=1e-8)
    np.testing.assert_allclose(tp.position(0.0), path.point(0.0), atol=1e-15)
    np.testing.assert_allclose(tp.position(tp.duration), path.point(1.0), atol=1e-12)


def test_normal_is_eq_3_43_and_right_of_travel():
    """n = (dy/ds, -dx/ds)/|p'|: along +x it is -y; on a counter-clockwise arc it points
    outwards; at a 90-degree corner it is the bisector of the two legs' normals."""
    line = DesiredPath([Line((0, 0), (1, 0))])
    np.testing.assert_allclose(line.normal(0.3), [0.0, -1.0])
    arc = DesiredPath([Arc((0, 0), 2.0, 0.0, math.pi)])
    s = np.array([0.1, 0.5, 0.9])
    radial = arc.point(s) / 2.0
    np.testing.assert_allclose(arc.normal(s), radial, atol=1e-14)
    bend, _ = named_case("bend90")
    np.testing.assert_allclose(bend.normal(0.5), [1 / math.sqrt(2), -1 / math.sqrt(2)])


def test_pchip_passes_through_offset_waypoints():
    """The nozzle path passes through w~_i = p(s_i) + delta_i n_i (eq. 3.44) exactly, and
    the projection of w~_i on the desired path returns (s_i, delta_i)."""
    path, _ = named_case("bend180-large")
    s = np.array([0.25, 0.4, 0.55, 0.7])
    delta = np.array([-1e-3, -0.5e-3, 0.8e-3, -2e-3])
    tp = Toolpath(path, SPEED, s, delta)
    w = tp.point(s)
    np.testing.assert_allclose(w, path.point(s) + delta[:, None] * path.normal(s), atol=1e-15)
    dist, s_back, offset = path.project(w)
    np.testing.assert_allclose(s_back, s, atol=1e-12)
    np.testing.assert_allclose(offset, delta, atol=1e-15)
    np.testing.assert_allclose(dist, np.abs(delta), atol=1e-15)


def test_pchip_offset_does_not_overshoot():
    """Between waypoints the offset stays within the waypoints' range (PCHIP is monotone
    on monotone data): one waypoint at +1 mm on a straight line gives offsets in [0, 1 mm]
    (the line's normal is -y, so the nozzle's y is in [-1 mm, 0])."""
    path = DesiredPath([Line((0, 0), (0.01, 0))])
    tp = Toolpath(path, SPEED, [0.4], [1e-3])
    y = tp.point(np.linspace(0, 1, 4001))[:, 1]
    assert y.min() == pytest.approx(-1e-3, abs=1e-15)
    assert y.max() <= 0.0
    assert np.all(np.diff(y[:1600]) <= 1e-18) and np.all(np.diff(y[1601:]) >= -1e-18)


def test_arc_length_and_speed_of_an_offset_path():
    """A straight line with one waypoint offset: the table length matches an independent
    quadrature of |dp/ds| (rel 1e-8); |velocity| = speed, and velocity is the time
    derivative of position (central differences, rel 1e-5)."""
    from scipy.integrate import quad

    path = DesiredPath([Line((0, 0), (0.01, 0))])
    tp = Toolpath(path, SPEED, [0.3, 0.6], [0.8e-3, -0.4e-3])
    dpds = tp._offset.derivative()

    def speed_s(s):
        return float(np.hypot(0.01 + dpds(s)[0], dpds(s)[1]))

    exact = sum(quad(speed_s, a, b, epsabs=1e-14, epsrel=1e-12)[0]
                for a, b in ((0, 0.3), (0.3, 0.6), (0.6, 1)))
    assert tp.length == pytest.approx(exact, rel=1e-8)
    t = np.linspace(0.05, 0.95, 37) * tp.duration
    v = tp.velocity(t)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), SPEED, rtol=1e-12)
    dt = 1e-4 * tp.duration
    fd = (tp.position(t + dt) - tp.position(t - dt)) / (2 * dt)
    np.testing.assert_allclose(fd, v, rtol=0, atol=1e-5 * SPEED)


def test_naive_bend90_turns_abruptly():
    """The naive 90-degree bend: velocity +x before the corner, +y after it."""
    path, _ = named_case("bend90")
    tp = Toolpath.naive(path, SPEED)
    half = tp.duration / 2
    np.testing.assert_allclose(tp.velocity(half - 1e-3), [SPEED, 0.0], atol=1e-12)
    np.testing.assert_allclose(tp.velocity(half + 1e-3), [0.0, SPEED], atol=1e-12)
    np.testing.assert_allclose(tp.velocity(tp.duration + 1.0), [0.0, 0.0])


def test_parameter_space_fills_fixed_values():
    """Free values come from x in the order of ``names``; fixed ones from the specs."""
    space = ParameterSpace([WaypointSpec((0.1, 0.3), 0.0), WaypointSpec(0.5, (-1.0, 1.0)),
                            WaypointSpec((0.6, 0.9), (-2.0, 0.0))])
    assert space.names == ["s1", "delta2", "s3", "delta3"]
    s, d = space.waypoints([0.2, 0.5, 0.7, -1.5])
    np.testing.assert_allclose(s, [0.2, 0.5, 0.7])
    np.testing.assert_allclose(d, [0.0, 0.5, -1.5])
    s, d = space.waypoints([9.0, 9.0, 9.0, 9.0])  # clipped to the bounds
    np.testing.assert_allclose(s, [0.3, 0.5, 0.9])
    np.testing.assert_allclose(d, [0.0, 1.0, 0.0])


def test_named_case_bounds_follow_the_geometry():
    """bend180-small: waypoints 2, 3 (free delta) lie on the half circle, 1 and 4 on the
    legs (table 3.4); bend180-large: five free waypoints on the half circle (table 3.5)."""
    path, space = named_case("bend180-small")
    a, b = path.breaks[1], path.breaks[2]
    assert b - a == pytest.approx(math.pi * 2e-3 / path.length)
    assert space.names == ["s1", "s2", "delta2", "s3", "delta3", "s4"]
    np.testing.assert_allclose(space.lower[[1, 3]], a)
    np.testing.assert_allclose(space.upper[[1, 3]], b)
    path, space = named_case("bend180-large")
    assert space.n_var == 10
    assert np.all(space.upper[1::2] == 0.0)


def test_bend90_corner_offsets_are_local_and_inward():
    """bend90-corner: 4 free deltas at fixed s (the corner and 0.16, 0.32, 0.48 leg after
    it); outside the fixed waypoints on the path (0.32 leg before, 0.72 leg after the
    corner) the nozzle is on the desired path, and between them it is on the inner side
    (signed offset <= 0: PCHIP keeps the sign of its data)."""
    path, space = named_case("bend90-corner")
    assert space.n_var == 4 and all(n.startswith("delta") for n in space.names)
    np.testing.assert_array_equal(space.naive(), 0.0)
    rng = np.random.default_rng(3)
    for x in space.lower + rng.random((5, 4)) * (space.upper - space.lower):
        tp = Toolpath.from_parameters(path, space, x, SPEED)
        np.testing.assert_allclose(tp.s, [0.0, 0.34, 0.5, 0.58, 0.66, 0.74, 0.86, 1.0])
        s_out = np.r_[np.linspace(0.0, 0.34, 50), np.linspace(0.86, 1.0, 50)]
        np.testing.assert_allclose(tp.point(s_out), path.point(s_out), rtol=0, atol=1e-15)
        _, _, offset = path.project(tp.point(np.linspace(0.34, 0.86, 400)))
        assert offset.max() <= 1e-12
        assert offset.min() >= space.lower.min() * (1 + 1e-9)
