"""``sphfem validate stability``: stiff and extreme scenes run to their end, one verdict each.

Every row is a complete scene (built here as a dict, run by the ordinary driver into its own
folder) and ends in one of three verdicts:

* ``stable``: the run reached ``t_end`` and every check of the row passed;
* ``stopped cleanly``: a guard stopped it, and every check passed: the stop was expected
  (or allowed) for the row, the message names the guard the row expects, a required stop
  came by a bounded step, every written file is finite, and the state before the stopping
  step passed the row's physics checks;
* ``FAILED``: a crash (an exception other than a guard's), a stop where the row must run
  through, a run through where the row must stop, or any check missed.

Checks run after a stop as well, on the state before the stopping step (kept by
:class:`_Recorder`); a figure that is missing counts as a failed check, never as zero.
Every row has checks that can fail: besides its own physics checks (energy ledger,
maximum principle, mechanical energy of the fluid, force balance, stress scale, the dt
cap), every row scans all the files it wrote (particle and substrate VTU, probe CSV, JSON,
checkpoint) for NaN/Inf.

Figures per row come from the run's ``summary.json``: steps, smallest dt and the limit that
set it, steps above the stable limit, max speed over c0, the density band rho/rho0, the
energy-balance residual of the heat ledger (E - E0 - boundary heat) / E, the temperature
range, renormalisation/Laplacian fallbacks, the substrate's peak von Mises stress, and wall
seconds.

The rows (quick: 2D and coarse; full: 3D droplets and finer heat patches) are
- a 50 m/s water droplet onto a 300 GPa substrate (fluid, heat, FEM coupling), and onto a
  300 GPa TL-SPH substrate;
- 100 m/s impacts with c0 at 10x the impact speed, and at 5x (Mach 0.2);
- a 1000 K thermal shock (droplet at 1293 K on a 293 K substrate, heat and FEM stress);
- a conductivity contrast of 1e4 (explicit plain and corrected Laplacian, implicit);
- a viscosity 1e3x that of water;
- 20 % random disorder of every particle;
- isolated particles and one-particle-thick sheets (singular corrections);
- fixed time steps at 0.9x and 2x the stable limit, with the cap (the driver adapts) and
  without it (``[time] cap_dt = false``: the guards must stop the run cleanly), for heat and
  for the fluid, and at 8x without the cap.
"""

from __future__ import annotations

import copy
import json
import logging
import math
import re
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

STABLE, STOPPED, FAILED = "stable", "stopped cleanly", "FAILED"

log = logging.getLogger(__name__)


#: what a row's run must do (``Row.expect``)
EITHER = "stable or stopped"


@dataclass
class Outcome:
    """What a row's checks see: the summary, the output folder, how the run ended, the
    state at the first step and the ``final`` state (the end state of a run that reached
    ``t_end``; the state before the stopping step of a stopped run), the scene dict and the
    stable dt limit measured for ``dt_factor`` rows (else None)."""

    summary: dict
    folder: Path
    stopped: bool
    message: str
    initial: dict
    final: dict
    scene: dict
    stable_limit: float | None = None


#: a check: fn(outcome) -> (value or None when the figure is missing, limit, op)
Check = Callable[[Outcome], tuple[float | None, float, str]]


@dataclass
class Row:
    """One scene of the matrix: ``build(quick)`` returns the scene dict."""

    name: str
    description: str
    build: Callable[[bool], dict]
    #: STABLE: must reach t_end; STOPPED: a guard must stop it; EITHER: both pass
    expect: str = STABLE
    #: regular expression the stop message must match (the guard the row expects to fire);
    #: required when a stop is allowed
    guard: str | None = None
    #: a required stop must come at or before this step
    max_stop_step: int | None = None
    #: the row's physics checks, evaluated on every run, stopped or not
    checks: dict[str, Check] = field(default_factory=dict)
    #: run the scene once without a fixed dt to measure the stable limit, then set
    #: ``time.dt = dt_factor * limit`` (and ``cap_dt``)
    dt_factor: float | None = None
    cap_dt: bool = True


@dataclass
class RowResult:
    name: str
    description: str
    verdict: str
    reason: str
    figures: dict
    checks: dict
    wall_s: float

    @property
    def passed(self) -> bool:
        return self.verdict != FAILED


# --------------------------------------------------------------------------------------
# scenes

WATER = {"rho0": 1000.0, "c": 4000.0, "k": 0.6, "mu": 3.0e-4, "c0": 500.0}
ALUMINA = {"rho0": 3950.0, "c": 900.0, "k": 10.0, "E": 300.0e9, "nu": 0.21, "alpha": 8.1e-6}


