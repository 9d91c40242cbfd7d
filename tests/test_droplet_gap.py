"""The droplet starts clear of the substrate; first contact is recorded (issue 14, bug 5).

The droplet scenes used to start one dx above the substrate, inside the kernel support
radius R = 3 dx, so the substrate carried a load at t = 0 (18 kPa von Mises).  A block can
now be placed ``gap`` above another (``[[blocks]] above = "substrate"``, ``gap >= R``, see
:func:`sphfem.geometry.place_above`), and the coupling records the first contact: the end of
the first step at which a fluid particle is closer than R to a substrate particle.

Before contact the droplet flies ballistically (no gravity, p = 0 on a lattice at rho0,
uniform velocity: no force), so the contact time is known exactly from the initial
particle positions x_f, x_s and the velocity u: the first t >= 0 with
|x_f - x_s + u t| = R over all pairs.  The recorded contact is the end of the step in which
that time falls: t_pred <= t_contact <= t_pred + dt.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import coupling  # noqa: F401  (registers the "coupling" module and its section)
from sphfem.geometry import build_particles
from sphfem.particles import ParticleKind
from sphfem.scene import SceneError, load_scene, parse_scene_toml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "droplet_impact"
SPEED = 20.0

SCENE = """
[scene]
name = "gap_2d"
dim = 2
[domain]
lo = [-0.6e-3, -0.3e-3]
hi = [0.6e-3, 0.5e-3]
[sph]
dx = 25e-6
[materials.water]
rho0 = 1000.0
c = 4000.0
k = 0.6
mu = 1.0e-3
c0 = 200.0
[materials.alumina]
rho0 = 3950.0
c = 900.0
k = 10.0
E = 300e9
nu = 0.21
alpha = 8.1e-6
[[blocks]]
name = "substrate"
shape = "box"
kind = "wall"
material = "alumina"
lo = [-0.5e-3, -0.25e-3]
hi = [0.5e-3, 0.0]
temperature = "20 C"
[[blocks]]
name = "droplet"
shape = "sphere"
kind = "fluid"
material = "water"
center = [0.0, 0.0]
radius = 0.1e-3
above = "substrate"
gap = {gap}
velocity = [0.0, -{speed}]
temperature = "100 C"
[physics]
modules = ["fluid", "heat", "coupling"]
[coupling]
material = "alumina"
clamps = ["left", "right"]
every_k_steps = 2
[coupling.mesh]
h_fine = 25e-6
cells = "tri"
[time]
t_end = {t_end}
"""

R = 3 * 25e-6


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SPHFEM_CACHE", str(tmp_path / "cache"))


def ballistic_contact_time(xf, xs, u, R):
    """First t >= 0 with |xf_i - xs_j + u t| = R over all pairs (inf if never)."""
    d = xf[:, None, :] - xs[None, :, :]
    a = float(u @ u)
    b = d @ u
    c = np.einsum("ijk,ijk->ij", d, d) - R * R
    disc = b * b - a * c
    ok = disc >= 0.0
    t = (-b[ok] - np.sqrt(disc[ok])) / a
    t = t[t >= 0.0]
    return float(t.min()) if t.size else math.inf


def test_gap_is_placed_and_validated():
    gap = 1.5 * R
    s = parse_scene_toml(SCENE.format(gap=gap, speed=SPEED, t_end=1e-6))
    drop, sub = s.blocks[1], s.blocks[0]
    assert drop.center[1] - drop.radius == pytest.approx(sub.hi[1] + gap, rel=1e-12)
    assert s.blocks[1].gap == gap
    assert parse_scene_toml(SCENE.format(gap=gap, speed=SPEED, t_end=1e-6)) == s
    from sphfem.scene import parse_scene

    assert parse_scene(s.to_dict()) == s  # the resolved scene round-trips
    default = parse_scene_toml(SCENE.format(gap=R, speed=SPEED, t_end=1e-6).replace(
        f"gap = {R}\n", ""))
    assert default.blocks[1].gap == pytest.approx(R)  # default: the support radius
    with pytest.raises(SceneError, match=r"blocks\[1\]\.gap: clearance .* less than the "
                                         r"kernel support radius"):
        parse_scene_toml(SCENE.format(gap=0.5 * R, speed=SPEED, t_end=1e-6))
    with pytest.raises(SceneError, match=r"blocks\[1\]\.above: expected the name of an "
                                         r"earlier block"):
        parse_scene_toml(SCENE.format(gap=R, speed=SPEED, t_end=1e-6).replace(
            'above = "substrate"', 'above = "floor"'))
    with pytest.raises(SceneError, match=r"blocks\[1\]\.gap: applies only with `above`"):
        parse_scene_toml(SCENE.format(gap=R, speed=SPEED, t_end=1e-6).replace(
            'above = "substrate"\n', ""))


@pytest.mark.parametrize("name", ["droplet_impact.toml", "droplet_impact_full.toml",
                                  "droplet_impact_tlsph.toml"])
def test_droplet_scenes_start_clear_of_the_substrate(name):
    s = load_scene(EXAMPLES / name)
    drop = next(b for b in s.blocks if b.kind == "fluid")
    sub = s.blocks[s.block_index(drop.above)] if drop.above else None
    assert sub is not None, f"{name}: the droplet is not placed with above/gap"
    clearance = drop.center[-1] - drop.radius - sub.hi[-1]
    assert clearance >= s.support_radius * (1 - 1e-12)
    assert s.fluid.surface_tension == "csf" and s.materials[drop.material].sigma == 0.072
    if name == "droplet_impact.toml":  # the particles themselves (the others are larger)
        ps = build_particles(s)
        fl = ps.kind == ParticleKind.FLUID
        from scipy.spatial import cKDTree

        d, _ = cKDTree(ps.x[~fl]).query(ps.x[fl])
        assert d.min() >= s.support_radius


def test_no_load_before_contact_and_contact_time(tmp_path, cache):
    from sphfem.api import run

    gap = 1.2 * R
    t_end = 1.2 * gap / SPEED
    scene = parse_scene_toml(SCENE.format(gap=gap, speed=SPEED, t_end=t_end))
    ps0 = build_particles(scene)
    fl = ps0.kind == ParticleKind.FLUID
    u = np.array([0.0, -SPEED])
    t_pred = ballistic_contact_time(ps0.x[fl], ps0.x[~fl], u, R)
    assert 0.0 < t_pred < t_end

    res = run(scene, tmp_path / "out")
    summary = res.summary
    c = summary["diagnostics"]["coupling"]
    dt_max = summary["dt"]["max"]
    # the substrate carries no load at t = 0, nor at any solve before contact: no force at
    # all, and a stress at the round-off of the mapped temperature (E alpha T0 1e-12 =
    # 7e-4 Pa; the old one-dx start gave 18 kPa in the 3D scene)
    roundoff = 300e9 * 8.1e-6 * 293.15 * 1e-12
    assert c["start"]["t"] == 0.0
    assert c["start"]["peak_von_mises_Pa"] < roundoff
    assert c["start"]["force_sensors"] == [0.0, 0.0]
    hist = json.loads((tmp_path / "out" / "substrate" / "history.json").read_text())[
        "history"]
    t_contact = c["t_contact_s"]
    before = [h for h in hist if h["t"] < t_contact]
    assert len(before) >= 3
    assert all(h["peak_von_mises"] < roundoff and h["force_sensors"] == [0.0, 0.0]
               for h in before)
    assert max(h["peak_von_mises"] for h in hist) > 1e3 * roundoff  # and a load after it
    # the impact force's peak: the largest wall-normal sensor force of the history
    peak = max(hist, key=lambda h: abs(h["force_sensors"][-1]))
    assert c["peak_normal_force_N"] == abs(peak["force_sensors"][-1]) > 0.0
    assert c["peak_normal_force_t_s"] == peak["t"] > t_contact
    # contact at the end of the step in which the ballistic contact time falls
    # a pair closes at most at |u|: contact needs >= (d0 - R) / |u|; equal here, as the two
    # lattices are vertically aligned (a pair straight above another)
    assert c["contact"]["clearance_at_start_m"] == pytest.approx(t_pred * SPEED, rel=1e-9)
    assert t_pred * (1 - 1e-9) <= t_contact <= t_pred + dt_max * (1 + 1e-9)
    assert c["peak_von_mises_t_after_contact_s"] == pytest.approx(
        c["peak_von_mises_t_s"] - t_contact)


def test_contact_after_resume(tmp_path, cache):
    """A run resumed from a checkpoint before contact finds the same contact step as an
    uninterrupted run; one resumed past contact keeps the contact time of the process that
    saw it (the coupling's checkpoint state) instead of reporting the resume time."""
    from sphfem.simulation import Simulation

    gap = 1.2 * R
    t_end = 1.2 * gap / SPEED
    text = SCENE.format(gap=gap, speed=SPEED, t_end=t_end)
    ref = Simulation(parse_scene_toml(text)).run(tmp_path / "ref", progress=False)
    c_ref = ref["diagnostics"]["coupling"]["contact"]
    assert c_ref["step"] is not None
    for where, every, steps in (("before", 0.5 * c_ref["t_s"], c_ref["step"] - 2),
                                ("after", 1.05 * c_ref["t_s"], c_ref["step"] + 10)):
        out = tmp_path / where  # stop after `steps`; the checkpoint is the last output
        stop = parse_scene_toml(text.replace("[time]\n", f"[time]\nmax_steps = {steps}\n")
                                + f"[output]\nevery = {every!r}\n")
        Simulation(stop).run(out, progress=False)
        assert (out / "checkpoint.npz").exists()
        full = parse_scene_toml(text + f"[output]\nevery = {every!r}\n")
        c = Simulation(full).run(out, progress=False, resume=True)["diagnostics"][
            "coupling"]["contact"]
        # output times split a step: the same contact within a step
        assert abs(c["t_s"] - c_ref["t_s"]) <= ref["dt"]["max"], where
        assert "note" not in c, where
