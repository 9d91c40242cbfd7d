"""Deposit fitness on constructed deposits with known answers: the thesis metric (eq. 3.47),
deviation in nozzle diameters, bead width, gaps and pieces."""

import math

import numpy as np
import pytest

from sphfem.diw.fitness import deposit_fitness, uncovered_stretches
from sphfem.diw.toolpath import Arc, DesiredPath, Line, named_case

D = 0.7e-3
H = 0.1e-3


def bead_on_line(length, rows, dx, y0=0.0):
    """Lattice bead along +x: columns every dx on [0, length], rows at y0 + rows[k]."""
    x = np.arange(0.0, length + 0.5 * dx, dx)
    X, Y = np.meshgrid(x, np.asarray(rows) + y0, indexing="ij")
    return np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 5e-5)])


def test_bead_offset_from_a_line():
    """Three rows at y = e + (-dx, 0, dx) along a 5 mm line: dist = |y| exactly, so
    f = N_col sum_rows (|y|/h)^3, max dev = (e + dx)/D, mean = e/D (all rows on one side),
    width = 2 dx + h, no gap, one piece."""
    L, dx, e = 5e-3, H, 3 * H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    rows = np.array([-dx, 0.0, dx])
    pos = bead_on_line(L, rows, dx, y0=e)
    f = deposit_fitness(pos, H, D, line)
    ncol = len(pos) // 3
    assert f["thesis"] == pytest.approx(ncol * np.sum(((e + rows) / H) ** 3), rel=1e-12)
    assert f["objective"] == f["thesis"]
    assert f["max_dev_D"] == pytest.approx((e + dx) / D, rel=1e-12)
    assert f["mean_dev_D"] == pytest.approx(e / D, rel=1e-12)
    assert f["width_mean_D"] == pytest.approx((2 * dx + H) / D, rel=1e-12)
    assert f["width_max_D"] == pytest.approx((2 * dx + H) / D, rel=1e-12)
    assert (f["gap_D"], f["n_gaps"], f["pieces"]) == (0.0, 0, 1)


def test_bead_on_an_arc_is_measured_radially():
    """Particles on a circle of radius r + e around a half-circle path of radius r: every
    dist = e, f = N (e/h)^3."""
    r, e = 2e-3, 0.25e-3
    path = DesiredPath([Arc((0.0, 0.0), r, 0.0, math.pi)])
    th = np.linspace(0.0, math.pi, 200)
    pos = np.column_stack([(r + e) * np.cos(th), (r + e) * np.sin(th)])
    f = deposit_fitness(pos, H, D, path)
    assert f["thesis"] == pytest.approx(200 * (e / H) ** 3, rel=1e-12)
    assert f["max_dev_D"] == pytest.approx(e / D, rel=1e-12)


def test_gap_in_the_bead():
    """A single-row bead with the particles at x in (2, 3) mm removed: the uncovered stretch
    is (next - previous) - 2 h, the deposit has two pieces, and the objective adds
    gap_weight (l/h)^3."""
    L, dx = 5e-3, H / 2
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    pos = bead_on_line(L, [0.0], dx)
    keep = (pos[:, 0] < 2e-3 - 1e-12) | (pos[:, 0] > 3e-3 + 1e-12)
    pos = pos[keep]
    prev = pos[pos[:, 0] < 2.5e-3, 0].max()
    nxt = pos[pos[:, 0] > 2.5e-3, 0].min()
    gap = (nxt - prev) - 2 * H
    f = deposit_fitness(pos, H, D, line, gap_weight=2.0)
    assert f["n_gaps"] == 1
    assert f["gap_D"] == pytest.approx(gap / D, rel=1e-9)
    assert f["pieces"] == 2
    assert f["objective"] == pytest.approx(f["thesis"] + 2.0 * (gap / H) ** 3, rel=1e-12)