def droplet_scene(quick: bool, *, speed: float = 50.0, c0: float | None = None,
                  T_drop: float = 373.15, T_sub: float = 293.15, mu_factor: float = 1.0,
                  modules=("fluid", "heat", "coupling"), t_tc: float = 1.0, jitter: float = 0.0,
                  laplacian: str = "cleary", E: float = 300.0e9, dx: float | None = None
                  ) -> dict:
    """A water droplet (D = 0.1 mm) hitting an alumina-like substrate block (wall particles,
    coupled to an FEM substrate when ``coupling`` is listed).  2D at dx = 5 um (quick) or 3D
    at dx = 6.25 um.  A moving droplet starts a support radius (3 dx) above the substrate and
    runs ``t_tc`` contact times D / speed after reaching it; a droplet at rest lies on the
    substrate one dx above it and runs 0.4 ms (some 200 explicit thermal steps)."""
    dim = 2 if quick else 3
    dx = dx or (5.0e-6 if quick else 6.25e-6)
    D = 1.0e-4
    half = 0.2e-3
    water = dict(WATER, mu=WATER["mu"] * mu_factor, c0=c0 if c0 else max(10.0 * speed, 500.0))
    lat = [-half] * (dim - 1)
    # a moving droplet starts one support radius above the substrate (no pair interacts at
    # t = 0) and runs t_tc contact times after touching it; at rest it lies on the substrate
    R = 3.0 * dx
    t_end = (t_tc * D + R) / speed if speed > 0 else 4.0e-4  # at rest: ~200 thermal steps
    drop = {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
            "center": [0.0] * (dim - 1) + [0.5 * D + dx], "radius": 0.5 * D,
            "velocity": [0.0] * (dim - 1) + [-speed], "temperature": T_drop,
            "sampling": "lattice" if jitter else "poisson", "jitter": jitter}
    if speed > 0:
        drop.update(center=[0.0] * dim, above="substrate", gap=R)
    sub = {"name": "substrate", "shape": "box", "kind": "wall" if "fluid" in modules else "solid",
           "material": "alumina", "lo": lat + [-6 * dx], "hi": [half] * (dim - 1) + [0.0],
           "temperature": T_sub, "jitter": jitter}
    scene = {
        "scene": {"name": "droplet", "dim": dim, "seed": 1},
        "domain": {"lo": [-1.25 * half] * (dim - 1) + [-12 * dx],
                   "hi": [1.25 * half] * (dim - 1) + [1.6 * D]},
        "sph": {"kernel": "wendland_c2", "dx": dx, "support_factor": 3.0},
        "materials": {"water": water, "alumina": dict(ALUMINA, E=E)},
        "blocks": [sub, drop],
        "physics": {"modules": list(modules)},
        "time": {"t_end": t_end},
    }
    if "heat" in modules:
        scene["heat"] = {"laplacian": laplacian}
    if "fluid" in modules:
        scene["fluid"] = {"alpha": 0.02}
    if "coupling" in modules:
        cl = ["left", "right"] if dim == 2 else ["left", "right", "front", "back"]
        scene["coupling"] = {"material": "alumina", "blocks": ["substrate"], "clamps": cl,
                             "vtu_every": 0,
                             "mesh": {"lo": [-2 * half] * (dim - 1) + [-0.1e-3],
                                      "hi": [2 * half] * (dim - 1) + [0.0],
                                      "h_fine": 2 * dx, "h_coarse": 0.1e-3,
                                      "refine_radius": half,
                                      "cells": "tri" if dim == 2 else "tet"}}
    return scene


def ink_scene(quick: bool) -> dict:
    """The 50 m/s droplet (fluid + heat) as a Herschel-Bulkley ink: yield stress 1e4 Pa,
    index n = 0.3, k = 10 Pa s^0.3, cut-off at 1e3 1/s (largest viscosity 10 Pa s, 3e4 x
    the water's; sphfem.fluid.rheology)."""
    s = droplet_scene(quick, modules=("fluid", "heat"))
    s["fluid"].update(rheology="herschel-bulkley", tau0=1.0e4, n=0.3, k=10.0,
                      gamma_dot_0=1.0e3)
    return s


def tlsph_substrate_scene(quick: bool) -> dict:
    """:func:`droplet_scene` with the TL-SPH substrate backend (0.3 mm wide, 60 um deep
    box of solid particles relaxed quasi-statically every 60 SPH steps); full: 3D at
    dx = 10 um (the relaxation of a finer 3D box takes tens of minutes)."""
    d = droplet_scene(quick, dx=None if quick else 10.0e-6)
    dim = d["scene"]["dim"]
    c = d["coupling"]
    c.update(backend="tlsph", every_k_steps=60)
    c["mesh"] = {"lo": [-0.15e-3] * (dim - 1) + [-0.06e-3], "hi": [0.15e-3] * (dim - 1) + [0.0]}
    return d


