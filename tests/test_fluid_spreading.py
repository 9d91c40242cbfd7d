"""Maximum-spreading correlations (values worked by hand) and the wetted-diameter measurement
(synthetic lamellae of known radius)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphfem.fluid import spreading as sp
from sphfem.output import ParticleSeries
from sphfem.particles import FLUID, WALL, ParticleSet

# --------------------------------------------------------------------------------------
# correlations at We = 100, Re = 1000 (theta = 90 deg unless stated), by hand:
#   Re^(1/5) = 10^0.6 = 3.981072, Re^(2/5) = 10^1.2 = 15.848932, Re^(4/5) = 251.188643,
#   sqrt(Re) = 31.622777, We^(1/4) = 3.162278


def test_pasandideh_fard_by_hand():
    # 4 We / sqrt(Re) = 400 / 31.622777 = 12.649111
    # theta = 90:  (100 + 12) / (3 + 12.649111) = 7.156952 -> sqrt = 2.675248
    # theta = 180: 112 / (6 + 12.649111) = 6.005648 -> sqrt = 2.450642
    assert sp.pasandideh_fard_1996(100.0, 1000.0) == pytest.approx(2.675248, rel=1e-6)
    assert sp.pasandideh_fard_1996(100.0, 1000.0, 180.0) == pytest.approx(2.450642, rel=1e-6)


def test_ukiwe_kwok_by_hand():
    # 15.649111 beta^3 - 112 beta + 8 = 0: at beta = 2.6390 the left side is +0.05, at
    # 2.6385 it is -0.06 (by hand), so the root lies in between
    b = sp.ukiwe_kwok_2005(100.0, 1000.0)
    assert 2.6385 < b < 2.6390
    a = 3.0 + 400.0 / math.sqrt(1000.0)
    assert a * b**3 - 112.0 * b + 8.0 == pytest.approx(0.0, abs=1e-9)


def test_clanet_regimes_by_hand():
    # P = We Re^(-4/5) = 100 / 251.188643 = 0.398 < 1: 0.9 We^(1/4) = 0.9 * 3.162278
    assert sp.clanet_2004(100.0, 1000.0) == pytest.approx(2.846050, rel=1e-6)
    # We = 1000: P = 3.98 > 1: Re^(1/5)
    assert sp.clanet_2004(1000.0, 1000.0) == pytest.approx(3.981072, rel=1e-6)


def test_roisman_by_hand():
    # 0.87 * 3.981072 - 0.40 * 15.848932 / 10 = 3.463533 - 0.633957 = 2.829576
    assert sp.roisman_2009(100.0, 1000.0) == pytest.approx(2.829576, rel=1e-6)


def test_laan_by_hand():
    # P = We Re^(-2/5) = 100 / 15.848932 = 6.309573, sqrt(P) = 2.511886;
    # Re^(1/5) sqrt(P) = 10 exactly; 10 / (1.24 + 2.511886) = 2.665325
    assert sp.laan_2014(100.0, 1000.0) == pytest.approx(2.665325, rel=1e-6)


def test_correlations_vectorise_and_table():
    We = np.array([100.0, 3472.0])
    Re = np.array([1000.0, 16667.0])
    for c in sp.CORRELATIONS.values():
        out = np.asarray(c(We, Re))
        assert out.shape == (2,) and np.all(np.isfinite(out))
        assert out[0] == pytest.approx(float(c(100.0, 1000.0)), rel=1e-12)
    tab = sp.correlation_table(100.0, 1000.0)
    assert set(tab) == set(sp.CORRELATIONS)
    # inertia-dominated limit: the Re-only forms grow like Re^(1/5)
    assert sp.roisman_2009(1e12, 1e5) / sp.roisman_2009(1e12, 1e4) == pytest.approx(
        10**0.2, rel=1e-5)


def test_artificial_viscosity_and_reynolds():
    # alpha h c0 / (2 (d + 2)): 0.02 * 9.375e-6 * 500 / 10 = 9.375e-6 m^2/s
    assert sp.artificial_nu(0.02, 9.375e-6, 500.0, 3) == pytest.approx(9.375e-6, rel=1e-12)
    assert sp.artificial_nu(0.02, 9.375e-6, 500.0, 2) == pytest.approx(0.02 * 9.375e-6
                                                                       * 500.0 / 8)
    assert sp.weber(1000.0, 50.0, 1e-4, 0.072) == pytest.approx(3472.2222, rel=1e-6)
    assert sp.reynolds(1000.0, 50.0, 1e-4, 3e-4) == pytest.approx(16666.667, rel=1e-6)
    assert sp.effective_reynolds(50.0, 1e-4, 3e-7, 9.375e-6) == pytest.approx(
        5e-3 / 9.675e-6, rel=1e-12)


# --------------------------------------------------------------------------------------
# measurement


def _lamella_3d(radius, dx, layers=2, center=(0.0, 0.0)):
    """Cell-centred lattice disc of ``radius`` and ``layers`` layers on the wall z = 0."""
    n = int(np.ceil(radius / dx)) + 1
    g = (np.arange(-n, n) + 0.5) * dx
    X, Y = np.meshgrid(g, g, indexing="ij")
    inside = X**2 + Y**2 <= radius**2
    pts = [np.column_stack([X[inside] + center[0], Y[inside] + center[1],
                            np.full(inside.sum(), (k + 0.5) * dx)]) for k in range(layers)]
    return np.vstack(pts)


@pytest.mark.parametrize("radius", [0.13, 0.2, 0.31])
def test_contact_diameter_of_a_synthetic_lamella(radius):
    dx = 0.01
    fluid = _lamella_3d(radius, dx, center=(0.05, -0.02))
    # distractors: a splash droplet above the contact layer far out, a thick rim above the
    # wetted layer (z > dx) and wall particles below z = 0, all beyond the wetted radius
    splash = np.array([[0.05 + 2.5 * radius, 0.0, 3.2 * dx]])
    rim = np.array([[0.05 + radius + 2 * dx, -0.02, 1.5 * dx]])
    wall = _lamella_3d(3 * radius, dx, layers=3) - np.array([0, 0, 3 * dx])
    x = np.vstack([fluid, splash, rim, wall])
    kind = np.r_[np.full(len(fluid) + 2, FLUID), np.full(len(wall), WALL)]
    d = sp.contact_diameter(x, 0.0, dx, kind)
    # the lattice fills the disc to within one cell: |D - 2 radius| <= dx
    assert abs(d - 2 * radius) <= dx
    # with the axis given the same answer; without kinds the wall rows (z < -dx/2) still drop
    assert sp.contact_diameter(x, 0.0, dx, kind, center=(0.05, -0.02)) == pytest.approx(
        d, abs=dx)
    # within = 2 takes the rim's layer (1.5 dx above the wall) as wetted
    assert sp.contact_diameter(x, 0.0, dx, kind, within=2.0, center=(0.05, -0.02)) == (
        pytest.approx(2 * (radius + 2 * dx) + dx, abs=1e-12))


def test_contact_diameter_2d_and_empty():
    dx = 0.02
    xs = (np.arange(-10, 10) + 0.5) * dx  # a strip of length 0.4 on the wall y = 1
    x = np.column_stack([xs, np.full(xs.size, 1.0 + 0.5 * dx)])
    assert sp.contact_diameter(x, 1.0, dx) == pytest.approx(0.4, abs=1e-12)
    # nothing within one spacing of the wall: 0
    assert sp.contact_diameter(x + [0.0, 2 * dx], 1.0, dx) == 0.0


def test_max_spreading_over_frames_and_from_files(tmp_path):
    dx = 0.01
    radii = [0.05, 0.12, 0.2, 0.17, 0.15]
    series = ParticleSeries(tmp_path)
    frames = []
    for i, r in enumerate(radii):
        x = _lamella_3d(r, dx)
        frames.append((0.1 * i, x, np.full(len(x), FLUID)))
        series.write(0.1 * i, ParticleSet.from_arrays(x, vol=dx**3), ["kind"])
    s = sp.max_spreading(frames, D=0.1, wall_level=0.0, dx=dx)
    assert s.index == 2 and s.t_max == pytest.approx(0.2)
    assert abs(s.d_max - 0.4) <= dx and s.beta_max == pytest.approx(s.d_max / 0.1)
    assert not s.at_end
    again = sp.max_spreading(sp.read_frames(tmp_path), D=0.1, wall_level=0.0, dx=dx)
    np.testing.assert_allclose(again.diameters, s.diameters, rtol=1e-12)
    np.testing.assert_allclose(again.times, s.times, rtol=1e-12)


def test_disc_spread_ratio_by_hand():
    # pi D^3 / 6 = pi D_disc^2 h / 4 with h = D / 12: D_disc^2 = 8 D^2 -> 2.828427
    assert sp.disc_spread_ratio(1.0 / 12.0) == pytest.approx(math.sqrt(8.0), rel=1e-12)
    # beta = 6 needs h = 2 D / (3 * 36) = D / 54
    assert sp.disc_spread_ratio(1.0 / 54.0) == pytest.approx(6.0, rel=1e-12)


def test_residual_film_by_hand_and_bad_input():
    """h_res = 0.79 D Re^-0.4 (Roisman 2009): water D = 0.1 mm at 10 m/s, Re = 10^4 / 3,
    by hand 0.79e-4 * (3 / 10^4)^0.4 = 3.0795e-6 m; Re = 1 gives 0.79 D."""
    assert sp.residual_film(1e-4, 1e4 / 3) == pytest.approx(0.79e-4 * (3e-4) ** 0.4, rel=1e-12)
    assert sp.residual_film(1e-4, 1e4 / 3) == pytest.approx(3.0795e-6, rel=1e-4)
    assert sp.residual_film(2.0, 1.0) == pytest.approx(1.58)
    with pytest.raises(ValueError, match="Re"):
        sp.residual_film(1e-4, 0.0)


def test_link_keeps_the_connected_sheet_and_area_diameter():
    dx = 0.01
    radius = 0.2
    sheet = _lamella_3d(radius, dx, layers=1)
    # broken-off particles on the wall, 3 dx apart, out to twice the radius
    xl = radius + 3 * dx * np.arange(1, 6)
    loose = np.column_stack([xl, np.zeros(5), np.full(5, 0.5 * dx)])
    x = np.vstack([sheet, loose])
    everything = sp.contact_diameter(x, 0.0, dx, center=(0.0, 0.0))
    assert everything == pytest.approx(2 * (loose[:, 0].max() + 0.5 * dx))
    # links up to 2 dx join the lattice (spacing dx, diagonal 1.41 dx) but not the loose ones
    assert abs(sp.contact_diameter(x, 0.0, dx, link=2.0, center=(0.0, 0.0))
               - 2 * radius) <= dx
    # area: N dx^2 = pi D^2 / 4 for the lattice disc (to the cells cut by the circle)
    assert sp.area_diameter(sheet, 0.0, dx) == pytest.approx(2 * radius, rel=0.03)
    # 2D: the wetted length
    xs = np.column_stack([(np.arange(7) + 0.5) * dx, np.full(7, 0.4 * dx)])
    assert sp.area_diameter(xs, 0.0, dx) == pytest.approx(7 * dx)


def test_spreading_study_scenes_parse():
    """examples/droplet_impact/spreading_study.py: every case is a valid scene with the
    stated spacing and an end time 4 tc after contact (contact at R / v)."""
    import importlib.util
    from pathlib import Path

    from sphfem.scene import parse_scene

    path = Path(__file__).resolve().parents[1] / "examples" / "droplet_impact" / \
        "spreading_study.py"
    spec = importlib.util.spec_from_file_location("spreading_study", path)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    for name in study.CASES:
        c = study.case_params(name)
        sc = parse_scene(study.scene_dict(c), source=name)
        assert sc.sph.dx == pytest.approx(study.D / c["n"])
        tc = study.D / c["v"]
        assert sc.time.t_end == pytest.approx(sc.support_radius / c["v"] + study.T_TC * tc)



def _lattice(R, dx):
    g = (np.arange(int(2.5 * R / dx)) + 0.5) * dx
    r, z = np.meshgrid(g, g, indexing="ij")
    return g, r.ravel(), z.ravel()


def _sheet(r, z, rc, dx, rows=2, out=1.4):
    return (r > rc) & (r <= out * rc) & (z < rows * dx)


@pytest.mark.parametrize("d_over_R", [0.1, 0.25, 0.5])
def test_lamella_root_converges_to_the_contact_radius(d_over_R):
    """A sphere pressed d into the wall (the part below cut off) with a two-row sheet from
    its contact radius r_c = sqrt(R^2 - (R - d)^2) outwards: the sphere overhangs the sheet
    in a wedge of air that opens with slope s = r_c / (R - d), and the root is found where
    the wedge above the sheet is wider than ``gap`` spacings: within (gap + rows + 1) dx / s
    + 2 dx beyond r_c (a bound that falls with dx), never inside it.  The wetted edge is
    the sheet's tip."""
    R, gap, rows = 1.0, 2.5, 2
    d = d_over_R * R
    rc = math.sqrt(R * R - (R - d) ** 2)
    slope = rc / (R - d)
    for dx in (R / 40, R / 80, R / 160):
        _, r, z = _lattice(R, dx)
        keep = (r ** 2 + (z - (R - d)) ** 2 <= R * R) | _sheet(r, z, rc, dx, rows)
        r, z = r[keep], z[keep]
        root = sp.lamella_root_radius(r, z, 0.0, dx, 0.1 * R, gap=gap)
        err = root - rc
        assert -dx <= err <= (gap + rows + 1) * dx / slope + 2 * dx, (dx, root, rc)
        x = np.column_stack([r, z])
        tip = r[z < dx].max()
        assert sp.contact_diameter(x, 0.0, dx, center=[0.0]) == pytest.approx(
            2 * (tip + 0.5 * dx))
        assert tip > 1.3 * rc


