"""The maximum spreading of each (We, Re) case against its resolution: convergence ladders.

    python examples/droplet_impact/spreading_ladders.py RUNS [RUNS ...] --out FOLDER

Reads the run records (``We<We>_Re<Re>_n<n>[_m<k>].json``) that
``spreading_axisymmetric.py --n ... [--ensemble K]`` wrote into the folders RUNS (runs with
scene overrides are left out), groups them by case and by level, and writes to FOLDER:

- ``ladders.md``: per case the levels (D/dx), the level means of D_max / D (with the
  members' sd where a level has several), the particles across the residual film
  0.79 D Re^-0.4 (Roisman 2009) at the finest level, the range of the last three level
  means over the finest one, the correlations' band at a 90 degree contact angle
  (:func:`sphfem.fluid.spreading.correlation_table`) and how far the finest mean lies
  outside it, and the CPU seconds of all the case's runs;
- ``ladders.png``: D_max / D against the particles across the film, one panel per Re,
  one colour per We, the bands shaded, the members as dots;
- ``ladders.json``: every record read (histories included).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def read_runs(folders) -> dict:
    """{(We, Re): {n: [record, ...]}} of the records in ``folders`` (no overrides)."""
    runs: dict = defaultdict(lambda: defaultdict(list))
    for folder in folders:
        for f in sorted(Path(folder).glob("We*_Re*_n*.json")):
            rec = json.loads(f.read_text())
            if rec.get("overrides"):
                continue
            runs[(rec["We"], rec["Re"])][rec["n"]].append(rec)
    return runs


def table(runs) -> list[str]:
    """The rows of ``ladders.md`` (header included)."""
    rows = ["| We | Re | D/dx | D_max/D (level mean; members: sd) | film particles at the "
            "finest | range of the last three / finest | correlations (90 deg) | finest "
            "outside the band | CPU s |", "|---|---|---|---|---|---|---|---|---|"]
    for (We, Re) in sorted(runs, key=lambda k: (k[1], k[0])):
        levels = runs[(We, Re)]
        ns = sorted(levels)
        means = [float(np.mean([r["spread"] for r in levels[n]])) for n in ns]
        cells = []
        for n, m in zip(ns, means, strict=True):
            k = len(levels[n])
            sd = np.std([r["spread"] for r in levels[n]], ddof=1) if k > 1 else 0.0
            cells.append(f"{m:.3f}" + (f" ({k}: sd {sd:.3f})" if k > 1 else ""))
        band = list(levels[ns[0]][0]["correlations"].values())
        lo, hi = min(band), max(band)
        last = means[-1]
        off = 0.0 if lo <= last <= hi else ((last - hi) / hi if last > hi else (last - lo) / lo)
        rng = ((max(means[-3:]) - min(means[-3:])) / last * 100 if len(means) >= 3
               else float("nan"))
        cpu = sum(r["wall_s"] for n in ns for r in levels[n])
        rows.append(f"| {We:g} | {Re:g} | {' / '.join(map(str, ns))} | {' / '.join(cells)} | "
                    f"{levels[ns[-1]][0]['film_particles']:.1f} | {rng:.1f} % | "
                    f"{lo:.2f}-{hi:.2f} | {off * 100:+.1f} % | {cpu:.0f} |")
    return rows


def plot(runs, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = sorted({k[1] for k in runs})
    wes = sorted({k[0] for k in runs})
    fig, axs = plt.subplots(1, len(res), figsize=(4.3 * len(res), 3.8), squeeze=False)
    for (We, Re), levels in sorted(runs.items()):
        ax = axs[0, res.index(Re)]
        col = COLOURS[wes.index(We) % len(COLOURS)]
        ns = sorted(levels)
        band = list(levels[ns[0]][0]["correlations"].values())
        ax.axhspan(min(band), max(band), color=col, alpha=0.12)
        film = [levels[n][0]["film_particles"] for n in ns]
        ax.plot(film, [np.mean([r["spread"] for r in levels[n]]) for n in ns], "o-", color=col,
                label=f"We {We:g}")
        for n, fp in zip(ns, film, strict=True):
            if len(levels[n]) > 1:
                ax.plot([fp] * len(levels[n]), [r["spread"] for r in levels[n]], ".",
                        color=col, alpha=0.6)
        ax.set_title(f"Re {Re:g} (bands: the correlations, 90 deg)", fontsize=9)
        ax.set_xlabel("particles across the residual film 0.79 D Re^-0.4")
        ax.set_ylabel("D_max / D")
        ax.set_xscale("log")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", type=Path, nargs="+", help="folders of run records")
    p.add_argument("--out", type=Path, required=True, help="folder of the report")
    a = p.parse_args(argv)
    runs = read_runs(a.runs)
    if not runs:
        p.error("no run records (We*_Re*_n*.json) in " + ", ".join(map(str, a.runs)))
    a.out.mkdir(parents=True, exist_ok=True)
    rows = table(runs)
    (a.out / "ladders.md").write_text("\n".join(rows) + "\n")
    recs = [r for levels in runs.values() for n in levels for r in levels[n]]
    (a.out / "ladders.json").write_text(json.dumps(recs, indent=1))
    plot(runs, a.out / "ladders.png")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
