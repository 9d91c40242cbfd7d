"""One impact speed of the ``droplet-impact`` validation, run level by level and resumable.

    python examples/droplet_impact/convergence.py SPEED --out DIR [--levels N N N ...]
                                                  [--members K] [--member M ...]
                                                  [--t-end-tc T] [--figures-from JSON ...]
                                                  [--prune] [--no-run]
                                                  [--override SECTION.KEY=VALUE ...]

Runs the validation's scene (:func:`sphfem.validation.droplet_impact.scene_at`) at SPEED
[m/s] and each level N (particles across the droplet; default: the case's own three,
:func:`~sphfem.validation.droplet_impact.levels_for`) into ``DIR/V{SPEED}_n{N}``.  A level
that has completed to the end time is read, not run again; one with a checkpoint continues
from it (the runs write one at every output, every 0.1 t_c here, and keep the last), so
the script can be stopped and started again at no loss, and a longer ``--t-end-tc``
continues completed levels.  Then it prints the case's criteria and notes for
this speed (:func:`~sphfem.validation.droplet_impact.speed_criteria`, from all the levels
given), and writes ``DIR/convergence_V{SPEED}.json`` and a figure ``.png``: the four
figures against dx with the Richardson limit and its error bar, and the spread against
the band of the published correlations.

``--members K`` runs an ensemble of K members per level (:func:`~sphfem.validation.
droplet_impact.scene_at`'s ``member``: member 0 the scene as it is, in ``V{SPEED}_n{N}``,
member k > 0 the droplet jittered by 1e-3 dx with seed k, in ``V{SPEED}_n{N}_m{k}``); the
criteria then take the level means and their sampling uncertainty
(:func:`~sphfem.validation.droplet_impact.ensemble`).  ``--member M`` (repeatable) runs only
those members, reading the others' completed folders: two processes with different members
share the two cores of a machine (``NUMBA_NUM_THREADS=1`` each); the criteria are printed
from the members completed so far, with their counts.  ``--no-run`` runs nothing and reads
what has completed (a look at the state of running ensembles).  ``--prune`` deletes a completed
run's particle and substrate VTU series (the checkpoint and ``summary.json`` stay; a D/dx
181 level writes ~10 GB).

``--override section.key=value`` (repeatable) sets a scene key in every run (a model
variant, e.g. ``fluid.contact_line=cox-voinov``); the overrides are recorded in the JSON,
not in the folder names, so each variant needs its own ``--out``.

``--figures-from`` takes the figures of levels run elsewhere (another machine, an earlier
session whose run folders are gone) from an earlier ``convergence_V{SPEED}.json``: a level
given with ``--levels`` that has no completed folder in DIR but whose figures are in such a
file (same speed, same end time) is read from it and not run; the printout marks it.

The full case (``sphfem validate droplet-impact``) runs the three speeds in one process;
this script is the way to run them one at a time, on several machines, or with a finer
level added: ``--levels 128`` alone runs (or continues) that level and prints its figures,
without the criteria, which need three levels; the figures go to
``convergence_V{SPEED}.json`` all the same (empty criteria), for a later ``--figures-from``.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def completed(folder: Path, speed: float, t_end_tc: float) -> dict | None:
    """The summary of the level in ``folder`` when it has completed to ``t_end_tc``."""
    done = folder / "summary.json"
    if not done.exists():
        return None
    s = json.loads(done.read_text())
    drop = next(b for b in s["scene"]["blocks"] if b["kind"] == "fluid")
    if (s.get("status") == "completed"
            and s["t"] >= 0.999 * t_end_tc * 2.0 * drop["radius"] / speed):
        return s
    return None


def earlier_figures(paths, speed: float, t_end_tc: float,
                    overrides=()) -> dict[tuple, tuple[dict, str]]:
    """(level, member) -> (figures, file) from earlier ``convergence_V*.json`` files of the
    same speed, end time and ``--override`` set (a later file wins; a file without
    ``member_figures`` holds member 0's); a file of another speed, end time or model variant
    is an error, except for overrides that change nothing at a file's level
    (:func:`~sphfem.validation.droplet_impact.inert_override`: a damping length below the
    level's h), so coarse levels run without such a floor join the finer ones run with it."""
    from sphfem.validation import droplet_impact as di

    out: dict[tuple, tuple[dict, str]] = {}
    for path in paths:
        d = json.loads(Path(path).read_text())
        if not math.isclose(float(d["speed"]), speed):
            raise SystemExit(f"--figures-from {path}: speed {d['speed']} m/s, not {speed:g}")
        theirs = list(d.get("overrides") or [])
        differ = sorted(set(theirs) ^ set(overrides))
        same = [n for n in d["levels"] if all(
            di.inert_override(kv, di.scene_at(speed, int(n), t_end_tc)) for kv in differ)]
        if not same:
            raise SystemExit(f"--figures-from {path}: run with --override "
                             f"{theirs}, not {list(overrides)}")
        if len(same) < len(d["levels"]):
            print(f"--figures-from {path}: only D/dx {same} (run with --override {theirs}, "
                  f"which differs from {list(overrides)} at its other levels)")
        per_level = d.get("member_figures") or [{"0": f} for f in d["figures"]]
        for n, members in zip(d["levels"], per_level, strict=True):
            if n not in same:
                continue
            for m, f in members.items():
                t_tc = f["t_end"] / f["tc"]
                if abs(t_tc - t_end_tc) > 1e-6 * t_end_tc:
                    raise SystemExit(f"--figures-from {path}: D/dx {n} ended at {t_tc:.4g} "
                                     f"t_c, not {t_end_tc:g}")
                out[int(n), int(m)] = (f, str(path))
    return out


def member_folder(out: Path, speed: float, n: int, member: int) -> Path:
    """The run folder of ``member`` of level ``n`` (module docstring)."""
    return out / (f"V{speed:g}_n{n}" + (f"_m{member}" if member else ""))


def prune(folder: Path) -> int:
    """Delete the VTU series of a completed run in ``folder``; returns the bytes freed."""
    freed = 0
    for f in [*folder.glob("*.vtu"), *folder.glob("*.pvd"), *folder.glob("*/*.vtu"),
              *folder.glob("*/*.pvd")]:
        freed += f.stat().st_size
        f.unlink()
    return freed


def run_level(speed: float, n: int, t_end_tc: float, folder: Path, member: int = 0,
              overrides=()) -> dict:
    """The summary of one level's ensemble ``member``, run (or continued) when it has not
    completed."""
    from sphfem.api import run
    from sphfem.scene import parse_scene
    from sphfem.validation import droplet_impact as di

    s = completed(folder, speed, t_end_tc)
    if s is not None:
        return s
    d = di.scene_at(speed, n, t_end_tc, member=member, overrides=overrides)
    scene = parse_scene(d, source=f"convergence V={speed:g} D/dx={n} member {member}")
    resume = (folder / "checkpoint.npz").exists()
    # the checkpoint is kept, so a later, longer --t-end-tc continues the level
    run(scene, folder, resume=resume, overwrite=not resume, keep_checkpoint=True)
    return json.loads((folder / "summary.json").read_text())


def plot(path: Path, speed: float, levels, figs: list[dict]) -> None:
    """The four figures against dx (with their Richardson limits) and the spread band;
    with ensembles (``figs`` from :func:`~sphfem.validation.droplet_impact.ensemble`) the
    members as dots and the means with their 95 % sampling interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.validation import droplet_impact as di
    from sphfem.validation.droplet_impact import FIGURES
    D = figs[-1]["tc"] * speed
    h = [D / n * 1e6 for n in levels]
    scale = {"spread": 1.0, "heat": 1e6, "T_impact": 1.0, "vm_peak": 1e-6}
    unit = {"spread": "D_max/D", "heat": "heat [uJ]", "T_impact": "rise [K]",
            "vm_peak": "peak von Mises [MPa]"}
    fig, axs = plt.subplots(1, 4, figsize=(16, 3.6))
    for ax, key in zip(axs, FIGURES, strict=True):
        y = [f[key] * scale[key] for f in figs]
        se, t95, dof = di.ensemble_uncertainty(figs, key)
        if dof:
            for hi, f in zip(h, figs, strict=True):
                ax.plot([hi] * f["members"], [v * scale[key] for v in f[f"{key}_members"]],
                        ".", color="0.5", ms=4)
            ax.errorbar(h, y, yerr=[t95 * e * scale[key] for e in se], fmt="o-", capsize=3,
                        label="SPH-FEM ensemble means (95 %)")
        else:
            ax.plot(h, y, "o-", label="SPH-FEM")
        if len(levels) >= 3:
            est, u, _, _ = di.figure_estimate([D / n for n in levels], figs, key)
            v, bar, u = (x * scale[key] for x in (est.value, est.error_bar, u))
            ax.axhline(v, color="k", lw=0.8, label="Richardson limit")
            ax.axhspan(v - bar, v + bar, color="k", alpha=0.15, label="error bar (GCI)")
            if u:
                ax.axhspan(v - bar - u, v + bar + u, color="k", alpha=0.06,
                           label="+ sampling (95 %)")
        if key == "spread":
            lo, hi = figs[-1]["correlations"]
            ax.axhspan(lo, hi, color="tab:green", alpha=0.25, label="correlations")
        ax.set_xlabel("dx [um]")
        ax.set_ylabel(unit[key])
        ax.set_xlim(0.0, max(h) * 1.1)
        ax.legend(fontsize=7)
    fig.suptitle(f"droplet impact at {speed:g} m/s: D/dx = {list(levels)}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def members_table(levels, figs: list[dict], member_ids) -> str:
    """A markdown table of each level's members (``member_ids``) and their mean and sample sd
    (``figs``: each level's :func:`~sphfem.validation.droplet_impact.ensemble`; the four
    figures in D_max/D, uJ, K and MPa)."""
    scale = {"spread": (1.0, "{:.3f}"), "heat": (1e6, "{:.1f}"), "T_impact": (1.0, "{:.2f}"),
             "vm_peak": (1e-6, "{:.2f}")}
    rows = ["| D/dx | members | D_max/D | heat [uJ] | rise [K] | peak vM [MPa] |",
            "|---|---|---|---|---|---|"]
    for n, f, ids in zip(levels, figs, member_ids, strict=True):
        cells = []
        for key, (k, fmt) in scale.items():
            cell = " / ".join(fmt.format(x * k) for x in f[f"{key}_members"])
            if f["members"] > 1:
                cell += f": mean {fmt.format(f[key] * k)}, sd {fmt.format(f[key + '_sd'] * k)}"
            cells.append(cell)
        rows.append(f"| {n} | {', '.join(map(str, ids))} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("speed", type=float, help="impact speed [m/s]")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--levels", type=int, nargs="+", default=None,
                    help="particles across the droplet, coarse to fine (default: the case's)")
    ap.add_argument("--members", type=int, default=1,
                    help="ensemble members per level (default 1: the scene as it is)")
    ap.add_argument("--member", type=int, action="append", default=[],
                    help="run only this member (repeatable); the others are read")
    ap.add_argument("--t-end-tc", type=float, default=None,
                    help="end time in t_c (default: the case's, di.t_end_for)")
    ap.add_argument("--figures-from", type=Path, nargs="+", default=[],
                    help="earlier convergence_V*.json files: members without a completed "
                         "folder in --out take their figures from these")
    ap.add_argument("--no-run", action="store_true",
                    help="run nothing: read the completed members (and --figures-from) only")
    ap.add_argument("--prune", action="store_true",
                    help="delete a completed run's VTU series (summary and checkpoint stay)")
    ap.add_argument("--override", action="append", default=[], metavar="SECTION.KEY=VALUE",
                    help="a scene key for every run (repeatable; di.apply_overrides), e.g. "
                         "fluid.contact_line=cox-voinov; use a separate --out per set")
    a = ap.parse_args(argv)

    from sphfem.output import write_json
    from sphfem.validation import droplet_impact as di

    if a.speed <= 0:
        ap.error(f"the speed must be > 0, got {a.speed}")
    levels = sorted(a.levels) if a.levels else list(di.levels_for(a.speed))
    if levels[0] <= 0:
        ap.error(f"--levels must be positive, got {levels}")
    if a.members < 1:
        ap.error(f"--members must be >= 1, got {a.members}")
    if any(not 0 <= m < a.members for m in a.member):
        ap.error(f"--member must lie in [0, {a.members}) (--members {a.members}), "
                 f"got {a.member}")
    t_end = a.t_end_tc or di.t_end_for(a.speed)
    from sphfem.errors import SceneError
    from sphfem.scene import parse_scene

    try:  # a bad override is refused before anything runs
        parse_scene(di.scene_at(a.speed, levels[0], t_end, overrides=a.override),
                    source="convergence.py --override")
    except (SceneError, ValueError, KeyError, IndexError) as e:
        ap.error(f"--override: {e}")
    a.out.mkdir(parents=True, exist_ok=True)
    earlier = earlier_figures(a.figures_from, a.speed, t_end, a.override)
    figs, member_figs = [], []
    for n in levels:
        got: dict[int, dict] = {}
        for m in range(a.members):
            folder = member_folder(a.out, a.speed, n, m)
            s = completed(folder, a.speed, t_end)
            if s is None and (n, m) in earlier:
                f, origin = earlier[n, m]
                print(f"D/dx {n} member {m}: figures from {origin}")
            elif s is None and (a.no_run or (a.member and m not in a.member)):
                continue  # not to be run here (another process's member, or --no-run)
            else:
                s = s or run_level(a.speed, n, t_end, folder, m, a.override)
                f = di.figures(s, a.speed, 2.0 * next(
                    b for b in s["scene"]["blocks"] if b["kind"] == "fluid")["radius"])
                if a.prune:
                    freed = prune(folder)
                    if freed:
                        print(f"D/dx {n} member {m}: pruned {freed / 1e9:.2f} GB of VTU")
            got[m] = f
            print(f"D/dx {n} member {m}: spread {f['spread']:.3f} heat {f['heat'] * 1e6:.2f} "
                  f"uJ rise {f['T_impact']:.2f} K vM {f['vm_peak'] / 1e6:.2f} MPa "
                  f"({f['wall_s']:.0f} s)", flush=True)
        member_figs.append(got)
        if got:
            figs.append(di.ensemble([got[m] for m in sorted(got)]))

    def clean(v):
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            v = float(v)
            return v if math.isfinite(v) else None
        return v

    def cleaned(f):
        return {k: clean(v) for k, v in f.items()}

    def save(crit: dict, notes: list) -> None:
        """convergence_V{speed}.json: the completed levels' figures (read back by
        ``--figures-from``) and the criteria (empty below three levels)."""
        done = [(n, g) for n, g in zip(levels, member_figs, strict=True) if g]
        write_json(a.out / f"convergence_V{a.speed:g}.json", {
            "speed": a.speed, "levels": [n for n, _ in done], "members": a.members,
            "overrides": a.override, "figures": [cleaned(f) for f in figs],
            "member_figures": [{str(m): cleaned(f) for m, f in g.items()} for _, g in done],
            "criteria": {k: {"value": clean(float(c.value)), "limit": c.limit, "op": c.op,
                             "passed": bool(c.passed), "description": c.description}
                         for k, c in crit.items()},
            "notes": notes})

    if len(levels) < 3 or len(figs) < len(levels):
        if figs:  # the figures so far, for --figures-from (the run folders may go)
            save({}, [])
        print(f"{len(figs)} of {len(levels)} level(s) with a completed member: the criteria "
              "need three (run again when they have completed; completed folders are read)")
        return 0
    counts = [len(g) for g in member_figs]
    if any(c < a.members for c in counts):
        print(f"members completed per level {counts} of {a.members}: the criteria below are "
              "from those")
    print(members_table(levels, figs, [sorted(g) for g in member_figs]))
    crit, notes = di.speed_criteria(a.speed, levels, figs)
    for name, c in crit.items():
        print(f"[{'PASS' if c.passed else 'FAIL'}] {name}: {c.value:.4g} {c.op} {c.limit:g}")
    for x in notes:
        print("note:", x)

    save(crit, notes)
    plot(a.out / f"convergence_V{a.speed:g}.png", a.speed, levels, figs)
    return 0 if all(c.passed for c in crit.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