def test_lamella_root_of_a_column_and_an_overhanging_blob():
    """A vertical column r <= r_c with a sheet beyond it: the root is r_c to within one
    spacing for any threshold between the sheet and the column; a blob hanging over the
    sheet with three spacings of air below it is not wall-attached, and closing that air
    moves the root out to the blob's edge."""
    R, dx = 1.0, 1.0 / 40
    rc = 0.6 * R
    g, r, z = _lattice(R, dx)
    keep = ((r <= rc) & (z <= R)) | _sheet(r, z, rc, dx)
    for thr in (0.05, 0.1, 0.5):
        assert abs(sp.lamella_root_radius(r[keep], z[keep], 0.0, dx, thr * R) - rc) <= dx
    blob = (r > rc) & (r < 1.2 * rc) & (z > 5 * dx) & (z < 20 * dx)
    assert abs(sp.lamella_root_radius(r[keep | blob], z[keep | blob], 0.0, dx, 0.1 * R)
               - rc) <= dx
    blob = (r > rc) & (r < 1.2 * rc) & (z < 20 * dx)
    assert abs(sp.lamella_root_radius(r[keep | blob], z[keep | blob], 0.0, dx, 0.1 * R)
               - 1.2 * rc) <= 2 * dx  # the bin width


def test_lamella_root_edge_cases():
    dx = 0.1
    assert sp.lamella_root_radius([], [], 0.0, dx, 1.0) == 0.0
    # a film thinner than the threshold everywhere: no body
    r = np.arange(50) * dx
    assert sp.lamella_root_radius(r, np.full(50, 0.5 * dx), 0.0, dx, 1.0) == 0.0
    # nothing on the wall at the axis (the fluid still in the air): no root
    assert sp.lamella_root_radius(r, np.full(50, 5 * dx), 0.0, dx, 0.1) == 0.0
    with pytest.raises(ValueError, match="shape"):
        sp.lamella_root_radius([0.0, 1.0], [0.0], 0.0, dx, 1.0)


