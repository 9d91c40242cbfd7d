"""Extrusion of direct ink writing (sphfem.diw.extrusion, issue 18 part B): the nozzle's
inflow flux, emission without overlap, mass conservation of a straight bead, and the
overshoot of the naive 90-degree bend (slow).

The reduced scene examples/diw/line_reduced.toml: thesis table 3.2's ink density and nozzle
(D = 0.7 mm) with a Herschel-Bulkley rheology, 4 particles across the bore, DFSPH with
Weiler et al.'s implicit viscosity.  The toolpaths are stand-ins written here (the contract:
position(t), velocity(t), duration).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from sphfem.diw.extrusion import bore_lattice, simulate_deposit
from sphfem.errors import SceneError
from sphfem.scene import load_scene, parse_scene, parse_scene_toml

ROOT = Path(__file__).resolve().parents[1]
REDUCED = ROOT / "examples" / "diw" / "line_reduced.toml"


class Line:
    """Straight toolpath from ``p0`` along ``direction`` at ``speed`` for ``length``."""

    def __init__(self, p0, direction, speed, length):
        self.p0 = np.asarray(p0, float)
        self.d = np.asarray(direction, float) / np.linalg.norm(direction)
        self.speed = speed
        self.length = length
        self.duration = length / speed

    def position(self, t):
        return self.p0 + self.d * self.speed * t

    def velocity(self, t):
        return self.d * self.speed


class Bend:
    """Two straight legs of ``leg`` meeting at the origin at 90 degrees: along +x to the
    corner, then along +y, at constant ``speed`` (the naive 90-degree toolpath)."""

    def __init__(self, leg, speed):
        self.leg, self.speed = leg, speed
        self.duration = 2 * leg / speed

    def position(self, t):
        s = self.speed * t
        return np.array([s - self.leg, 0.0]) if s <= self.leg else np.array(
            [0.0, s - self.leg])

    def velocity(self, t):
        return np.array([self.speed, 0.0]) if self.speed * t < self.leg else np.array(
            [0.0, self.speed])


def test_bore_lattice_flux_is_exact():
    """The piston speed makes the flux N_b dx^2 U_b equal Q for any bore lattice, and the
    lattice disc stays within a few per cent of pi D^2 / 4 from 4 points across."""
    D = 7e-4
    for n_across in (4, 6, 8, 12):
        dx = D / n_across
        pts = bore_lattice(D, dx)
        r = np.hypot(pts[:, 0], pts[:, 1])
        assert r.max() < D / 2                         # inside the bore
        assert abs(pts.mean(axis=0)).max() < 1e-12 * D  # centred on the axis
        ratio = pts.shape[0] * dx**2 / (math.pi * D**2 / 4)
        assert 0.9 < ratio < 1.15


def test_extrusion_scene_needs_one_flux():
    text = REDUCED.read_text().replace("extrusion_speed = 0.1",
                                       "extrusion_speed = 0.1\nflow_rate = 1e-8")
    with pytest.raises(SceneError, match="exactly one of extrusion_speed"):
        parse_scene_toml(text, source="x.toml")


def test_generic_driver_refuses_extrusion_scene():
    """The nozzle adds particles, which the driver's module protocol forbids: building the
    scene's modules says where extrusion scenes run instead."""
    from sphfem.physics import build_modules

    with pytest.raises(SceneError, match="simulate_deposit"):
        build_modules(load_scene(REDUCED))


@pytest.fixture(scope="module")
def straight_bead():
    """An 8 mm straight line at 30 degrees to the lattice axes (so the bead's centreline is
    not given by symmetry); about 10 s."""
    scene = load_scene(REDUCED)
    ang = math.radians(30.0)
    path = Line([0.0, -1.5e-3], [math.cos(ang), math.sin(ang)], scene.extrusion.nozzle_speed,
                8e-3)
    return scene, path, simulate_deposit(scene, path)


def test_emitted_volume_matches_flux(straight_bead):
    """Emitted ink = Q t to within one buffer layer (N_b dx^3), and the ink leaving the
    outlet does so at Q (least-squares slope over 20-100 % of the path time: within 2 %)."""
    scene, path, res = straight_bead
    info = res.info
    assert info["stopped_reason"] is None
    assert info["particles"]["leaked"] == 0  # no ink above the outlet outside the bore
    dx = info["dx"]
    layer = info["bore_points"] * dx**3
    Qt = info["expected_emitted_volume_m3"]
    assert Qt == pytest.approx(info["flow_rate_m3_per_s"] * path.duration, rel=1e-12)
    assert abs(info["emitted_volume_m3"] - Qt) <= layer
    h = info["history"]
    t, out = np.asarray(h["t"]), np.asarray(h["outflow"])
    win = (t > 0.2 * path.duration) & (t <= path.duration)
    slope = np.polyfit(t[win], out[win], 1)[0]
    assert slope == pytest.approx(info["flow_rate_m3_per_s"], rel=0.02)


