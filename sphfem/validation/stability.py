"""``sphfem validate stability``: stiff and extreme scenes run to their end, one verdict each.

Every row is a complete scene (built here as a dict, run by the ordinary driver into its own
folder) and ends in one of three verdicts:

* ``stable``: the run reached ``t_end`` with every state finite and its row checks met;
* ``stopped cleanly``: a guard stopped it with a reason (the message is reported), every
  file it wrote is finite, and stopping is acceptable for that row;
* ``FAILED``: a crash (an exception other than a guard's), non-finite numbers in any
  written file, a row check missed, or a stop where the row must run through.

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
import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

STABLE, STOPPED, FAILED = "stable", "stopped cleanly", "FAILED"


@dataclass
class Row:
    """One scene of the matrix: ``build(quick)`` returns the scene dict."""

    name: str
    description: str
    build: Callable[[bool], dict]
    #: verdicts that pass: (STABLE,) when the scene must run through, else (STABLE, STOPPED)
    allowed: tuple[str, ...] = (STABLE, STOPPED)
    #: extra checks on the summary: name -> fn(summary) -> (value, limit, op)
    checks: dict[str, Callable[[dict], tuple[float, float, str]]] = field(default_factory=dict)
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
    at dx = 6.25 um; runs ``t_tc`` contact times D / speed (at rest: 0.4 ms, some 200
    explicit thermal steps)."""
    dim = 2 if quick else 3
    dx = dx or (5.0e-6 if quick else 6.25e-6)
    D = 1.0e-4
    half = 0.2e-3
    water = dict(WATER, mu=WATER["mu"] * mu_factor, c0=c0 if c0 else max(10.0 * speed, 500.0))
    lat = [-half] * (dim - 1)
    t_end = t_tc * D / speed if speed > 0 else 4.0e-4  # at rest: ~200 thermal steps
    drop = {"name": "droplet", "shape": "sphere", "kind": "fluid", "material": "water",
            "center": [0.0] * (dim - 1) + [0.5 * D + dx], "radius": 0.5 * D,
            "velocity": [0.0] * (dim - 1) + [-speed], "temperature": T_drop,
            "sampling": "lattice" if jitter else "poisson", "jitter": jitter}
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
# row checks


def _heat(s: dict) -> dict:
    return s.get("diagnostics", {}).get("heat", {})


def _energy_balance(s: dict) -> tuple[float, float, str]:
    """|E - E0 - heat through the boundaries| / E of the heat ledger (Cleary form)."""
    return abs(_heat(s).get("energy_balance_residual_rel", math.nan)), 1e-10, "<="


def _max_principle(lo: float, hi: float, slack: float = 1e-9):
    """T stays inside the initial/wall range [lo, hi] (to ``slack`` of its width)."""

    def check(s: dict) -> tuple[float, float, str]:
        r = _heat(s).get("T_range_K", [math.nan, math.nan])
        over = max(lo - r[0], r[1] - hi) / (hi - lo)
        return over, slack, "<="

    return check


def _force_balance(s: dict) -> tuple[float, float, str]:
    c = s.get("diagnostics", {}).get("coupling", {})
    return c.get("force_residual_rel_max", math.nan) or 0.0, 1e-6, "<="


def _thermal_stress_scale(E: float, nu: float, alpha: float, dT: float):
    """Peak von Mises over E alpha dT / (1 - nu), the stress of a fully restrained layer
    (plane biaxial); a sound linear solution stays within a small multiple of it."""

    def check(s: dict) -> tuple[float, float, str]:
        vm = s.get("diagnostics", {}).get("coupling", {}).get("peak_von_mises_Pa")
        return (vm if vm is not None else math.nan) / (E * alpha * dT / (1 - nu)), 2.0, "<="

    return check