def contrast_scene(quick: bool, *, ratio: float = 1.0e4, laplacian: str = "cleary",
                   implicit: bool = False, jitter: float = 0.0) -> dict:
    """Unit square (2D) or cube (3D, full) of two halves with conductivities 1 and 1/ratio
    (rho c = 1), held at 400 K on the left and 300 K on the right, insulated elsewhere;
    runs a quarter of the conductive half's diffusion time."""
    dim = 2 if quick else 3
    n = 32 if quick else 24
    dx = 1.0 / n
    lo, mid, hi = [0.0] * dim, [0.5] + [1.0] * (dim - 1), [1.0] * dim
    faces = [{"block": "a", "face": "xmin", "condition": "dirichlet", "temperature": 400.0},
             {"block": "b", "face": "xmax", "condition": "dirichlet", "temperature": 300.0}]
    heat = {"laplacian": laplacian, "boundaries": faces}
    if implicit:
        heat.update(time_integration="implicit", implicit_dt_factor=50.0)
    return {
        "scene": {"name": "contrast", "dim": dim, "seed": 1},
        "domain": {"lo": [-0.2] * dim, "hi": [1.2] * dim},
        "sph": {"kernel": "wendland_c2", "dx": dx, "support_factor": 3.0},
        "materials": {"hi_k": {"rho0": 1.0, "c": 1.0, "k": 1.0},
                      "lo_k": {"rho0": 1.0, "c": 1.0, "k": 1.0 / ratio}},
        "blocks": [{"name": "a", "shape": "box", "kind": "solid", "material": "hi_k",
                    "lo": lo, "hi": mid, "temperature": 300.0, "jitter": jitter},
                   {"name": "b", "shape": "box", "kind": "solid", "material": "lo_k",
                    "lo": [0.5] + [0.0] * (dim - 1), "hi": hi, "temperature": 300.0,
                    "jitter": jitter}],
        "physics": {"modules": ["heat"]},
        "heat": heat,
        "time": {"t_end": 0.25 * 0.25},
    }


def sheets_scene(quick: bool) -> dict:
    """Isolated particles and one-particle-thick sheets: a fluid sheet and a lone fluid
    particle falling under gravity, a solid sheet one particle thick and a lone solid
    particle conducting heat (corrected Laplacian), nothing touching anything."""
    dim = 2 if quick else 3
    dx = 1.0e-3

    def box(name, kind, mat, x0, y0, w, T):
        """A block one particle thick along the last axis, ``w`` wide along the others."""
        lo = [x0] * (dim - 1) + [y0]
        hi = [x0 + w] * (dim - 1) + [y0 + dx]
        return {"name": name, "shape": "box", "kind": kind, "material": mat, "lo": lo,
                "hi": hi, "temperature": T}

    return {
        "scene": {"name": "sheets", "dim": dim, "seed": 1},
        "domain": {"lo": [-0.02] * dim, "hi": [0.06] * dim},
        "sph": {"kernel": "wendland_c2", "dx": dx, "support_factor": 3.0},
        "materials": {"water": {"rho0": 1000.0, "c": 4000.0, "k": 0.6, "mu": 1.0e-3,
                                "c0": 10.0},
                      "steel": {"rho0": 7800.0, "c": 500.0, "k": 40.0}},
        "blocks": [box("fluid_sheet", "fluid", "water", 0.0, 0.04, 0.02, 350.0),
                   box("fluid_lone", "fluid", "water", 0.03, 0.04, dx, 350.0),
                   box("solid_sheet", "solid", "steel", 0.0, 0.01, 0.02, 300.0),
                   box("solid_lone", "solid", "steel", 0.03, 0.01, dx, 400.0)],
        "physics": {"modules": ["fluid", "heat"]},
        "fluid": {"gravity": [0.0] * (dim - 1) + [-9.81]},
        "heat": {"laplacian": "fatehi_manzari"},
        "time": {"t_end": 0.02},
    }


def rest_heat_scene(quick: bool) -> dict:
    """A hot droplet (80 K above the substrate) resting on it: heat only, explicit."""
    return droplet_scene(quick, speed=0.0, T_drop=373.15, modules=("heat",))


def rest_fluid_scene(quick: bool) -> dict:
    """The 50 m/s droplet impact without heat or coupling (fluid only)."""
    return droplet_scene(quick, modules=("fluid",), t_tc=0.5)


# --------------------------------------------------------------------------------------
# row checks: fn(outcome) -> (value, limit, op); value None when the figure is missing


def _heat(s: dict) -> dict:
    return s.get("diagnostics", {}).get("heat", {})


def _energy_balance(o: Outcome) -> tuple[float | None, float, str]:
    """|E - E0 - heat through the boundaries| / E of the heat ledger (Cleary form: 0 to
    round-off, whatever the step, so it also holds for a stopped run)."""
    r = _heat(o.summary).get("energy_balance_residual_rel")
    return (None if r is None else abs(r)), 1e-10, "<="


def _T_bounds(o: Outcome) -> tuple[float, float] | None:
    """The maximum-principle range: initial temperatures of the non-ghost particles and the
    temperatures held on Dirichlet faces (conduction cannot leave it)."""
    from sphfem.particles import GHOST

    T, kind = o.initial.get("T"), o.initial.get("kind")
    if T is None or kind is None or not np.any(kind != GHOST):
        return None
    held = [b["temperature"] for b in o.scene.get("heat", {}).get("boundaries", [])
            if b.get("condition") == "dirichlet"]
    T0 = T[kind != GHOST]
    return min([float(T0.min()), *held]), max([float(T0.max()), *held])