def test_particles_far_off_the_path_do_not_close_a_gap():
    """A bead covering only the first half of the path, plus a blob 2 D off the second
    half: the second half is a gap (blob too far to cover it), ends uncovered too."""
    L, dx = 6e-3, H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    bead = bead_on_line(3e-3, [0.0], dx)
    blob = bead_on_line(2e-3, [0.0], dx, y0=2 * D) + [3.5e-3, 0.0, 0.0]
    f = deposit_fitness(np.vstack([bead, blob]), H, D, line)
    assert f["n_gaps"] == 1
    assert f["gap_D"] == pytest.approx((L - bead[:, 0].max() - H) / D, rel=1e-9)
    assert f["max_dev_D"] == pytest.approx(2.0, rel=1e-12)


def test_uncovered_stretches_at_the_ends():
    """Intervals s +- r inside [0, total]: the ends before the first and after the last."""
    np.testing.assert_allclose(uncovered_stretches(np.array([3.0, 5.0]), 1.0, 10.0),
                               [2.0, 4.0])
    np.testing.assert_allclose(uncovered_stretches(np.array([]), 1.0, 10.0), [10.0])


def test_corner_overshoot_of_bend90():
    """A bead following the 90-degree bend but overshooting the corner by a straight run of
    length a beyond x = 0: the far end (a, 0) is nearest to the corner, a away, so the
    largest deviation is a."""
    path, _ = named_case("bend90")
    a = 2.0 * D
    leg1 = bead_on_line(5e-3, [0.0], H) - [5e-3, 0.0, 0.0]
    over = bead_on_line(a, [0.0], H)  # beyond the corner along +x
    f = deposit_fitness(np.vstack([leg1, over]), H, D, path)
    assert f["max_dev_D"] == pytest.approx(a / D, rel=1e-9)


def test_bad_deposits_raise():
    line = DesiredPath([Line((0.0, 0.0), (1e-3, 0.0))])
    with pytest.raises(ValueError, match="empty deposit"):
        deposit_fitness(np.zeros((0, 3)), H, D, line)
    with pytest.raises(ValueError, match="NaN"):
        deposit_fitness(np.array([[np.nan, 0.0, 0.0]]), H, D, line)


def test_lag_model_steady_lag_on_a_line():
    """The stand-in deposit x'' = (n - x)/tau^2 - 2 zeta x'/tau trails a nozzle moving at
    speed v on a line by 2 zeta v tau once the start-up transient (~exp(-zeta t/tau)) has
    died out, centred on the line, rows of round(D/h) particles."""
    from sphfem.diw.lag_model import lag_deposit
    from sphfem.diw.toolpath import Toolpath

    v, tau, zeta = 0.01, 0.02, 0.5
    line = DesiredPath([Line((0.0, 0.0), (0.01, 0.0))])
    tp = Toolpath.naive(line, v)
    dep = lag_deposit(tp, D, H, tau, zeta)
    n_across = round(D / H)
    rows = dep.positions.reshape(-1, n_across, 3)
    centre = rows.mean(axis=1)
    t = np.linspace(0.0, tp.duration, len(rows))
    late = t > 20 * tau / zeta  # transient below exp(-20)
    assert late.sum() > 10
    np.testing.assert_allclose(v * t[late] - centre[late, 0], 2 * zeta * v * tau, rtol=1e-6)
    np.testing.assert_allclose(centre[:, 1], 0.0, atol=1e-15)
    assert dep.info["stopped_reason"] is None


# --- the practitioner's deviation: centreline and edges against the bead's own width ---


@pytest.mark.parametrize("half_rows", [1, 4])
def test_bead_on_the_path_scores_zero_whatever_its_width(half_rows):
    """A lattice bead 2 k dx wide (centres) centred on the path: the thesis' max deviation
    is its half-width k dx, the centreline, edge and 'edge' objective are exactly 0, and
    the nominal width is 2 k dx."""
    L, dx = 5e-3, H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    rows = dx * np.arange(-half_rows, half_rows + 1)
    f = deposit_fitness(bead_on_line(L, rows, dx), H, D, line, objective="edge")
    assert f["max_dev_D"] == pytest.approx(half_rows * dx / D, rel=1e-12)
    assert f["width_nominal_D"] == pytest.approx(2 * half_rows * dx / D, rel=1e-12)
    for key in ("centre_dev_max_D", "centre_dev_mean_D", "edge_dev_max_D",
                "edge_dev_mean_D", "edge", "centre"):
        assert f[key] == pytest.approx(0.0, abs=1e-12), key
    assert f["objective"] == f["edge"]


