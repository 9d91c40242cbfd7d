"""The axisymmetric droplet job (droplet_impact_axisymmetric.toml) at several spacings.

For each dx the scene is scaled as its header says: the droplet's gap and the wall's
thickness 3 dx, the stress mesh's h_fine = dx, the heat mesh's lateral cells dx / 2.  Each
run writes its own folder (``<out>/dx_<um>um``); the figures of every run go to
``<out>/figures.json`` (names as in summary.json) and a table to stdout.

    python examples/droplet_impact/axisymmetric_resolutions.py --out DIR \
        [--dx 6.25e-6 3.125e-6 1.5625e-6] [--t-end "4 tc"]
    python examples/droplet_impact/axisymmetric_resolutions.py --out DIR --table-only
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import time
import tomllib
from pathlib import Path

SCENE = Path(__file__).with_name("droplet_impact_axisymmetric.toml")


def scaled_scene(dx: float, t_end: str) -> dict:
    """The example scene's dict with everything tied to the spacing set from ``dx``."""
    data = copy.deepcopy(tomllib.loads(SCENE.read_text()))
    data["sph"]["dx"] = dx
    blocks = {b["name"]: b for b in data["blocks"]}
    blocks["substrate"]["lo"][1] = -3.0 * dx
    blocks["droplet"]["gap"] = 3.0 * dx
    data["coupling"]["heat"]["h_lateral"] = dx / 2
    data["coupling"]["mesh"]["h_fine"] = dx
    data["time"]["t_end"] = t_end
    data["scene"]["name"] = f"droplet_impact_axisymmetric_dx{dx * 1e6:g}um"
    return data


def figures(summary: dict, folder: Path | None = None) -> dict:
    """The run's figures under their summary.json names (None where absent), and the peak
    von Mises and spreading before ``t_wall_breach_s`` (a fluid ring in the second wall
    layer; the stress after it is not the droplet's), from ``folder``'s substrate history."""
    d = summary["diagnostics"]
    c = d.get("coupling", {})
    h = c.get("substrate_heat", {})
    f = d.get("fluid", {})
    sp = f.get("spreading", {})
    hist = h.get("history", [])
    tc = 1e-4 / 50.0

    def heat_at(t):  # heat into the substrate at time t (the last exchange before it)
        rows = [r for r in hist if r["t"] <= t * (1 + 1e-9)]
        return rows[-1]["heat_to_substrate_J"] if rows and hist[-1]["t"] >= t else None

    return {
        "dx_m": summary["scene"]["sph"]["dx"], "status": summary["status"],
        "message": summary["message"], "t_reached_s": summary["t"],
        "particles": summary["particles"]["total"], "steps": summary["steps"],
        "setup_s": summary["setup_s"], "wall_s": summary["wall_s"],
        "peak_rss_mb": summary["peak_rss_mb"],
        "wall_s_per_module": summary["wall_s_per_module"],
        "t_contact_s": c.get("t_contact_s"),
        "peak_von_mises_Pa": c.get("peak_von_mises_Pa"),
        "peak_von_mises_t_s": c.get("peak_von_mises_t_s"),
        "peak_von_mises_location_m": c.get("peak_von_mises_location_m"),
        "T_impact_max_K": h.get("T_impact_max_K"), "T_impact_max_t_s": h.get("T_impact_max_t_s"),
        "ideal_contact_temperature_K": h.get("ideal_contact_temperature_K"),
        "T_impact_history": [[r["t"], r["T_impact"]] for r in hist],
        "heat_to_substrate_J": h.get("heat_to_substrate_J"),
        "heat_to_substrate_at_1tc_J": heat_at(tc), "heat_to_substrate_at_2tc_J": heat_at(2 * tc),
        "ideal_contact_heat_J": h.get("ideal_contact_heat_J"),
        "fluid_substrate_residual_rel": h.get("fluid_substrate_residual_rel"),
        "spread_max_ratio": sp.get("max_ratio"), "spread_max_t_s": sp.get("max_t_s"),
        "axial_momentum_residual_rel": f.get("axial_momentum_residual_rel"),
        "max_ring_depth_below_wall_top_dx": f.get("max_ring_depth_below_wall_top_dx"),
        "t_wall_breach_s": f.get("t_wall_breach_s"),
        **before_breach(summary, folder),
    }