def test_emission_does_not_overlap(straight_bead):
    """The released and the new buffer layer are never closer than 0.75 dx to any particle
    (layers enter dx apart; the ink below the piston is compressed only by the solver's
    density tolerance)."""
    info = straight_bead[2].info
    assert info["emissions"] > 10
    assert info["emission_min_distance_over_dx"] >= 0.75


def test_straight_bead_mass_and_centreline(straight_bead):
    """Mass conservation of the steady bead: ink volume per unit length over the window
    s in [L/2, L - 2D] of the path equals Q / U_nozzle within 5 %; its centroid lies on the
    path within 0.25 dx (normal offset) and every D-long slice's within dx."""
    scene, path, res = straight_bead
    dx, D = res.info["dx"], res.nozzle_diameter
    rel = res.positions[:, :2] - path.p0
    s = rel @ path.d
    nrm = rel @ np.array([-path.d[1], path.d[0]])
    a, b = path.length / 2, path.length - 2 * D
    win = (s > a) & (s < b)
    area = win.sum() * dx**3 / (b - a)
    Q = res.info["flow_rate_m3_per_s"]
    assert area == pytest.approx(Q / path.speed, rel=0.05)
    assert abs(nrm[win].mean()) < 0.25 * dx
    for lo in np.arange(a, b - D, D):
        sl = (s > lo) & (s < lo + D)
        assert abs(nrm[sl].mean()) < dx


@pytest.mark.slow
def test_naive_bend_overshoots_corner():
    """The naive 90-degree toolpath (examples/diw/bend90.toml, thesis ink, at D/dx = 4):
    the deposit reaches past the corner (x > 0, where the path never goes) farther than the
    bead's own edge on the second leg, by more than one particle spacing (measured 0.50 D
    = 2.0 dx; 0.53 D at D/dx = 8, docs/diw_extrusion.md).  About 10 CPU s."""
    data = tomllib.loads((ROOT / "examples" / "diw" / "bend90.toml").read_text())
    D = data["extrusion"]["nozzle_diameter"]
    dx = D / 4
    data["sph"]["dx"] = dx
    sub = next(b for b in data["blocks"] if b["kind"] == "wall")
    sub["lo"][2] = sub["hi"][2] - 3 * dx
    scene = parse_scene(data, source="bend90 at D/4")
    path = Bend(5e-3, scene.extrusion.nozzle_speed)
    res = simulate_deposit(scene, path)
    assert res.info["stopped_reason"] is None
    x = res.positions
    corner = x[:, 1] < 2e-3
    leg = (x[:, 1] > 2e-3) & (x[:, 1] < 4e-3)  # the second leg, away from both ends
    beyond = x[corner, 0].max() - x[leg, 0].max()
    assert beyond > dx


def test_start_dwell_primes_the_bead():
    """With start_dwell longer than the first ink's fall over the stand-off
    (t = (-U + sqrt(U^2 + 2 g H)) / g = 9.4 ms here), the bead starts at the path's start
    (within D/2; without priming it starts ~1.5 mm later), and the emitted volume is
    Q (dwell + duration) to within one layer."""
    text = REDUCED.read_text().replace("settle_time = 0.01",
                                       "settle_time = 0.01\nstart_dwell = 0.012")
    scene = parse_scene_toml(text, source="dwell.toml")
    path = Line([0.0, 0.0], [1.0, 0.0], scene.extrusion.nozzle_speed, 3e-3)
    res = simulate_deposit(scene, path)
    info, D = res.info, res.nozzle_diameter
    assert info["stopped_reason"] is None
    s = res.positions[:, 0]
    on_path = s[s > 0]
    assert on_path.min() < 0.5 * D
    Q = info["flow_rate_m3_per_s"]
    layer = info["bore_points"] * info["dx"] ** 3
    assert abs(info["emitted_volume_m3"] - Q * (0.012 + path.duration)) <= layer