def _max_principle(slack: float = 1e-9) -> Check:
    """Largest excursion of a non-ghost temperature of the final state beyond the
    maximum-principle range, over the range's width, at most ``slack``."""

    def check(o: Outcome) -> tuple[float | None, float, str]:
        from sphfem.particles import GHOST

        b, T, kind = _T_bounds(o), o.final.get("T"), o.final.get("kind")
        if b is None or T is None or kind is None:
            return None, slack, "<="
        T = T[kind != GHOST]
        lo, hi = b
        if not np.isfinite(T).all():
            return math.inf, slack, "<="
        return max(lo - float(T.min()), float(T.max()) - hi, 0.0) / (hi - lo), slack, "<="

    return check


def _bound_margin(o: Outcome) -> float:
    """The heat guard's margin (``heat.bound_margin``, default 0.1) of the scene."""
    from sphfem.heat.params import HeatParams

    return float(o.scene.get("heat", {}).get("bound_margin", HeatParams.bound_margin))


def _within_guard_band(o: Outcome) -> tuple[float | None, float, str]:
    """:func:`_max_principle` with the heat guard's own margin as the limit: a state the
    guard accepted stays within it (fails when the guard fires late or not at all)."""
    value, _, op = _max_principle()(o)
    return value, _bound_margin(o), op


def _mechanical_energy(state: dict, gravity) -> tuple[float, float] | None:
    """(kinetic, potential) energy sum 1/2 m |v|^2 and -sum m g.x of the fluid particles."""
    from sphfem.particles import FLUID

    if any(state.get(k) is None for k in ("x", "v", "m", "kind")):
        return None
    f = state["kind"] == FLUID
    if not f.any():
        return None
    m, v, x = state["m"][f], state["v"][f], state["x"][f]
    g = np.zeros(x.shape[1]) if gravity is None else np.asarray(gravity, float)[: x.shape[1]]
    return 0.5 * float(np.sum(m * np.sum(v * v, axis=1))), -float(np.sum(m * (x @ g)))


def _energy_gain(tol: float = 1e-2) -> Check:
    """Gain of the fluid's kinetic plus potential energy from the first step to the final
    state, over the larger kinetic energy of the two: no source feeds it (static walls,
    p(rho0) = 0 at the start so the stored compression energy only grows, viscosity and
    the density diffusion dissipate), so a gain beyond the integrator's error ``tol``
    means the step pumps energy in."""

    def check(o: Outcome) -> tuple[float | None, float, str]:
        g = o.scene.get("fluid", {}).get("gravity")
        e0, e1 = _mechanical_energy(o.initial, g), _mechanical_energy(o.final, g)
        if e0 is None or e1 is None:
            return None, tol, "<="
        gain = sum(e1) - sum(e0)
        scale = max(e0[0], e1[0])
        if not math.isfinite(gain):
            return math.inf, tol, "<="
        return (gain / scale if scale > 0 else (0.0 if gain == 0 else math.inf)), tol, "<="

    return check


def _force_balance(o: Outcome) -> tuple[float | None, float, str]:
    """Largest |sum of the sensor forces - sum of the substrate's nodal loads| / |sum| over
    the coupling solves (missing: no solve happened, a failure)."""
    c = o.summary.get("diagnostics", {}).get("coupling", {})
    return c.get("force_residual_rel_max"), 1e-6, "<="


def _thermal_stress_scale(E: float, nu: float, alpha: float, dT: float) -> Check:
    """Peak von Mises over E alpha dT / (1 - nu), the stress of a fully restrained layer
    (plane biaxial); a sound linear solution stays within a small multiple of it."""

    def check(o: Outcome) -> tuple[float | None, float, str]:
        vm = o.summary.get("diagnostics", {}).get("coupling", {}).get("peak_von_mises_Pa")
        return (None if vm is None else vm / (E * alpha * dT / (1 - nu))), 2.0, "<="

    return check


def _dt_capped(o: Outcome) -> tuple[float | None, float, str]:
    """Largest step over the stable limit of a scene whose particles do not move (the limit
    is that of t = 0 throughout): the cap must keep it at 1."""
    dt_max = o.summary.get("dt", {}).get("max")
    if dt_max is None or o.stable_limit is None:
        return None, 1.0 + 1e-12, "<="
    return dt_max / o.stable_limit, 1.0 + 1e-12, "<="


def _growth_steps(dt_factor: float, margin: float = 0.1, eps: float = 1e-16) -> int:
    """Steps a mode needs to grow from round-off ``eps`` to ``margin`` (the guards' band)
    when amplified by g = 2 f - 1 per step: forward Euler's fastest mode at f times the
    limit, the slowest growth among the explicit schemes used here (Heun's is
    1 - 2f + 2f^2 >= 2f - 1).  A required stop must come by this step; from a
    discontinuous start the mode begins far above round-off, so the guard fires sooner."""
    return math.ceil(math.log(margin / eps) / math.log(2.0 * dt_factor - 1.0))


