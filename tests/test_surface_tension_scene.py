"""Every surface-tension model runs from a scene file (issue 14, bug 1).

The ``[fluid]`` cross-key check used to read ``iif_s`` / ``akinci_gamma`` for every model, but
those keys exist only for their own model (``Param.when``), so ``surface_tension = "csf"``,
``"iif"`` or ``"akinci"`` stopped with an AttributeError before anything was built.

Each model is parsed from a TOML file, built and stepped a few times by the driver
(:class:`sphfem.simulation.Simulation`, as ``sphfem run`` does).  The scene is a 2D water
disc (R = 0.4 mm, 8 lattice spacings per radius) at rest, without gravity, above a wall
floor with a clearance larger than the kernel support (the floor exerts no force).

Physics check: at rest on a lattice, the pressure is zero and only surface tension moves
the particles.  Over the first few steps (the pressure reaction grows only as dt^2) the
radial momentum of the disc is the surface force integrated over the boundary,
sum_i m_i v_i . e_r = -t * (sigma kappa) * (2 pi R) = -2 pi sigma t (kappa = 1 / R, per
unit depth).  CSF applies sigma kappa directly and must match it within 5 %; the IIF pair
force also pulls the surface inward with a cohesion pressure that does not depend on
curvature, so for it only the sign and that it reports the material's sigma are checked.
Akinci (issue 17: by default its curvature term alone, which first stretches the lattice's
surface layer outward to build up its tension) must report the material's sigma and, its
forces being pairwise, keep the disc's linear momentum at zero.  ``"none"`` leaves the disc
exactly at rest.
"""

import math

import numpy as np
import pytest

from sphfem.particles import ParticleKind
from sphfem.scene import load_scene
from sphfem.simulation import Simulation

SIGMA = 0.072
RADIUS = 0.4e-3
CENTER = (0.0, 0.6e-3)

SCENE = """
[scene]
name = "st_{model}"
dim = 2
[domain]
lo = [-1.0e-3, -0.4e-3]
hi = [1.0e-3, 1.2e-3]
[sph]
dx = 5.0e-5
[materials.water]
rho0 = 1000.0
mu = 1.0e-3
c0 = 20.0
sigma = {sigma}
[materials.floor]
rho0 = 1000.0
[[blocks]]
name = "floor"
shape = "box"
kind = "wall"
material = "floor"
lo = [-1.0e-3, -0.15e-3]
hi = [1.0e-3, 0.0]
[[blocks]]
name = "drop"
shape = "sphere"
kind = "fluid"
material = "water"
center = [{cx}, {cy}]
radius = {radius}
[physics]
modules = ["fluid"]
[fluid]
surface_tension = "{model}"
[time]
t_end = 1.0e-3
max_steps = 5
"""


def _run(tmp_path, model):
    path = tmp_path / f"{model}.toml"
    path.write_text(SCENE.format(model=model, sigma=SIGMA, cx=CENTER[0], cy=CENTER[1],
                                 radius=RADIUS))
    scene = load_scene(path)
    assert scene.fluid.surface_tension == model
    sim = Simulation(scene, source=str(path))
    summary = sim.run(tmp_path / f"out_{model}", progress=False)
    return sim, summary


def _radial_momentum(sim):
    ps = sim.particles
    fl = ps.kind == ParticleKind.FLUID
    r = ps.x[fl] - np.asarray(CENTER)
    e_r = r / np.linalg.norm(r, axis=1)[:, None]
    return float(np.sum(ps.m[fl] * np.einsum("ij,ij->i", ps.v[fl], e_r)))


@pytest.mark.parametrize("model", ["none", "csf", "iif", "akinci"])
def test_surface_tension_model_from_a_scene_file(tmp_path, model):
    sim, summary = _run(tmp_path, model)
    assert summary["status"] == "max_steps"
    assert summary["steps"] == 5
    assert not sim.particles.check_finite()  # no NaN or Inf
    st = summary["diagnostics"]["fluid"]["surface_tension"]
    assert st["model"] == model
    assert st["sigma_N_per_m"] == pytest.approx(SIGMA)
    p_r = _radial_momentum(sim)
    impulse = 2.0 * math.pi * SIGMA * sim.t  # sigma kappa times the perimeter, times t
    if model == "none":
        assert p_r == 0.0
    elif model == "csf":
        assert p_r == pytest.approx(-impulse, rel=0.05)
    elif model == "iif":
        assert p_r < -0.5 * impulse
        # the calibrated constant reproduces the material's sigma
        assert st["sigma_of_constant_N_per_m"] == pytest.approx(SIGMA, rel=1e-9)
    else:  # akinci: calibrated to sigma, pairwise (momentum-conserving) forces
        assert st["sigma_of_constant_N_per_m"] == pytest.approx(SIGMA, rel=1e-9)
        ps = sim.particles
        fl = ps.kind == ParticleKind.FLUID
        P = np.abs((ps.m[fl, None] * ps.v[fl]).sum(0)).max()
        assert P < 1e-9 * float(np.sum(ps.m[fl] * np.linalg.norm(ps.v[fl], axis=1)))