def test_lamella_thickness_inviscid_by_hand():
    # 0.39 D / (tau + 0.25)^2: tau = 0.75 -> 0.39 D; tau = 1.75 -> 0.39 D / 4
    assert sp.lamella_thickness_inviscid(0.75, 1e-4) == pytest.approx(0.39e-4, rel=1e-14)
    np.testing.assert_allclose(sp.lamella_thickness_inviscid([0.75, 1.75], 2.0),
                               [0.78, 0.195], rtol=1e-14)
    with pytest.raises(ValueError, match="D must be > 0"):
        sp.lamella_thickness_inviscid(1.0, 0.0)


@pytest.mark.parametrize("rows", [1, 3, 7])
def test_centre_thickness_of_a_film_on_a_lattice(rows):
    """k rows of rings on the wall (surface at z = 0.3, first row dx / 2 above it) read k
    dx at the axis, wherever the film ends radially; drops thrown above a gap are not
    counted; a dry axis reads 0."""
    dx, wall = 0.1, 0.3
    r, z = np.meshgrid((np.arange(40) + 0.5) * dx, wall + (np.arange(rows) + 0.5) * dx)
    r, z = r.ravel(), z.ravel()
    assert sp.centre_thickness(r, z, wall, dx) == pytest.approx(rows * dx, rel=1e-12)
    # a drop 3 dx above the film's top (gap > 2.5 dx) is not film
    r2 = np.r_[r, 0.5 * dx]
    z2 = np.r_[z, z.max() + 3.0 * dx]
    assert sp.centre_thickness(r2, z2, wall, dx) == pytest.approx(rows * dx, rel=1e-12)
    # a hole at the axis: nothing within 2 dx
    far = r > 2.0 * dx
    assert sp.centre_thickness(r[far], z[far], wall, dx) == 0.0
    # fluid at the axis but lifted off the wall (lowest point 2 dx up): dry
    assert sp.centre_thickness(r, z + 2.0 * dx, wall, dx) == 0.0
    with pytest.raises(ValueError, match="differ in shape"):
        sp.centre_thickness(r, z[:-1], wall, dx)