HEAT_GUARD = r"^heat stopped at step \d+.*temperature outside"
FLUID_GUARD = r"^fluid stopped at step \d+.*(density ratio|speed above)"
FLUID_CHECKS = {"fluid energy gain (dE / KE)": _energy_gain()}
HEAT_CHECKS = {"max principle (overshoot / range)": _max_principle()}
CLEARY_CHECKS = {**HEAT_CHECKS, "energy balance |rel|": _energy_balance}


ROWS: list[Row] = [
    Row("stiff-substrate-300GPa", "50 m/s water droplet (100 C) onto a 300 GPa substrate, "
        "fluid + heat + FEM coupling", lambda q: droplet_scene(q), STABLE,
        checks={**CLEARY_CHECKS, **FLUID_CHECKS, "sensor/FEM force balance": _force_balance}),
    Row("stiff-substrate-300GPa-tlsph", "the same onto a 300 GPa TL-SPH substrate "
        "(quasi-static relaxation)", tlsph_substrate_scene, STABLE,
        checks={**CLEARY_CHECKS, **FLUID_CHECKS,
                "sensor/solid force balance": _force_balance}),
    Row("impact-100mps", "100 m/s impact, c0 = 1000 m/s (10x the speed)",
        lambda q: droplet_scene(q, speed=100.0, modules=("fluid", "heat")), STABLE,
        checks={**CLEARY_CHECKS, **FLUID_CHECKS}),
    Row("impact-100mps-mach0.2", "100 m/s impact with c0 = 500 m/s (Mach 0.2: the density "
        "guard may stop it)", lambda q: droplet_scene(q, speed=100.0, c0=500.0,
                                                      modules=("fluid",)),
        EITHER, FLUID_GUARD, checks=FLUID_CHECKS),
    Row("thermal-shock-1000K", "droplet at 1293 K resting on a 293 K substrate: heat + FEM "
        "thermal stress", lambda q: droplet_scene(q, speed=0.0, T_drop=1293.15,
                                                  modules=("heat", "coupling")), STABLE,
        checks={**CLEARY_CHECKS,
                "peak von Mises / (E alpha dT/(1-nu))": _thermal_stress_scale(
                    300e9, 0.21, 8.1e-6, 1000.0)}),
    Row("contrast-1e4-cleary", "conductivity contrast 1e4, explicit, Cleary Laplacian",
        lambda q: contrast_scene(q), STABLE, checks=CLEARY_CHECKS),
    Row("contrast-1e4-corrected", "conductivity contrast 1e4, explicit, corrected Laplacian",
        lambda q: contrast_scene(q, laplacian="fatehi_manzari"), STABLE, checks=HEAT_CHECKS),
    Row("contrast-1e4-implicit", "conductivity contrast 1e4, backward Euler at 50x the "
        "explicit step", lambda q: contrast_scene(q, implicit=True), STABLE,
        checks=CLEARY_CHECKS),
    Row("viscosity-1000x", "50 m/s droplet with 1e3 x water's viscosity (0.3 Pa s)",
        lambda q: droplet_scene(q, mu_factor=1e3, modules=("fluid", "heat")), STABLE,
        checks={**CLEARY_CHECKS, **FLUID_CHECKS}),
    Row("ink-yield-1e4Pa-n0.3", "50 m/s droplet of a Herschel-Bulkley ink, tau0 = 1e4 Pa, "
        "n = 0.3 (explicit viscosity up to 10 Pa s)", ink_scene, EITHER, FLUID_GUARD,
        checks={**CLEARY_CHECKS, **FLUID_CHECKS}),
    Row("disordered-20pct", "50 m/s droplet, every particle moved randomly by up to 0.2 dx, "
        "corrected Laplacian", lambda q: droplet_scene(q, jitter=0.2, modules=("fluid", "heat"),
                                                       laplacian="fatehi_manzari"), STABLE,
        checks={**HEAT_CHECKS, **FLUID_CHECKS}),
    Row("disordered-20pct-heat", "conductivity contrast 1e4 on particles moved randomly by "
        "up to 0.2 dx, corrected Laplacian", lambda q: contrast_scene(
            q, laplacian="fatehi_manzari", jitter=0.2), STABLE, checks=HEAT_CHECKS),
    Row("isolated-and-sheets", "lone particles and one-particle-thick sheets (fluid falling, "
        "solid conducting with the corrected Laplacian)", sheets_scene, STABLE,
        checks={**HEAT_CHECKS, "energy balance |rel|": _energy_balance, **FLUID_CHECKS}),
    Row("heat-dt-0.9x", "explicit heat at a fixed dt of 0.9x the stable limit",
        rest_heat_scene, STABLE, checks=CLEARY_CHECKS, dt_factor=0.9, cap_dt=False),
    Row("heat-dt-2x-capped", "explicit heat asked for 2x the stable limit (the driver caps it)",
        rest_heat_scene, STABLE, checks={**CLEARY_CHECKS, "dt max / stable limit": _dt_capped},
        dt_factor=2.0, cap_dt=True),
    Row("heat-dt-2x", "explicit heat forced to 2x the stable limit (cap_dt = false; the "
        "checkerboard mode may not outgrow the guard's band before t_end)", rest_heat_scene,
        EITHER, HEAT_GUARD, checks={"energy balance |rel|": _energy_balance,
                                    "T within the guard band (overshoot / range)":
                                        _within_guard_band},
        dt_factor=2.0, cap_dt=False),
    Row("heat-dt-8x", "explicit heat forced to 8x the stable limit (cap_dt = false)",
        rest_heat_scene, STOPPED, HEAT_GUARD, _growth_steps(8.0),
        checks={"energy balance |rel|": _energy_balance,
                "T within the guard band (overshoot / range)": _within_guard_band},
        dt_factor=8.0, cap_dt=False),
    Row("fluid-dt-0.9x", "droplet impact at a fixed dt of 0.9x the initial stable limit "
        "(the limit shrinks during the impact: the guard may stop it)", rest_fluid_scene,
        EITHER, FLUID_GUARD, checks=FLUID_CHECKS, dt_factor=0.9, cap_dt=False),
    Row("fluid-dt-2x-capped", "droplet impact asked for 2x the stable limit (capped)",
        rest_fluid_scene, STABLE, checks=FLUID_CHECKS, dt_factor=2.0, cap_dt=True),
    Row("fluid-dt-2x", "droplet impact forced to 2x the stable limit (cap_dt = false)",
        rest_fluid_scene, EITHER, FLUID_GUARD, checks=FLUID_CHECKS, dt_factor=2.0,
        cap_dt=False),
    # the state the guard accepted last is checked for sanity, not accuracy: an unstable
    # step pumps energy in (2 % in the 4 steps before the density guard fires, quick), and
    # the guard must stop the run before the gain reaches a tenth of the kinetic energy
    Row("fluid-dt-8x", "droplet impact forced to 8x the stable limit (cap_dt = false)",
        rest_fluid_scene, STOPPED, FLUID_GUARD, _growth_steps(8.0),
        checks={"fluid energy gain before the stop (dE / KE)": _energy_gain(0.1)},
        dt_factor=8.0, cap_dt=False),
]