def test_offset_bead_deviates_by_its_offset():
    """The 3-row bead of test_bead_offset_from_a_line shifted by e = 3 h: centreline,
    outward excess (top row at e + dx, desired edge at dx) and mean edge error are all e;
    the shortfall on the other side, sqrt(e^2 + (dx/2)^2) - h at most, is smaller."""
    L, dx, e = 5e-3, H, 3 * H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    f = deposit_fitness(bead_on_line(L, [-dx, 0.0, dx], dx, y0=e), H, D, line)
    for key in ("centre_dev_max_D", "centre_dev_mean_D", "edge_dev_max_D",
                "edge_dev_mean_D", "edge_excess_max_D"):
        assert f[key] == pytest.approx(e / D, rel=1e-9), key
    assert f["edge_short_max_D"] <= (math.hypot(e, dx / 2) - H) / D + 1e-12


def test_corner_overshoot_beyond_the_bead_edge():
    """A 3-row bead (half-width dx) following the 90-degree bend, plus its outer rows run on
    a past the corner along +x: the far outside particle (a, -dx) is sqrt(a^2 + dx^2)
    from the corner, so the edge deviation is that minus the half-width dx, while the
    thesis' max deviation counts the half-width too."""
    path, _ = named_case("bend90")
    dx, a = H, 2.0 * D
    rows = [-dx, 0.0, dx]
    leg1 = bead_on_line(5e-3, rows, dx) - [5e-3, 0.0, 0.0]
    leg2 = bead_on_line(5e-3, rows, dx)[:, [1, 0, 2]]  # along +y, x = rows
    over = bead_on_line(a, rows, dx)[bead_on_line(a, rows, dx)[:, 0] > 1.5 * dx]
    f = deposit_fitness(np.vstack([leg1, leg2, over]), H, D, path)
    assert f["width_nominal_D"] == pytest.approx(2 * dx / D, rel=1e-9)
    assert f["max_dev_D"] == pytest.approx(math.hypot(a, dx) / D, rel=1e-9)
    assert f["edge_excess_max_D"] == pytest.approx((math.hypot(a, dx) - dx) / D, rel=1e-9)
    assert f["edge_dev_max_D"] == f["edge_excess_max_D"]
    assert f["edge_dev_s"] == pytest.approx(0.5, abs=1e-12)  # the corner


def test_cut_corner_is_a_shortfall():
    """A single-row bead that cuts the 90-degree corner along the chord from (-c, 0) to
    (0, c): no particle lies beyond the (zero) half-width outside, but the corner of the
    desired path is c / sqrt(2) from the chord, a shortfall of c / sqrt(2) - h."""
    path, _ = named_case("bend90")
    c, ds = 3 * D, H / 20
    leg1 = np.column_stack([np.arange(-5e-3, -c, ds), np.zeros_like(np.arange(-5e-3, -c, ds))])
    u = np.linspace(0.0, 1.0, int(c * math.sqrt(2) / ds) + 1)
    chord = np.column_stack([-c * (1 - u), c * u])
    y2 = np.arange(c + ds, 5e-3 + ds / 2, ds)
    leg2 = np.column_stack([np.zeros_like(y2), y2])
    f = deposit_fitness(np.vstack([leg1, chord, leg2]), H, D, path)
    assert f["width_nominal_D"] == 0.0
    assert f["edge_excess_max_D"] == pytest.approx(f["max_dev_D"], rel=1e-12)
    assert f["edge_short_max_D"] == pytest.approx((c / math.sqrt(2) - H) / D, abs=ds / D)
    assert f["edge_dev_s"] == pytest.approx(0.5, abs=H / path.length)  # the corner


def test_gap_is_a_shortfall_of_half_its_length():
    """The bead of test_gap_in_the_bead: the centreline sample nearest the hole's middle is
    (next - previous) / 2 from the particles, within the samples' spacing h / 2."""
    L, dx = 5e-3, H / 2
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    pos = bead_on_line(L, [0.0], dx)
    pos = pos[(pos[:, 0] < 2e-3 - 1e-12) | (pos[:, 0] > 3e-3 + 1e-12)]
    hole = np.diff(np.sort(pos[:, 0])).max()
    f = deposit_fitness(pos, H, D, line)
    short = f["edge_short_max_D"] * D
    assert hole / 2 - H - H / 4 - 1e-12 <= short <= hole / 2 - H + 1e-12