def test_end_ramp_kinematics():
    """end_ramp l: the nozzle's speed falls linearly from v to 0 over the last l of the path
    (which then takes 2 l / v), its velocity is dP/dt, it ends at the path's end, and the
    flux follows the speed: the emitted volume / Q (extruded_time) is dwell + path time,
    as without the ramp; coast_distance c stops extrusion where c of the path is left."""
    from sphfem.diw.extrusion import Nozzle

    L, dwell, ramp, coast = 3e-3, 0.012, 1e-3, 0.4e-3
    text = REDUCED.read_text().replace(
        "settle_time = 0.01",
        f"settle_time = 0.01\nstart_dwell = {dwell}\nend_ramp = {ramp}\ncoast_distance = 0.0")
    scene = parse_scene_toml(text, source="ramp.toml")
    v = scene.extrusion.nozzle_speed
    path = Line([0.0, 0.0], [1.0, 0.0], v, L)
    noz = Nozzle(scene, path, 0.0, 800.0)
    assert noz.duration == pytest.approx(dwell + (L - ramp) / v + 2 * ramp / v, rel=1e-12)
    t = np.linspace(0.0, noz.duration, 4001)
    x = np.array([noz.P(ti)[0] for ti in t])
    vx = np.array([noz.V(ti)[0] for ti in t])
    assert x[-1] == pytest.approx(L, rel=1e-12)
    assert noz.t_stop == noz.duration  # no coasting: extrusion ends with the ramp, exactly
    ramp_t = t - (dwell + (L - ramp) / v)
    on = (ramp_t > 0) & (t < noz.duration)
    np.testing.assert_allclose(vx[on], v * (1 - ramp_t[on] / (2 * ramp / v)), rtol=1e-9)
    eps = 1e-8  # central difference of P, exact for the quadratic ramp to rounding
    mid = t[(t > dwell + eps) & (t < noz.duration - eps)]
    dxdt = [(noz.P(ti + eps)[0] - noz.P(ti - eps)[0]) / (2 * eps) for ti in mid]
    np.testing.assert_allclose(dxdt, [noz.V(ti)[0] for ti in mid], atol=1e-6 * v)
    assert noz.extruded_time(noz.duration + 1.0) == pytest.approx(dwell + L / v, rel=1e-12)
    noz_c = Nozzle(parse_scene_toml(text.replace("coast_distance = 0.0",
                                                 f"coast_distance = {coast}"), source="c"),
                   path, 0.0, 800.0)
    assert L - noz_c.P(noz_c.t_stop)[0] == pytest.approx(coast, rel=1e-9)
    assert noz_c.piston(noz_c.t_stop) == 0.0 < noz_c.piston(noz_c.t_stop * (1 - 1e-9))


@pytest.fixture(scope="module")
def path_ends():
    """A primed 3 mm line (HB ink of the reduced scene, D/dx = 4) ended three ways: a dead
    stop, coasting over c = v t_fall and a ramp over l = v t_fall (t_fall = 9.4 ms, the
    ink's fall over the 1.4 mm stand-off); about 12 s."""
    from sphfem.diw.fitness import deposit_fitness
    from sphfem.diw.toolpath import DesiredPath
    from sphfem.diw.toolpath import Line as PathLine

    L, dwell, c = 3e-3, 0.012, 0.94e-3
    out = {}
    for name, key in (("stop", "coast_distance = 0"), ("coast", f"coast_distance = {c}"),
                      ("ramp", f"end_ramp = {c}")):
        text = REDUCED.read_text().replace(
            "settle_time = 0.01", f"settle_time = 0.01\nstart_dwell = {dwell}\n{key}")
        scene = parse_scene_toml(text, source=f"{name}.toml")
        v = scene.extrusion.nozzle_speed
        res = simulate_deposit(scene, Line([0.0, 0.0], [1.0, 0.0], v, L))
        fit = deposit_fitness(res.positions, res.h, res.nozzle_diameter,
                              DesiredPath([PathLine((0, 0), (L, 0))]))
        out[name] = (res, fit, res.positions[:, 0].max() - L)
    return L, dwell, c, out


def test_path_end_volumes(path_ends):
    """Emitted volume within one layer of Q (dwell + T - c / v) when coasting and of
    Q (dwell + T) with the ramp (the flux follows the nozzle's speed), as with a dead
    stop; no run stopped."""
    L, dwell, c, out = path_ends
    for name, (res, _, _) in out.items():
        info = res.info
        assert info["stopped_reason"] is None
        v = 0.1
        layer = info["bore_points"] * info["dx"] ** 3
        expect = info["flow_rate_m3_per_s"] * (dwell + L / v - (c / v if name == "coast" else 0))
        assert abs(info["emitted_volume_m3"] - expect) <= layer, name


def test_coasting_and_ramp_shorten_the_reach_past_the_end(path_ends):
    """Ink in the air when the nozzle stops dead lands past the end point.  Coasting (lay
    the ink in the air along the path) and the ramp (the ink leaves with the nozzle's
    dwindling speed) both shorten the bead's reach past the end by more than half a spacing
    (measured at D/dx = 4 with this yield-stress ink: 0.72 D dead stop, 0.53 D coasting,
    0.45 D ramp), and the end stays covered (no shortfall of the desired bead)."""
    _, _, _, out = path_ends
    dx = out["stop"][0].info["dx"]
    for name in ("coast", "ramp"):
        assert out[name][1]["edge_short_max_D"] == 0.0, name
        assert out[name][2] < out["stop"][2] - 0.5 * dx, name