# --------------------------------------------------------------------------------------
# running


def _stable_limit(data: dict) -> tuple[float, str]:
    """The driver's stable dt at t = 0 for the scene ``data`` (no fixed dt)."""
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    d = copy.deepcopy(data)
    d["time"].pop("dt", None)
    d["physics"]["modules"] = [m for m in d["physics"]["modules"] if m != "coupling"]
    d.pop("coupling", None)
    sim = Simulation(parse_scene(d, source="<stability>"))
    return sim.stable_dt()


def _nonfinite_files(folder: Path) -> list[str]:
    """Written files holding NaN or Inf: VTU (points, point, cell and field data), CSV
    (every numeric cell), JSON (every number) and NPZ (every float array)."""
    bad = []
    for f in sorted(p for p in Path(folder).rglob("*") if p.is_file()):
        try:
            finite = _file_finite(f)
        except Exception as e:  # an unreadable result file is as bad as a NaN in it
            finite = False
            log.warning("stability: cannot read %s: %s", f, e)
        if finite is False:
            bad.append(str(f.relative_to(folder)))
    return bad


def _file_finite(f: Path) -> bool | None:
    """True/False for the formats :func:`_nonfinite_files` reads, None for others."""
    suffix = f.suffix.lower()
    if suffix == ".vtu":
        import meshio

        m = meshio.read(f)
        arrays = [m.points, *m.point_data.values(), *m.field_data.values()]
        arrays += [a for v in m.cell_data.values() for a in v]
        return all(_finite(a) for a in arrays)
    if suffix == ".csv":
        import csv

        with open(f, newline="") as fh:
            for row in csv.reader(fh):
                for cell in row:
                    try:
                        x = float(cell)
                    except ValueError:
                        continue
                    if not math.isfinite(x):
                        return False
        return True
    if suffix == ".json":
        return _json_finite(json.loads(f.read_text()))
    if suffix == ".npz":
        with np.load(f) as z:
            return all(_finite(z[k]) for k in z.files)
    return None


def _finite(a) -> bool:
    a = np.asarray(a)
    return a.dtype.kind not in "fc" or bool(np.isfinite(a).all())


def _json_finite(o) -> bool:
    if isinstance(o, float):
        return math.isfinite(o)
    if isinstance(o, dict):
        return all(_json_finite(v) for v in o.values())
    if isinstance(o, list):
        return all(_json_finite(v) for v in o)
    return True