@pytest.mark.parametrize("p", [1.0, 8.0, 64.0])
def test_centre_objective_of_an_offset_bead_is_its_offset(p):
    """The 3-row bead shifted by e = 3 h: every station's centreline is e, so the power
    mean (1/N sum (c_k/h)^p)^(1/p) is e / h for any p, and equals the maximum."""
    L, dx, e = 5e-3, H, 3 * H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    pos = bead_on_line(L, [-dx, 0.0, dx], dx, y0=e)
    f = deposit_fitness(pos, H, D, line, objective="centre", centre_p=p)
    assert f["objective"] == f["centre"]
    assert f["centre"] == pytest.approx(e / H, rel=1e-9)
    assert f["centre"] == pytest.approx(f["centre_dev_max_D"] * D / H, rel=1e-9)


@pytest.mark.parametrize("p", [1.0, 2.0, 8.0, 200.0])
def test_centre_objective_of_one_displaced_station(p):
    """A 3-row bead on a 5 mm line whose particles in station 3 of N = ceil(L/D) = 8
    (x in [3, 4) L/N) are shifted by e across the path: the centreline is e there and 0
    elsewhere, so centre_dev_max = e, centre_dev_mean = e/N and the objective is the power
    mean (e/h) N^(-1/p), which tends to the maximum e/h as p grows."""
    L, dx, e = 5e-3, H, 2.5 * H
    line = DesiredPath([Line((0.0, 0.0), (L, 0.0))])
    n = math.ceil(L / D)
    pos = bead_on_line(L, [-dx, 0.0, dx], dx)
    station = (pos[:, 0] >= 3 * L / n + 1e-12) & (pos[:, 0] < 4 * L / n - 1e-12)
    assert station.sum() > 0
    pos[station, 1] += e
    f = deposit_fitness(pos, H, D, line, objective="centre", centre_p=p)
    assert f["width_nominal_D"] == pytest.approx(2 * dx / D, rel=1e-9)
    assert f["centre_dev_max_D"] == pytest.approx(e / D, rel=1e-9)
    assert f["centre_dev_mean_D"] == pytest.approx(e / (n * D), rel=1e-9)
    assert f["objective"] == pytest.approx(e / H * n ** (-1.0 / p), rel=1e-9)
    assert f["objective"] <= e / H


def test_centreline_of_the_desired_bead_at_a_sharp_corner():
    """The centreline figure's floor at a sharp corner: a fine lattice filling the desired
    bead of half-width b around the 90-degree bend (every point within b of the path).
    In the corner's station (arc +-a around it, a = half a station) the outer particles
    beyond the corner project onto it with offsets up to b, while an inner particle
    projects onto the nearer leg at an offset no larger than its foot's distance from the
    corner, so at most a: the station's centreline is (b - a)/2, not 0, for a bead that
    follows the path exactly.  Measured within one lattice spacing."""
    path, _ = named_case("bend90")
    dx, b = D / 32, 0.75 * D
    a = 0.5 * path.length / math.ceil(path.length / D)
    g = np.arange(-5.6e-3, 5.6e-3, dx) + dx / 2
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    xy = xy[path.project(xy)[0] <= b]
    f = deposit_fitness(xy, 1.5 * dx, D, path)
    assert f["centre_dev_max_D"] == pytest.approx((b - a) / 2 / D, abs=dx / D)
    assert f["edge_dev_max_D"] <= dx / D


def test_centre_objective_p_below_one_raises():
    line = DesiredPath([Line((0.0, 0.0), (1e-3, 0.0))])
    with pytest.raises(ValueError, match="centre_p"):
        deposit_fitness(np.zeros((1, 3)), H, D, line, objective="centre", centre_p=0.5)


def test_unknown_objective_raises():
    line = DesiredPath([Line((0.0, 0.0), (1e-3, 0.0))])
    with pytest.raises(ValueError, match="objective"):
        deposit_fitness(np.zeros((1, 3)), H, D, line, objective="width")
