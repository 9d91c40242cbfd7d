"""Maximum spreading over a range of We and Re: axisymmetric SPH against the correlations.

    python examples/droplet_impact/spreading_axisymmetric.py --out DIR
    python examples/droplet_impact/spreading_axisymmetric.py --out DIR --re 100,300 --we 30
    python examples/droplet_impact/spreading_axisymmetric.py --out DIR --refine --report FOLDER
    python examples/droplet_impact/spreading_axisymmetric.py --out DIR --we 30 --re 1000 \
        --n 61,87,123 --set fluid.film_tension=True --report FOLDER

A droplet (D = 0.1 mm, rho = 1000 kg/m^3, V = 10 m/s: the packaged axisymmetric scene of
:mod:`sphfem.validation.droplet_impact`, fluid only) hits the flat wall; each case sets the
liquid's viscosity and surface tension from (We, Re): mu = rho V D / Re, sigma = rho V^2 D /
We (c0 = 10 V, or the capillary bound where larger:
:func:`sphfem.validation.droplet_impact.sound_speed_for`; the scene's artificial
viscosity alpha and wall friction).  The spacing puts
three particles across the residual film of the spreading, h_res = 0.79 D Re^-0.4 (Roisman
2009; :func:`sphfem.fluid.spreading.residual_film`), the rule under which the droplet
study's figures settle (D/dx >= 3.8 Re^0.4: 24 at Re = 100, 61 at Re = 1000), and never
fewer than ``--min-n`` particles across the droplet; ``--refine`` adds a level sqrt(2)
finer per case; ``--n`` names the levels instead (a convergence study of one case), and
``--set section.key=value`` (repeatable) changes the scene as
:func:`sphfem.validation.droplet_impact.scene_at`'s overrides do (the runs' file names
then carry the tag ``--tag``, default one made of the overrides).  Each run goes to
``--t-end`` t_c (4: past the maximum spreading at these We) and reports D_max / D (the
contact diameter's maximum,
:meth:`sphfem.axisymmetric_scene.AxisymmetricFluidModule.contact_diameter`) beside the
correlations at the same (We, Re) and a 90 degree contact angle
(:func:`sphfem.fluid.spreading.correlation_table`: Pasandideh-Fard et al. 1996, Ukiwe &
Kwok 2005, Clanet et al. 2004, Roisman 2009, Laan et al. 2014).

One JSON per run (``DIR/We<We>_Re<Re>_n<n>.json``; an existing one is kept, so an
interrupted study resumes; a run cut off mid-way continues from its folder's last
checkpoint, its ``wall_s`` then that of the continuation only).  ``--report FOLDER``
writes ``results.json``, ``table.md``, ``spreading.png`` (D_max / D against Re, one
colour per We, the correlations' band shaded) and ``spread_history.png`` (the contact
diameter against time, one line per run).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

SPEED = 10.0  # m/s


def particles_across(Re: float, min_n: int, refine: bool = False) -> int:
    """D/dx putting MIN_FILM_PARTICLES (:mod:`sphfem.fluid.spreading`, the droplet study's
    rule) across h_res = 0.79 D Re^-0.4 (at least min_n), times sqrt(2) when ``refine``."""
    from sphfem.fluid.spreading import MIN_FILM_PARTICLES, residual_film

    n = max(min_n, math.ceil(MIN_FILM_PARTICLES / residual_film(1.0, Re)))
    return math.ceil(n * math.sqrt(2.0)) if refine else n


def scene_for(We: float, Re: float, n: int, t_end_tc: float, overrides=(),
              member: int = 0) -> dict:
    """The fluid-only axisymmetric droplet scene at (We, Re) with n particles across;
    ``overrides``: ``"section.key=value"`` strings applied last
    (:func:`sphfem.validation.droplet_impact.scene_at`); ``member`` k > 0: the droplet's
    rings jittered by up to :data:`~sphfem.validation.droplet_impact.ENSEMBLE_JITTER` dx
    with seed k (an ensemble member)."""
    from sphfem.validation import droplet_impact as di

    d = di.scene_at(SPEED, n, t_end_tc, member=member)
    drop = next(b for b in d["blocks"] if b["kind"] == "fluid")
    mat = d["materials"][drop["material"]]
    D, rho = 2.0 * drop["radius"], mat["rho0"]
    mat["mu"] = rho * SPEED * D / Re
    mat["sigma"] = rho * SPEED ** 2 * D / We
    mat["c0"] = di.sound_speed_for(SPEED, mat, d)  # the capillary bound at low We
    d["physics"]["modules"] = ["fluid"]
    for section in ("coupling", "heat"):
        d.pop(section, None)
    d["output"]["every"] = f"{t_end_tc / 4} tc"
    d["scene"]["name"] = f"spreading_We{We:g}_Re{Re:g}_n{n}"
    d["scene"]["description"] = f"fluid-only droplet impact at We = {We:g}, Re = {Re:g}"
    return di.apply_overrides(d, overrides)


def override_tag(overrides) -> str:
    """A file-name tag for the overrides ("" for none): ``fluid.film_tension=True`` ->
    ``film_tension-True``."""
    parts = []
    for kv in overrides:
        key, _, value = kv.partition("=")
        parts.append(key.split(".")[-1] + "-" + value)
    return "_".join("".join(c if c.isalnum() or c in "-._" else "-" for c in p)
                    for p in parts)


def _history(sp: dict, tc: float) -> dict:
    """The contact diameter's history (the run's samples, up to 200) from a summary's
    spreading record ``sp``: times in t_c = ``tc`` and D(t) / D."""
    return {"history_t_tc": [t / tc for t in sp.get("history_t_s", [])],
            "history_ratio": list(sp.get("history_ratio", []))}


def run_case(We: float, Re: float, n: int, t_end_tc: float, out: Path,
             refined: bool = False, overrides=(), tag: str | None = None,
             member: int = 0) -> dict:
    """One case's record (read back if its JSON exists); ``refined``: the sqrt(2) level;
    ``overrides``: scene changes (:func:`scene_for`), ``tag`` the file names' suffix
    (default :func:`override_tag`); ``member``: the ensemble member (:func:`scene_for`)."""
    from sphfem.api import run
    from sphfem.fluid.spreading import correlation_table
    from sphfem.scene import parse_scene

    tag = override_tag(overrides) if tag is None else tag
    path = out / (f"We{We:g}_Re{Re:g}_n{n}" + (f"_{tag}" if tag else "")
                  + (f"_m{member}" if member else "") + ".json")
    folder = out / path.stem
    if path.exists():
        rec = json.loads(path.read_text())
        summary = folder / "summary.json"
        if "history_ratio" not in rec and summary.exists():  # a record from before it was kept
            s = json.loads(summary.read_text())
            sp = s["diagnostics"]["fluid"]["spreading"]
            rec.update(_history(sp, s["t"] / rec["t_end_tc"]))
        return rec
    t0 = time.perf_counter()
    scene = parse_scene(scene_for(We, Re, n, t_end_tc, overrides, member),
                        source=path.stem)
    # a run cut off mid-way continues from its last checkpoint (one per frame)
    resumed = (folder / "checkpoint.npz").exists()
    run(scene, folder, overwrite=not resumed, resume=resumed)
    s = json.loads((folder / "summary.json").read_text())
    sp = s["diagnostics"]["fluid"]["spreading"]
    drop = next(b for b in scene.blocks if b.kind == "fluid")
    tc = 2.0 * drop.radius / SPEED
    band = correlation_table(We, Re, 90.0)
    rec = {"We": We, "Re": Re, "n": n, "refined": refined, "spread": sp["max_ratio"],
           "spread_t_tc": sp["max_t_s"] / tc, "t_end_tc": s["t"] / tc,
           # the wall row's measure (stray rings ahead of the rim count) and the mass
           # broken off the main body when the maximum is reached
           "spread_wall_row": sp.get("max_ratio_wall_row"),
           "detached_at_max": sp.get("detached_mass_fraction_at_max"),
           "max_reached": sp["max_t_s"] < 0.98 * s["t"],
           "film_particles": s["diagnostics"]["fluid"].get("residual_film", {}).get(
               "particles_across"),
           "correlations": band, "overrides": list(overrides), "tag": tag,
           "member": member, "resumed": resumed,
           **_history(sp, tc),
           # of this process only when resumed
           "wall_s": time.perf_counter() - t0}
    from sphfem.output import atomic_write_text

    atomic_write_text(path, json.dumps(rec, indent=2))
    return rec


def _fmt(x, spec: str) -> str:
    """``x`` formatted with ``spec``, "-" when missing (records of older runs)."""
    return "-" if x is None else format(x, spec)


def convergence_lines(groups: dict[tuple, list[float]]) -> list[str]:
    """Markdown lines: for each (We, Re) run at three or more spacings, the observed order,
    Richardson limit and GCI error bar of the mean D_max / D over each level's members
    (:func:`sphfem.validation.richardson.richardson`, the last three levels), and the
    finest level's distance from the limit, its error bar and its members' half-range added
    (the droplet-impact case's "converged" measure with the run-to-run scatter counted)."""
    from sphfem.validation.richardson import richardson

    cases: dict[tuple, list[tuple[int, list[float]]]] = {}
    for (We, Re, n), v in sorted(groups.items()):
        cases.setdefault((We, Re), []).append((n, v))
    out = []
    for (We, Re), lv in cases.items():
        if len(lv) < 3:
            continue
        if not out:
            out = ["", "Convergence of the ensemble means (Richardson over the last three "
                   "levels; the finest level's |mean - limit| + error bar + half its "
                   "members' range, relative to the limit):", "",
                   "| We | Re | D/dx | means | order | limit +- error bar | finest's distance |",
                   "|---|---|---|---|---|---|---|"]
        ns = [n for n, _ in lv]
        means = [sum(v) / len(v) for _, v in lv]
        est = richardson([1.0 / n for n in ns], means)
        fin = lv[-1][1]
        dist = (abs(est.finest - est.value) + est.error_bar
                + 0.5 * (max(fin) - min(fin))) / abs(est.value)
        order = f"{est.order:.2f}" if est.order is not None else "none"
        out.append(f"| {We:g} | {Re:g} | {', '.join(map(str, ns))} | "
                   f"{', '.join(f'{m:.3f}' for m in means)} | {order} | {est.value:.3f} +- "
                   f"{est.error_bar:.3f}{' (' + est.note + ')' if est.note else ''} | "
                   f"{dist:.1%} |")
    return out


def report(records: list[dict], folder: Path) -> None:
    """results.json, table.md and spreading.png in ``folder``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.fluid.spreading import correlation_table
    from sphfem.output import atomic_write_text

    folder.mkdir(parents=True, exist_ok=True)
    records = sorted(records, key=lambda r: (r["We"], r["Re"], r["n"], r.get("member", 0)))
    atomic_write_text(folder / "results.json", json.dumps(records, indent=2))
    groups: dict[tuple, list[float]] = {}
    for r in records:
        groups.setdefault((r["We"], r["Re"], r["n"]), []).append(r["spread"])
    names = list(records[0]["correlations"])
    lines = ["| We | Re | D/dx | run | film particles | D_max/D (t/t_c) | wall row | broken "
             "off | correlations min-max | outside the band | " + " | ".join(names)
             + " | wall s |", "|" + "---|" * (11 + len(names))]
    for r in records:
        lo, hi = min(r["correlations"].values()), max(r["correlations"].values())
        off = max(lo / r["spread"] - 1.0, r["spread"] / hi - 1.0, 0.0)
        when = f"{r['spread_t_tc']:.2f}" + ("" if r["max_reached"] else ", not reached")
        lines.append(
            f"| {r['We']:g} | {r['Re']:g} | {r['n']} | {r.get('member', 0)} | "
            f"{r['film_particles']:.1f} | {r['spread']:.2f} ({when}) | "
            f"{_fmt(r.get('spread_wall_row'), '.2f')} | "
            f"{_fmt(r.get('detached_at_max'), '.1%')} | "
            f"{lo:.2f}-{hi:.2f} | {off:.1%} | "
            + " | ".join(f"{r['correlations'][k]:.2f}" for k in names)
            + f" | {r['wall_s']:.0f} |")
    if any(len(v) > 1 for v in groups.values()):
        lines += ["", "Ensembles (the droplet jittered by 1e-3 dx, seeds 1..; the spread of "
                  "D_max/D over the members is the run-to-run uncertainty):", "",
                  "| We | Re | D/dx | runs | D_max/D mean | min-max | (max - min) / mean |",
                  "|---|---|---|---|---|---|---|"]
        for (We, Re, n), v in groups.items():
            m = sum(v) / len(v)
            lines.append(f"| {We:g} | {Re:g} | {n} | {len(v)} | {m:.3f} | {min(v):.3f}-"
                         f"{max(v):.3f} | {(max(v) - min(v)) / m:.1%} |")
    lines += convergence_lines(groups)
    atomic_write_text(folder / "table.md", "\n".join(lines) + "\n")
    cases = sorted({(r["We"], r["Re"]) for r in records})
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    wes = sorted({r["We"] for r in records})
    res = sorted({r["Re"] for r in records})
    Re_line = [res[0] * (res[-1] / res[0]) ** (k / 40) for k in range(41)] if len(res) > 1 \
        else [0.9 * res[0], 1.1 * res[0]]
    for i, We in enumerate(wes):
        c = f"C{i}"
        band = [correlation_table(We, Re, 90.0).values() for Re in Re_line]
        ax.fill_between(Re_line, [min(b) for b in band], [max(b) for b in band], color=c,
                        alpha=0.15, lw=0)
        for refine, marker in ((False, "o"), (True, "s")):
            pts = sorted((r["Re"], r["spread"]) for r in records if r["We"] == We
                         and r.get("refined", False) == refine)
            if pts:
                ax.plot(*zip(*pts, strict=True), marker, color=c, ls="-" if not refine
                        else ":", label=f"We {We:g}" + (" (sqrt 2 finer)" if refine else ""))
    ax.set_xscale("log")
    ax.set_xlabel("Re")
    ax.set_ylabel("D_max / D")
    ax.set_title("SPH (points) vs correlations (bands, 90 deg)", fontsize=10)
    ax.legend(fontsize=8)
    # each case against the resolution: members, ensemble means (``groups``), the band
    for i, (We, Re) in enumerate(cases):
        c = f"C{i}"
        lv = sorted((n, v) for (we, re_, n), v in groups.items() if (we, re_) == (We, Re))
        ax2.plot([n for n, v in lv for _ in v], [x for _, v in lv for x in v], "o",
                 color=c, ms=4, alpha=0.5)
        ax2.plot([n for n, _ in lv], [sum(v) / len(v) for _, v in lv], "-", color=c,
                 label=f"We {We:g}, Re {Re:g}: members, mean")
        b = correlation_table(We, Re, 90.0).values()
        ax2.axhspan(min(b), max(b), color=c, alpha=0.15, lw=0)
    ax2.set_xlabel("particles across D (D/dx)")
    ax2.set_ylabel("D_max / D")
    ax2.set_title("against the resolution (band: the correlations, 90 deg)", fontsize=10)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(folder / "spreading.png", dpi=120)
    plt.close(fig)
    history_plot(records, folder / "spread_history.png")


def history_plot(records: list[dict], path: Path) -> bool:
    """D(t) / D against t / t_c, one panel per (We, Re), one colour per level, one line per
    member (records without a history, from before it was kept, are left out); False when
    no record has one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.fluid.spreading import correlation_table

    recs = [r for r in records if r.get("history_ratio")]
    if not recs:
        return False
    cases = sorted({(r["We"], r["Re"]) for r in recs})
    fig, axs = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4.2), squeeze=False)
    for ax, (We, Re) in zip(axs[0], cases, strict=True):
        mine = [r for r in recs if (r["We"], r["Re"]) == (We, Re)]
        levels = sorted({r["n"] for r in mine})
        for r in sorted(mine, key=lambda r: (r["n"], r.get("member", 0))):
            k = levels.index(r["n"])
            first = r.get("member", 0) == min(q.get("member", 0) for q in mine
                                              if q["n"] == r["n"])
            ax.plot(r["history_t_tc"], r["history_ratio"], color=f"C{k}", lw=1.0,
                    alpha=0.8, label=f"D/dx {r['n']}" if first else None)
        b = correlation_table(We, Re, 90.0).values()
        ax.axhspan(min(b), max(b), color="0.5", alpha=0.2, lw=0,
                   label="correlations' D_max (90 deg)")
        ax.set_xlabel("t / t_c")
        ax.set_ylabel("contact diameter / D")
        ax.set_title(f"We {We:g}, Re {Re:g}: one line per run", fontsize=10)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, required=True, help="folder of the runs")
    p.add_argument("--we", default="30,100,300", help="Weber numbers (comma separated)")
    p.add_argument("--re", default="100,300,1000", help="Reynolds numbers (comma separated)")
    p.add_argument("--min-n", type=int, default=24, help="fewest particles across D")
    p.add_argument("--t-end", type=float, default=4.0, help="end time [t_c]")
    p.add_argument("--refine", action="store_true", help="also run sqrt(2) finer")
    p.add_argument("--n", help="particles across D, comma separated (instead of the rule)")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="scene change (repeatable), e.g. fluid.film_tension=True")
    p.add_argument("--tag", help="file-name suffix of these runs (default: from --set)")
    p.add_argument("--ensemble", type=int, default=1,
                   help="runs per level: the droplet jittered by 1e-3 dx with seeds 1.. "
                        "(the spread of D_max over them is the run-to-run uncertainty)")
    p.add_argument("--member", type=int, action="append", metavar="K",
                   help="run only ensemble member K of each level (repeatable; 0 the "
                        "unperturbed droplet): members in separate processes run in parallel")
    p.add_argument("--report", type=Path, help="write results.json, table.md, spreading.png")
    a = p.parse_args(argv)
    try:
        wes = [float(x) for x in a.we.split(",")]
        res = [float(x) for x in a.re.split(",")]
    except ValueError as e:
        p.error(f"--we / --re: {e}")
    if any(x <= 0 for x in wes + res):
        p.error("--we / --re: must be positive")
    try:
        ns = [int(x) for x in a.n.split(",")] if a.n else None
    except ValueError as e:
        p.error(f"--n: {e}")
    if ns is not None and any(n < 4 for n in ns):
        p.error("--n: at least 4 particles across the droplet")
    if a.ensemble < 1:
        p.error("--ensemble: at least 1")
    if a.member and min(a.member) < 0:
        p.error("--member: 0 or more")
    members = sorted(set(a.member)) if a.member else range(a.ensemble)
    bad = [kv for kv in a.set if "=" not in kv or "." not in kv.partition("=")[0]]
    if bad:
        p.error(f"--set: expected SECTION.KEY=VALUE, got {bad[0]!r}")
    a.out.mkdir(parents=True, exist_ok=True)
    records = []
    for Re in res:
        for We in wes:
            if ns is not None:
                levels = [(n, k > 0) for k, n in enumerate(ns)]
            else:
                levels = [(particles_across(Re, a.min_n, refine), refine)
                          for refine in ((False, True) if a.refine else (False,))]
            for n, refine in levels:
                for k in members:
                    r = run_case(We, Re, n, a.t_end, a.out, refine, a.set, a.tag, k)
                    print(f"We {We:g} Re {Re:g} D/dx {n}" + (f" member {k}" if k else "")
                          + f": D_max/D {r['spread']:.3f} at {r['spread_t_tc']:.2f} t_c "
                          f"(wall row {r.get('spread_wall_row') or math.nan:.3f}, broken "
                          f"off {r.get('detached_at_max') or math.nan:.1%}; "
                          f"{r['wall_s']:.0f} s)", flush=True)
                    records.append(r)
    if a.report:
        report(records, a.report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
