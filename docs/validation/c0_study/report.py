"""Tables and figures of the c0 study (README.md) from the runs' JSON in ``runs/``.

    python docs/validation/c0_study/report.py [--runs DIR] [--backfill]

prints the markdown tables (peaks per run; the quasi-static check; dynamic / quasi-static
with depth), puts them into README.md (for the committed ``runs/``) and writes
``peaks_vs_c0.png`` and ``dynamic_vs_quasi_static.png`` next to this file.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

HERE = Path(__file__).parent
RHO_F, V, R_DROP, D_DROP = 1000.0, 50.0, 0.05e-3, 0.1e-3
C_WATER = 1480.0
#: the axisymmetric scene's substrate (coupling.mesh): alumina, 0.26 mm thick, r <= 1 mm
E, NU, RHO_S, KAPPA_S = 300e9, 0.21, 3950.0, 10.0 / (3950.0 * 900.0)
THICKNESS, HALF_WIDTH = 0.26e-3, 1.0e-3


def load(runs: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(runs.glob("*.json"))]


def c0_of(run: dict) -> float:
    return run["c0_m_s"]


def peaks_table(runs: list[dict]) -> str:
    rows = ["| D/dx | c0 [m/s] | load | substrate | p_w peak [MPa] (t - t_1, r [um]) | "
            "rho c0 V [MPa] | p_w / rho c0 V | peak von Mises [MPa] (t - t_1 [ns], r, z [um]) "
            "| steps | wall s |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(runs, key=lambda r: (r["D_over_dx"], r["mech_only"] is False, c0_of(r),
                                         bool(r["dynamic"]))):
        pw = r["peak_wall_pressure"]
        t1 = first_load_time(r)
        loc = r["peak_von_mises_location_m"] or [math.nan, math.nan]
        sub = f"HHT {r['hht_alpha']:g}" if r["dynamic"] else "quasi-static"
        load = "mechanical" if r["mech_only"] else "mech + thermal"
        rows.append(
            f"| {r['D_over_dx']:.0f} | {c0_of(r):.0f} | {load} | {sub} | "
            f"{pw['p_Pa'] / 1e6:.1f} ({(pw['t_s'] - t1) * 1e9:.0f} ns, "
            f"{pw['r_m'] * 1e6:.1f}) | {r['rho_c0_V_Pa'] / 1e6:.0f} | "
            f"{pw['p_Pa'] / r['rho_c0_V_Pa']:.2f} | {r['peak_von_mises_Pa'] / 1e6:.1f} "
            f"({(r['peak_von_mises_t_s'] - t1) * 1e9:.0f}, {loc[0] * 1e6:.1f}, "
            f"{loc[1] * 1e6:.1f}) | {r['steps']} | {r['process_wall_s']:.0f} |")
    return "\n".join(rows)


def first_load_time(run: dict) -> float:
    """The first coupling time with a wall pressure above 1 % of rho c0 V on the axis
    column: the start of the impact on the wall (t_1)."""
    for t, p in run["axis_wall_pressure"]:
        if p > 0.01 * run["rho_c0_V_Pa"]:
            return t
    return math.nan


def check_table() -> str:
    from sphfem.fem.elastodynamic import quasi_static_check

    times = {f"water hammer R V / c0^2, c0 = {c:.0f}": R_DROP * V / c ** 2
             for c in (500.0, 1000.0, C_WATER)}
    for n in (16, 32, 64):  # the SPH load's rise: the lattice droplet meets the wall
        times[f"SPH contact rise dx / V, D/dx = {n}"] = D_DROP / n / V
    times["contact D / V"] = D_DROP / V
    q = quasi_static_check(E, NU, RHO_S, THICKNESS, HALF_WIDTH, times)
    s = q.speeds
    rows = [f"c_P = {s['P']:.0f}, c_S = {s['S']:.0f}, c_R = {s['R']:.0f} m/s; "
            f"h / c_P = {q.transit['h/c_P'] * 1e9:.1f} ns, h / c_S = "
            f"{q.transit['h/c_S'] * 1e9:.1f} ns, T_1 = 4 h / c_S = {q.period * 1e9:.0f} ns, "
            f"edge echo 2 x {HALF_WIDTH * 1e3:g} mm / c_R = "
            f"{2 * q.transit['half_width/c_R'] * 1e9:.0f} ns; thermoelastic time "
            f"kappa / c_P^2 = {KAPPA_S / s['P'] ** 2:.1e} s", "",
            "| load | time scale [ns] | envelope amplification | quasi-static within 10 %? |",
            "|---|---|---|---|"]
    for k, t in q.load_times.items():
        rows.append(f"| {k} | {t * 1e9:.3g} | {q.amplification[k]:.2f} | "
                    f"{'yes' if q.applies[k] else 'no'} |")
    return "\n".join(rows)


def depth_table(runs: list[dict]) -> str:
    """Largest von Mises over the run at the probes under the impact point: HHT against
    quasi-static, for each pair of runs differing only in the substrate."""
    pairs = []
    for d in runs:
        if not d["dynamic"] or "probe_max" not in d:
            continue
        q = [r for r in runs if not r["dynamic"] and r["D_over_dx"] == d["D_over_dx"]
             and r["c0"] == d["c0"] and r["mech_only"] == d["mech_only"] and "probe_max" in r]
        if q:
            pairs.append((q[0], d))
    if not pairs:
        return ""
    head = "| depth [um] | " + " | ".join(
        f"D/dx {q['D_over_dx']:.0f}, c0 {c0_of(q):.0f}, "
        f"{'mech' if q['mech_only'] else 'mech + th'}: qs / HHT [MPa] (ratio)"
        for q, _ in pairs) + " |"
    rows = [head, "|---" * (len(pairs) + 1) + "|"]
    for k, pt in enumerate(pairs[0][0]["probe_max"]):
        cells = []
        for q, d in pairs:
            a, b = q["probe_max"][k][2], d["probe_max"][k][2]
            cells.append(f"{a / 1e6:.3g} / {b / 1e6:.3g} ({b / a:.2f})")
        rows.append(f"| {-pt[1] * 1e6:.0f} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def backfill(runs: Path) -> None:
    """Add ``probe_max`` to run JSONs written before c0_study recorded it, from the run
    folders next to them."""
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location(
        "c0_study", HERE.parents[2] / "examples" / "droplet_impact" / "c0_study.py")
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    for p in sorted(runs.glob("*.json")):
        d = json.loads(p.read_text())
        if "probe_max" not in d and (runs / p.stem).is_dir():
            d["probe_max"] = mod.probe_maxima(runs / p.stem)
            p.write_text(json.dumps(d, indent=1))


def plots(runs: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    cs = [400.0, 1600.0]
    ax[0].plot(cs, [RHO_F * c * V / 1e6 for c in cs], "k--", lw=1, label=r"$\rho c_0 V$")
    ax[0].plot([C_WATER], [RHO_F * C_WATER * V * (1 + 2 * V / C_WATER) / 1e6], "k*", ms=10,
               label=r"Lesser & Field $\rho c V(1 + 2V/c)$, c = 1480")
    marks = {16: "o", 32: "s", 64: "^"}
    for D in sorted({round(r["D_over_dx"]) for r in runs}):
        for dyn in (False, True):
            sel = sorted([r for r in runs if round(r["D_over_dx"]) == D and r["mech_only"]
                          and bool(r["dynamic"]) == dyn], key=c0_of)
            if not sel:
                continue
            lab = f"D/dx = {D}" + (", dynamic" if dyn else "")
            if not dyn:
                ax[0].plot([c0_of(r) for r in sel],
                           [r["peak_wall_pressure"]["p_Pa"] / 1e6 for r in sel],
                           marker=marks.get(D, "x"), label=lab)
            ax[1].plot([c0_of(r) for r in sel], [r["peak_von_mises_Pa"] / 1e6 for r in sel],
                       marker=marks.get(D, "x"), ls="none" if dyn else "-", mfc="none" if dyn
                       else None, ms=10 if dyn else 6, label=lab)
        full = sorted([r for r in runs if round(r["D_over_dx"]) == D and not r["mech_only"]
                       and not r["dynamic"]], key=c0_of)
        if full:
            ax[1].plot([c0_of(r) for r in full], [r["peak_von_mises_Pa"] / 1e6 for r in full],
                       marker=marks.get(D, "x"), ls=":", label=f"D/dx = {D}, with thermal")
    ax[0].set(xlabel="c0 [m/s]", ylabel="peak wall pressure [MPa]", title="wall pressure")
    ax[1].set(xlabel="c0 [m/s]", ylabel="peak von Mises [MPa]",
              title="substrate (open: dynamic; dotted: with thermal)")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(HERE / "peaks_vs_c0.png", dpi=120)

    fig, ax = plt.subplots(1, 2, figsize=(10, 4), sharey=False)
    for i, mech in enumerate((True, False)):
        for r in sorted(runs, key=lambda r: (r["D_over_dx"], c0_of(r), bool(r["dynamic"]))):
            if r["mech_only"] != mech or (mech and c0_of(r) != C_WATER):
                continue
            t1 = first_load_time(r)
            t = [(p[0] - t1) * 1e9 for p in r["impact_point"]]
            vm = [p[1] / 1e6 for p in r["impact_point"]]
            lab = (f"D/dx = {r['D_over_dx']:.0f}, c0 = {c0_of(r):.0f}, "
                   + (f"HHT {r['hht_alpha']:g}" if r["dynamic"] else "quasi-static"))
            ax[i].plot(t, vm, ls="--" if r["dynamic"] else "-", label=lab)
        ax[i].set(xlabel="t - t_1 [ns]", ylabel="von Mises at the impact point [MPa]",
                  title=("mechanical load alone" if mech else "mechanical + thermal")
                  + (", c0 = 1480 m/s" if mech else ""))
        ax[i].grid(alpha=0.3)
        ax[i].legend(fontsize=7)
        ax[i].set_xlim(-20, None)
    fig.tight_layout()
    fig.savefig(HERE / "dynamic_vs_quasi_static.png", dpi=120)


def fill_readme(tables: dict) -> None:
    """Put each table between ``<!-- name -->`` and ``<!-- /name -->`` in README.md."""
    path = HERE / "README.md"
    text = path.read_text()
    for name, table in tables.items():
        head, tail = f"<!-- {name} -->", f"<!-- /{name} -->"
        i, j = text.index(head) + len(head), text.index(tail)
        text = text[:i] + "\n" + table + "\n" + text[j:]
    path.write_text(text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=Path, default=HERE / "runs")
    ap.add_argument("--backfill", action="store_true",
                    help="add probe maxima from the run folders to older run JSONs")
    a = ap.parse_args(argv)
    if a.backfill:
        backfill(a.runs)
    runs = load(a.runs)
    tables = {"peaks": peaks_table(runs), "check": check_table(), "depth": depth_table(runs)}
    print("\n\n".join(tables.values()))
    if a.runs == HERE / "runs":
        fill_readme(tables)
    plots(runs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