class _Recorder:
    """Wraps ``sim.step``: keeps the state before the first step (after the modules' set-up,
    ghosts included) and the state before the latest step, so that the checks of a
    stopped run see the last state the guards accepted."""

    KEYS = ("x", "v", "m", "T", "kind")

    def __init__(self, sim):
        self.sim, self._step = sim, sim.step
        self.initial: dict = {}
        self.before: dict = {}
        sim.step = self

    def state(self) -> dict:
        f = self.sim.particles.fields
        return {k: np.array(f[k]) for k in self.KEYS if k in f}

    def __call__(self, dt: float) -> None:
        self.before = self.state()
        if not self.initial:
            self.initial = self.before
        self._step(dt)


def _evaluate(row: Row, o: Outcome) -> tuple[dict, list[str]]:
    """Every check of ``row`` on ``o``, with the common ones; returns (checks, failures)."""
    checks: dict[str, Check] = {"non-finite files written": lambda _: (
        float(len(_nonfinite_files(o.folder))), 0.0, "<=")}
    if o.stopped and row.expect in (STOPPED, EITHER):
        pattern = row.guard or r"(?!)"
        checks["stopped by the expected guard"] = lambda _: (
            1.0 if re.search(pattern, o.message) else 0.0, 1.0, ">=")
    if row.expect == STOPPED:
        checks["stop step"] = lambda _: (
            float(o.summary.get("steps", math.nan) + 1) if o.stopped else None,
            float(row.max_stop_step or 0), "<=")
    checks.update(row.checks)
    out, failures = {}, []
    for name, fn in checks.items():
        try:
            value, limit, op = fn(o)
        except Exception as e:  # a check that cannot be evaluated fails, with the reason
            value, limit, op = None, math.nan, "<="
            log.warning("stability: check %r of %s raised %s", name, row.name, e)
        ok = value is not None and not math.isnan(value) and (
            value <= limit if op == "<=" else value >= limit)
        out[name] = {"value": value, "limit": limit, "op": op, "passed": bool(ok)}
        if not ok:
            failures.append(f"{name}: {_g(value)} not {op} {_g(limit)}")
    return out, failures


def run_row(row: Row, quick: bool, folder: Path) -> RowResult:
    """Build and run ``row`` into ``folder``, then evaluate its checks (after a stop too);
    never raises."""
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation, SimulationStopped

    t0 = time.perf_counter()
    verdict, reason, summary, limit = STABLE, "", {}, None
    try:
        data = row.build(quick)
        data["scene"]["name"] = row.name
        if row.dt_factor is not None:
            limit, name = _stable_limit(data)
            data["time"]["dt"] = row.dt_factor * limit
            data["time"]["cap_dt"] = row.cap_dt
            reason = f"stable limit {limit:.3g} s ({name}); "
        sim = Simulation(parse_scene(data, source=f"<stability:{row.name}>"))
        rec = _Recorder(sim)
        try:
            summary = sim.run(folder, progress=False)
        except SimulationStopped as e:
            verdict, reason = STOPPED, reason + str(e)
            summary = json.loads((Path(folder) / "summary.json").read_text())
        outcome = Outcome(summary, Path(folder), verdict == STOPPED, summary.get("message", ""),
                          rec.initial, rec.before if verdict == STOPPED else rec.state(),
                          data, limit)
        checks, failures = _evaluate(row, outcome)
    except Exception as e:  # a crash is a failure of the row, reported, not raised
        msg = (str(e).strip().splitlines() or [""])[0]
        return RowResult(row.name, row.description, FAILED, f"{type(e).__name__}: {msg}", {},
                         {}, time.perf_counter() - t0)
    if verdict == STOPPED and row.expect == STABLE:
        failures.insert(0, "stopped, but this scene must run to its end")
    elif verdict == STABLE and row.expect == STOPPED:
        failures.insert(0, "ran to its end, but a guard must stop this scene")
    if failures:
        verdict, reason = FAILED, "; ".join(failures) + "; " + reason
    return RowResult(row.name, row.description, verdict, reason.strip("; "), figures(summary),
                     checks, time.perf_counter() - t0)


def figures(summary: dict) -> dict:
    """The matrix' figures from a run summary (None where a module is absent)."""
    d = summary.get("diagnostics", {})
    fl, ht, cp = d.get("fluid", {}), d.get("heat", {}), d.get("coupling", {})
    dt = summary.get("dt", {})
    lim = dt.get("controlling_limit_counts", {})
    return {
        "steps": summary.get("steps"),
        "t_s": summary.get("t"),
        "particles": summary.get("particles", {}).get("total"),
        "dt_min_s": dt.get("min_allowed"),
        "dt_limit": max(lim, key=lim.get) if lim else None,
        "steps_above_limit": dt.get("steps_above_stable_limit"),
        "max_speed_over_c0": fl.get("max_speed_over_c0"),
        "rho_ratio_range": fl.get("rho_ratio_range"),
        "fluid_fallbacks": fl.get("renormalisation_fallbacks"),
        "energy_residual_rel": ht.get("energy_balance_residual_rel"),
        "T_range_K": ht.get("T_range_K"),
        "heat_fallbacks": ht.get("fallbacks"),
        "peak_von_mises_Pa": cp.get("peak_von_mises_Pa"),
        "wall_s": summary.get("wall_s"),
    }