ROWS: list[Row] = [
    Row("stiff-substrate-300GPa", "50 m/s water droplet (100 C) onto a 300 GPa substrate, "
        "fluid + heat + FEM coupling", lambda q: droplet_scene(q), (STABLE,),
        {"energy balance |rel|": _energy_balance, "sensor/FEM force balance": _force_balance}),
    Row("stiff-substrate-300GPa-tlsph", "the same onto a 300 GPa TL-SPH substrate "
        "(quasi-static relaxation)", tlsph_substrate_scene, (STABLE,),
        {"energy balance |rel|": _energy_balance, "sensor/solid force balance": _force_balance}),
    Row("impact-100mps", "100 m/s impact, c0 = 1000 m/s (10x the speed)",
        lambda q: droplet_scene(q, speed=100.0, modules=("fluid", "heat")), (STABLE,),
        {"energy balance |rel|": _energy_balance}),
    Row("impact-100mps-mach0.2", "100 m/s impact with c0 = 500 m/s (Mach 0.2: the guard may "
        "stop it)", lambda q: droplet_scene(q, speed=100.0, c0=500.0, modules=("fluid",))),
    Row("thermal-shock-1000K", "droplet at 1293 K resting on a 293 K substrate: heat + FEM "
        "thermal stress", lambda q: droplet_scene(q, speed=0.0, T_drop=1293.15,
                                                  modules=("heat", "coupling")), (STABLE,),
        {"energy balance |rel|": _energy_balance,
         "max principle (overshoot / range)": _max_principle(293.15, 1293.15),
         "peak von Mises / (E alpha dT/(1-nu))": _thermal_stress_scale(300e9, 0.21, 8.1e-6,
                                                                       1000.0)}),
    Row("contrast-1e4-cleary", "conductivity contrast 1e4, explicit, Cleary Laplacian",
        lambda q: contrast_scene(q), (STABLE,),
        {"max principle (overshoot / range)": _max_principle(300.0, 400.0),
         "energy balance |rel|": _energy_balance}),
    Row("contrast-1e4-corrected", "conductivity contrast 1e4, explicit, corrected Laplacian",
        lambda q: contrast_scene(q, laplacian="fatehi_manzari"), (STABLE,)),
    Row("contrast-1e4-implicit", "conductivity contrast 1e4, backward Euler at 50x the "
        "explicit step", lambda q: contrast_scene(q, implicit=True), (STABLE,),
        {"max principle (overshoot / range)": _max_principle(300.0, 400.0),
         "energy balance |rel|": _energy_balance}),
    Row("viscosity-1000x", "50 m/s droplet with 1e3 x water's viscosity (0.3 Pa s)",
        lambda q: droplet_scene(q, mu_factor=1e3, modules=("fluid", "heat")), (STABLE,),
        {"energy balance |rel|": _energy_balance}),
    Row("disordered-20pct", "50 m/s droplet, every particle moved randomly by up to 0.2 dx, "
        "corrected Laplacian", lambda q: droplet_scene(q, jitter=0.2, modules=("fluid", "heat"),
                                                       laplacian="fatehi_manzari"), (STABLE,)),
    Row("disordered-20pct-heat", "conductivity contrast 1e4 on particles moved randomly by "
        "up to 0.2 dx, corrected Laplacian", lambda q: contrast_scene(
            q, laplacian="fatehi_manzari", jitter=0.2), (STABLE,)),
    Row("isolated-and-sheets", "lone particles and one-particle-thick sheets (fluid falling, "
        "solid conducting with the corrected Laplacian)", sheets_scene, (STABLE,),
        {"energy balance |rel|": _energy_balance}),
    Row("heat-dt-0.9x", "explicit heat at a fixed dt of 0.9x the stable limit",
        rest_heat_scene, (STABLE,),
        {"max principle (overshoot / range)": _max_principle(293.15, 373.15),
         "energy balance |rel|": _energy_balance},
        dt_factor=0.9, cap_dt=False),
    Row("heat-dt-2x-capped", "explicit heat asked for 2x the stable limit (the driver caps it)",
        rest_heat_scene, (STABLE,),
        {"max principle (overshoot / range)": _max_principle(293.15, 373.15)},
        dt_factor=2.0, cap_dt=True),
    Row("heat-dt-2x", "explicit heat forced to 2x the stable limit (cap_dt = false)",
        rest_heat_scene, dt_factor=2.0, cap_dt=False),
    Row("heat-dt-8x", "explicit heat forced to 8x the stable limit (cap_dt = false)",
        rest_heat_scene, dt_factor=8.0, cap_dt=False),
    Row("fluid-dt-0.9x", "droplet impact at a fixed dt of 0.9x the initial stable limit",
        rest_fluid_scene, dt_factor=0.9, cap_dt=False),
    Row("fluid-dt-2x-capped", "droplet impact asked for 2x the stable limit (capped)",
        rest_fluid_scene, (STABLE,), dt_factor=2.0, cap_dt=True),
    Row("fluid-dt-2x", "droplet impact forced to 2x the stable limit (cap_dt = false)",
        rest_fluid_scene, dt_factor=2.0, cap_dt=False),
    Row("fluid-dt-8x", "droplet impact forced to 8x the stable limit (cap_dt = false)",
        rest_fluid_scene, dt_factor=8.0, cap_dt=False),
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
    """Written VTU files holding NaN/Inf anywhere in their points or data."""
    import meshio

    bad = []
    for f in sorted(folder.rglob("*.vtu")):
        m = meshio.read(f)
        arrays = [m.points, *m.point_data.values()]
        arrays += [a for v in m.cell_data.values() for a in v]
        if not all(np.isfinite(np.asarray(a, float)).all() for a in arrays):
            bad.append(str(f.relative_to(folder)))
    return bad


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


def run_row(row: Row, quick: bool, folder: Path) -> RowResult:
    """Build and run ``row`` into ``folder``; never raises."""
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation, SimulationStopped

    t0 = time.perf_counter()
    verdict, reason, summary = STABLE, "", {}
    try:
        data = row.build(quick)
        data["scene"]["name"] = row.name
        if row.dt_factor is not None:
            limit, name = _stable_limit(data)
            data["time"]["dt"] = row.dt_factor * limit
            data["time"]["cap_dt"] = row.cap_dt
            reason = f"stable limit {limit:.3g} s ({name}); "
        sim = Simulation(parse_scene(data, source=f"<stability:{row.name}>"))
        try:
            summary = sim.run(folder, progress=False)
        except SimulationStopped as e:
            verdict, reason = STOPPED, reason + str(e)
            summary = json.loads((folder / "summary.json").read_text())
    except Exception as e:  # a crash is a failure of the row, reported, not raised
        msg = (str(e).strip().splitlines() or [""])[0]
        return RowResult(row.name, row.description, FAILED, f"{type(e).__name__}: {msg}", {},
                         {}, time.perf_counter() - t0)
    figs = figures(summary)
    checks = {}
    if verdict == STABLE:
        for name, fn in row.checks.items():
            value, limit, op = fn(summary)
            ok = value <= limit if op == "<=" else value >= limit
            checks[name] = {"value": value, "limit": limit, "op": op, "passed": bool(ok)}
    bad = _nonfinite_files(folder)
    if bad:
        verdict, reason = FAILED, f"non-finite values written to {', '.join(bad[:3])}; " + reason
    elif verdict not in row.allowed:
        verdict, reason = FAILED, "stopped, but this scene must run to its end: " + reason
    elif any(not c["passed"] for c in checks.values()):
        verdict = FAILED
        reason += "; ".join(f"{k}: {c['value']:.3g} not {c['op']} {c['limit']:.3g}"
                            for k, c in checks.items() if not c["passed"])
    return RowResult(row.name, row.description, verdict, reason.strip("; "), figs, checks,
                     time.perf_counter() - t0)


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


COLUMNS = (("verdict", None), ("steps", "steps"), ("dt min s", "dt_min_s"),
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
    lines += ["", "Columns: steps taken; dt min = the smallest step the limits allowed (before "
              "truncation to output times), and the limit that set the most steps; above limit "
              "= steps whose fixed dt exceeded the modules' smallest limit (`cap_dt = false`); "
              "max v/c0 and rho/rho0 = the fluid's state at the end (or at the stop); energy "
              "residual = (E - E0 - heat through the boundaries) / E of the heat ledger (0 to "
              "round-off for the conservative Cleary form; the corrected form is not "
              "conservative); T range at the end; fallbacks = fluid renormalisation / corrected-"
              "Laplacian rows that fell back to the plain operator (singular corrections); peak "
              "vM = the substrate's peak von Mises stress over the run; wall s = the run's "
              "stepping time.", ""]
    for r in results:
        lines.append(f"- **{r.name}** ({r.description}): {r.verdict}, {r.wall_s:.1f} s."
                     + (f" {r.reason}" if r.reason else ""))
        for k, c in r.checks.items():
            mark = "pass" if c["passed"] else "**FAIL**"
            lines.append(f"  - {mark} {k}: {c['value']:.3g} {c['op']} {c['limit']:.3g}")
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
