"""One impact speed of the ``droplet-impact`` validation, run level by level and resumable.

    python examples/droplet_impact/convergence.py SPEED --out DIR [--levels N N N ...]
                                                  [--t-end-tc T] [--figures-from JSON ...]

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

``--figures-from`` takes the figures of levels run elsewhere (another machine, an earlier
session whose run folders are gone) from an earlier ``convergence_V{SPEED}.json``: a level
given with ``--levels`` that has no completed folder in DIR but whose figures are in such a
file (same speed, same end time) is read from it and not run; the printout marks it.

The full case (``sphfem validate droplet-impact``) runs the three speeds in one process;
this script is the way to run them one at a time, on several machines, or with a finer
level added: ``--levels 128`` alone runs (or continues) that level and prints its figures,
without the criteria, which need three levels.
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


def earlier_figures(paths, speed: float, t_end_tc: float) -> dict[int, tuple[dict, str]]:
    """Level -> (figures, file) from earlier ``convergence_V*.json`` files of the same speed
    and end time (a later file wins); a file of another speed or end time is an error."""
    out: dict[int, tuple[dict, str]] = {}
    for path in paths:
        d = json.loads(Path(path).read_text())
        if not math.isclose(float(d["speed"]), speed):
            raise SystemExit(f"--figures-from {path}: speed {d['speed']} m/s, not {speed:g}")
        for n, f in zip(d["levels"], d["figures"], strict=True):
            t_tc = f["t_end"] / f["tc"]
            if abs(t_tc - t_end_tc) > 1e-6 * t_end_tc:
                raise SystemExit(f"--figures-from {path}: D/dx {n} ended at {t_tc:.4g} t_c, "
                                 f"not {t_end_tc:g}")
            out[int(n)] = (f, str(path))
    return out


def run_level(speed: float, n: int, t_end_tc: float, folder: Path) -> dict:
    """The summary of one level, run (or continued) when it has not completed."""
    from sphfem.api import run
    from sphfem.scene import parse_scene
    from sphfem.validation import droplet_impact as di

    s = completed(folder, speed, t_end_tc)
    if s is not None:
        return s
    d = di.scene_at(speed, n, t_end_tc)
    d["output"]["every"] = "0.1 tc"
    scene = parse_scene(d, source=f"convergence V={speed:g} D/dx={n}")
    resume = (folder / "checkpoint.npz").exists()
    # the checkpoint is kept, so a later, longer --t-end-tc continues the level
    run(scene, folder, resume=resume, overwrite=not resume, keep_checkpoint=True)
    return json.loads((folder / "summary.json").read_text())


def plot(path: Path, speed: float, levels, figs: list[dict]) -> None:
    """The four figures against dx (with their Richardson limits) and the spread band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.validation.droplet_impact import FIGURES
    from sphfem.validation.richardson import richardson

    D = figs[-1]["tc"] * speed
    h = [D / n * 1e6 for n in levels]
    scale = {"spread": 1.0, "heat": 1e6, "T_impact": 1.0, "vm_peak": 1e-6}
    unit = {"spread": "D_max/D", "heat": "heat [uJ]", "T_impact": "rise [K]",
            "vm_peak": "peak von Mises [MPa]"}
    fig, axs = plt.subplots(1, 4, figsize=(16, 3.6))
    for ax, key in zip(axs, FIGURES, strict=True):
        y = [f[key] * scale[key] for f in figs]
        ax.plot(h, y, "o-", label="SPH-FEM")
        if len(levels) >= 3:
            est = richardson(h, y)
            ax.axhline(est.value, color="k", lw=0.8, label="Richardson limit")
            ax.axhspan(est.value - est.error_bar, est.value + est.error_bar, color="k",
                       alpha=0.1, label="error bar (GCI)")
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("speed", type=float, help="impact speed [m/s]")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--levels", type=int, nargs="+", default=None,
                    help="particles across the droplet, coarse to fine (default: the case's)")
    ap.add_argument("--t-end-tc", type=float, default=None,
                    help="end time in t_c (default: the case's, di.t_end_for)")
    ap.add_argument("--figures-from", type=Path, nargs="+", default=[],
                    help="earlier convergence_V*.json files: levels without a completed "
                         "folder in --out take their figures from these")
    a = ap.parse_args(argv)

    from sphfem.output import write_json
    from sphfem.validation import droplet_impact as di

    if a.speed <= 0:
        ap.error(f"the speed must be > 0, got {a.speed}")
    levels = sorted(a.levels) if a.levels else list(di.levels_for(a.speed))
    if levels[0] <= 0:
        ap.error(f"--levels must be positive, got {levels}")
    t_end = a.t_end_tc or di.t_end_for(a.speed)
    a.out.mkdir(parents=True, exist_ok=True)
    earlier = earlier_figures(a.figures_from, a.speed, t_end)
    figs = []
    for n in levels:
        folder = a.out / f"V{a.speed:g}_n{n}"
        if n in earlier and not completed(folder, a.speed, t_end):
            f, origin = earlier[n]
            print(f"D/dx {n}: figures from {origin}")
        else:
            s = run_level(a.speed, n, t_end, folder)
            f = di.figures(s, a.speed, 2.0 * next(
                b for b in s["scene"]["blocks"] if b["kind"] == "fluid")["radius"])
        figs.append(f)
        print(f"D/dx {n}: spread {f['spread']:.3f} heat {f['heat'] * 1e6:.2f} uJ rise "
              f"{f['T_impact']:.2f} K vM {f['vm_peak'] / 1e6:.2f} MPa ({f['wall_s']:.0f} s)",
              flush=True)
    if len(levels) < 3:
        print(f"{len(levels)} level(s): run and read; the criteria need three "
              "(run again with all three --levels, completed folders are read)")
        return 0
    crit, notes = di.speed_criteria(a.speed, levels, figs)
    for name, c in crit.items():
        print(f"[{'PASS' if c.passed else 'FAIL'}] {name}: {c.value:.4g} {c.op} {c.limit:g}")
    for x in notes:
        print("note:", x)

    def clean(v):
        return None if isinstance(v, float) and not math.isfinite(v) else v

    write_json(a.out / f"convergence_V{a.speed:g}.json", {
        "speed": a.speed, "levels": levels,
        "figures": [{k: clean(float(v)) if isinstance(v, (int, float)) else v
                     for k, v in f.items()} for f in figs],
        "criteria": {k: {"value": clean(float(c.value)), "limit": c.limit, "op": c.op,
                         "passed": bool(c.passed), "description": c.description}
                     for k, c in crit.items()},
        "notes": notes})
    plot(a.out / f"convergence_V{a.speed:g}.png", a.speed, levels, figs)
    return 0 if all(c.passed for c in crit.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