def run_matrix(quick: bool, out: Path | None = None, rows=None, progress=None
               ) -> list[RowResult]:
    """Run every row (or the named ``rows``) into ``out/<row>`` (a temporary folder when
    ``out`` is None); ``progress(result)`` is called after each row."""
    chosen = [r for r in ROWS if rows is None or r.name in rows]
    results = []
    with tempfile.TemporaryDirectory(prefix="sphfem-stability-") as tmp:
        base = Path(out) if out is not None else Path(tmp)
        for row in chosen:
            res = run_row(row, quick, base / row.name)
            results.append(res)
            if progress is not None:
                progress(res)
    return results


def _g(v, fmt=".3g") -> str:
    if v is None:
        return "-"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_g(x, fmt) for x in v) + "]"
    if isinstance(v, (int, np.integer, str)):
        return str(v)
    return format(v, fmt)


COLUMNS = (("verdict", None), ("checks passed", None), ("steps", "steps"), ("dt min s", "dt_min_s"),
           ("dt set by", "dt_limit"), ("above limit", "steps_above_limit"),
           ("max v/c0", "max_speed_over_c0"), ("rho/rho0", "rho_ratio_range"),
           ("energy residual", "energy_residual_rel"), ("T range K", "T_range_K"),
           ("fallbacks fluid/heat", None), ("peak vM Pa", "peak_von_mises_Pa"),
           ("wall s", "wall_s"))


def markdown(results: list[RowResult], quick: bool) -> str:
    """The matrix as Markdown: one table of figures, then each row's reason and checks."""
    lines = [f"# sphfem stability matrix ({'quick' if quick else 'full'})", "",
             f"Generated by `sphfem validate stability{' --quick' if quick else ''}` on "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.", ""]
    lines += table(results)
    lines += ["",
              "Columns: checks passed = the row's checks met / evaluated (each listed below the"
              " table); steps taken; dt min = the smallest step the limits allowed (before "
              "truncation to output times), and the limit that set the most steps; above limit "
              "= steps whose fixed dt exceeded the modules' smallest limit (`cap_dt = false`); "
              "max v/c0 and rho/rho0 = the fluid's state at the end (or at the stop); energy "
              "residual = (E - E0 - heat through the boundaries) / E of the heat ledger (0 to "
              "round-off for the conservative Cleary form; the corrected form is not "
              "conservative); T range at the end; fallbacks = fluid renormalisation / "
              "corrected-Laplacian rows that fell back to the plain operator (singular "
              "corrections); peak vM = the substrate's peak von Mises stress over the run; wall"
              " s = the run's stepping time.", ""]
    for r in results:
        lines.append(f"- **{r.name}** ({r.description}): {r.verdict}, {r.wall_s:.1f} s."
                     + (f" {r.reason}" if r.reason else ""))
        for k, c in r.checks.items():
            mark = "pass" if c["passed"] else "**FAIL**"
            lines.append(f"  - {mark} {k}: {_g(c['value'])} {c['op']} {_g(c['limit'])}")
    return "\n".join(lines) + "\n"


def table(results: list[RowResult]) -> list[str]:
    """The Markdown table of the matrix' figures, one line per row."""
    head = [c for c, _ in COLUMNS]
    lines = ["| row | " + " | ".join(head) + " |", "|---" * (len(head) + 1) + "|"]
    for r in results:
        f = r.figures
        cells = []
        for c, key in COLUMNS:
            if c == "verdict":
                cells.append(r.verdict if r.verdict != FAILED else "**FAILED**")
            elif c == "checks passed":
                cells.append(f"{sum(x['passed'] for x in r.checks.values())}/{len(r.checks)}")
            elif c.startswith("fallbacks"):
                cells.append(f"{_g(f.get('fluid_fallbacks'))}/{_g(f.get('heat_fallbacks'))}")
            else:
                cells.append(_g(f.get(key)))
        lines.append(f"| {r.name} | " + " | ".join(cells) + " |")
    return lines


def text_line(r: RowResult) -> str:
    """One console line per row."""
    f = r.figures
    s = (f"{r.name:<26} {r.verdict:<16} steps {_g(f.get('steps')):>6}  dt_min "
         f"{_g(f.get('dt_min_s'))} ({f.get('dt_limit') or '-'})  wall {r.wall_s:.1f} s")
    if r.reason and r.verdict != STABLE:
        s += f"\n    {r.reason[:300]}"
    return s


def to_json(results: list[RowResult], quick: bool) -> dict:
    return {"quick": quick, "passed": all(r.passed for r in results),
            "rows": [{**asdict(r), "passed": r.passed} for r in results]}