def before_breach(summary: dict, folder: Path | None) -> dict:
    f = summary["diagnostics"].get("fluid", {})
    tb = f.get("t_wall_breach_s")
    tb = math.inf if tb is None else tb
    out = {}
    hist_path = None if folder is None else folder / "substrate" / "history.json"
    if hist_path is not None and hist_path.exists():
        rows = [r for r in json.loads(hist_path.read_text())["history"] if r["t"] < tb]
        if rows:
            r = max(rows, key=lambda r: r["peak_von_mises"])
            out.update(peak_von_mises_before_breach_Pa=r["peak_von_mises"],
                       peak_von_mises_before_breach_t_s=r["t"],
                       peak_von_mises_before_breach_location_m=r["peak_location"])
    sp = f.get("spreading", {})
    if sp:
        pairs = [(t, b) for t, b in zip(sp["history_t_s"], sp["history_ratio"], strict=True)
                 if t < tb]
        if pairs:
            t, b = max(pairs, key=lambda p: p[1])
            out.update(spread_max_ratio_before_breach=b, spread_max_before_breach_t_s=t)
    return out


def run_one(dx: float, t_end: str, out: Path) -> dict:
    from sphfem.errors import SimulationStopped
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    folder = out / f"dx_{dx * 1e6:g}um"
    t0 = time.perf_counter()
    sim = Simulation(parse_scene(scaled_scene(dx, t_end), source=str(SCENE)))
    try:
        sim.run(folder, progress=False)
    except SimulationStopped:
        pass  # summary.json holds the figures up to the stop
    fig = figures(json.loads((folder / "summary.json").read_text()), folder)
    fig["process_wall_s"] = time.perf_counter() - t0
    return fig


def table(figs: list[dict]) -> str:
    tc = 2e-6
    rows = ["dx um | status (t/tc) | steps | wall s | vM MPa (t/tc, r um, z um) | T_imp max C "
            "(t/tc) | Q 1tc / 2tc / end uJ (ideal end) | spread max (t/tc) | breach t/tc | "
            "vM before breach MPa (t/tc)"]
    for f in figs:
        loc = f["peak_von_mises_location_m"] or [math.nan, math.nan]
        g = lambda v, s=1.0: math.nan if v is None else v * s  # noqa: E731
        rows.append(
            f"{f['dx_m'] * 1e6:g} | {f['status']} ({f['t_reached_s'] / tc:.2f}) | {f['steps']} | "
            f"{f['wall_s']:.0f} | {g(f['peak_von_mises_Pa'], 1e-6):.3g} "
            f"({g(f['peak_von_mises_t_s'], 1 / tc):.2f}, {loc[0] * 1e6:.3g}, {loc[1] * 1e6:.3g}) | "
            f"{g(f['T_impact_max_K']) - 273.15:.1f} ({g(f['T_impact_max_t_s'], 1 / tc):.2f}) | "
            f"{g(f['heat_to_substrate_at_1tc_J'], 1e6):.3g} / "
            f"{g(f['heat_to_substrate_at_2tc_J'], 1e6):.3g} / "
            f"{g(f['heat_to_substrate_J'], 1e6):.3g} ({g(f['ideal_contact_heat_J'], 1e6):.3g}) | "
            f"{g(f['spread_max_ratio']):.3g} ({g(f['spread_max_t_s'], 1 / tc):.2f}) | "
            f"{g(f['t_wall_breach_s'], 1 / tc):.2f} | "
            f"{g(f.get('peak_von_mises_before_breach_Pa'), 1e-6):.3g} "
            f"({g(f.get('peak_von_mises_before_breach_t_s'), 1 / tc):.2f})")
    return "\n".join(rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--dx", type=float, nargs="+", default=[6.25e-6, 3.125e-6, 1.5625e-6])
    ap.add_argument("--t-end", default="4 tc")
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "figures.json"
    figs = json.loads(path.read_text()) if path.exists() else []
    if not a.table_only:
        for dx in a.dx:
            figs = [f for f in figs if f["dx_m"] != dx] + [run_one(dx, a.t_end, out)]
            figs.sort(key=lambda f: -f["dx_m"])
            path.write_text(json.dumps(figs, indent=1))
            print(table(figs), flush=True)
    print(table(figs))


if __name__ == "__main__":
    main()