def test_main_body_is_the_heaviest_connected_group():
    # two groups: 10 light points in a row, 3 heavy points far away
    a = np.c_[np.arange(10.0), np.zeros(10)]
    b = np.c_[100.0 + np.arange(3.0), np.zeros(3)]
    x = np.r_[a, b]
    assert sp.main_body(x, 1.5).sum() == 10  # by count
    heavy = np.r_[np.ones(10), 10.0 * np.ones(3)]
    body = sp.main_body(x, 1.5, heavy)
    assert body.sum() == 3 and body[10:].all()
    assert sp.main_body(np.zeros((0, 2)), 1.0).shape == (0,)
    with pytest.raises(ValueError, match="weights"):
        sp.main_body(x, 1.5, np.ones(3))


def test_body_contact_diameter_leaves_out_shed_and_stray_rings():
    """A lamella 3 rows thick out to r = 40 dx; stray rings on the wall ahead of it, 1.9 dx
    apart along r but alternating in height (2.1-2.7 dx apart: not joined by 2 dx links),
    which the wall-row measure (gaps < 2 dx along r) counts; a shed drop above the wall.
    The body's diameter is the lamella's, the detached fraction the strays' and drop's
    ring-mass share."""
    dx, wall = 1.0, 0.0
    r, z = np.meshgrid((np.arange(40) + 0.5) * dx, (np.arange(3) + 0.5) * dx)
    r, z = r.ravel(), z.ravel()
    rs = r.max() + 1.9 * dx * np.arange(1, 6)
    zs = np.where(np.arange(5) % 2 == 0, -0.45, 1.4) * dx
    rd, zd = np.array([20.0, 20.5]), np.array([10.0, 10.0])
    R, Z = np.r_[r, rs, rd], np.r_[z, zs, zd]
    m = R.copy()  # ring masses grow with r
    D, frac = sp.body_contact_diameter(R, Z, wall, dx, m)
    assert D == pytest.approx(2.0 * (r.max() + 0.5 * dx))
    assert frac == pytest.approx((rs.sum() + rd.sum()) / m.sum())
    # the wall-row measure runs on to the last stray ring
    row = np.sort(R[Z < 1.5 * dx])
    assert row[-1] == pytest.approx(rs[-1]) and np.diff(row).max() < 2.0 * dx
    # a body that has left the wall
    D, frac = sp.body_contact_diameter(r, z + 5.0 * dx, wall, dx)
    assert D == 0.0 and frac == 0.0
    assert sp.body_contact_diameter([], [], wall, dx) == (0.0, 0.0)
