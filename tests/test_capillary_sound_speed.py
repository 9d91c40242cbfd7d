"""c0 against the capillary pressure (sphfem.sound_speed.capillary_sound_speed): the
formula, its use by the droplet study's levels (c0 = max(10 V, bound)) and the set-up
warning of a fluid with surface tension whose c0 is below it."""

from __future__ import annotations

import logging
import math

import pytest

from sphfem.sound_speed import capillary_sound_speed, capillary_warning


def test_capillary_bound_compresses_by_one_per_cent():
    sigma, rho0, h = 0.072, 1000.0, 2.34e-6
    c0 = capillary_sound_speed(sigma, rho0, h)
    assert (sigma / h) / (rho0 * c0 ** 2) == pytest.approx(0.01, rel=1e-12)
    assert capillary_sound_speed(sigma, rho0, h / 4) == pytest.approx(2 * c0, rel=1e-12)
    assert capillary_warning(1.01 * c0, sigma, rho0, h) is None
    text = capillary_warning(30.0, sigma, rho0, h)
    assert "c0 = 30 m/s is low for the surface tension" in text and "3.4 %" in text
    assert capillary_warning(30.0, 0.0, rho0, h) is None
    with pytest.raises(ValueError, match="rho0 > 0"):
        capillary_sound_speed(sigma, -1.0, h)


def test_droplet_levels_take_the_capillary_bound_at_low_speed():
    from sphfem.validation import droplet_impact as di

    for speed, n in ((3.0, 64), (3.0, 128), (10.0, 128), (10.0, 181), (50.0, 256)):
        d = di.scene_at(speed, n, 1.0)
        water = d["materials"]["water"]
        h = 0.5 * d["sph"]["support_factor"] * d["sph"]["dx"]
        bound = capillary_sound_speed(water["sigma"], water["rho0"], h)
        assert water["c0"] == max(10.0 * speed, math.ceil(bound))
    assert di.scene_at(3.0, 64, 1.0)["materials"]["water"]["c0"] > 30.0
    assert di.scene_at(10.0, 181, 1.0)["materials"]["water"]["c0"] == 100.0


def test_axisymmetric_fluid_warns_of_a_low_c0(tmp_path, caplog):
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    dx, D = 6.25e-6, 1e-4
    data = {
        "scene": {"name": "axi", "dim": 2, "geometry": "axisymmetric"},
        "domain": {"lo": [0.0, -0.05e-3], "hi": [0.3e-3, 0.2e-3]},
        "sph": {"dx": dx},
        "materials": {"water": {"rho0": 1000.0, "mu": 3e-4, "c0": 20.0, "sigma": 0.072},
                      "alumina": {"rho0": 3950.0}},
        "blocks": [
            {"name": "substrate", "shape": "box", "kind": "wall", "material": "alumina",
             "lo": [0.0, -3 * dx], "hi": [0.3e-3, 0.0]},
            {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
             "center": [0.0, 0.0], "above": "substrate", "gap": 3 * dx,
             "radius": 0.5 * D, "velocity": [0.0, -1.0]}],
        "physics": {"modules": ["fluid"]},
        "fluid": {"alpha": 0.02, "surface_tension": "csf"},
        "time": {"t_end": 1e-9},
    }
    with caplog.at_level(logging.WARNING, logger="sphfem.axisymmetric_scene"):
        Simulation(parse_scene(data)).run(tmp_path, progress=False)
    assert "c0 = 20 m/s is low for the surface tension" in caplog.text
    caplog.clear()
    data["materials"]["water"]["c0"] = 60.0  # the bound at h = 1.5 dx is 27.7 m/s
    with caplog.at_level(logging.WARNING, logger="sphfem.axisymmetric_scene"):
        Simulation(parse_scene(data)).run(tmp_path / "ok", progress=False)
    assert "low for the surface tension" not in caplog.text
