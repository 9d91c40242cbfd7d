"""Compare finished `sphfem optimize` runs: naive against optimised figures, and the best
objective so far against evaluations.

    python benchmarks/diw_compare.py DIR [DIR ...] [--png FILE] [--names NAME ...]

Each DIR is an output folder of `sphfem optimize` (``best_parameters.json``,
``history.json``).  Prints a Markdown table per run: the thesis' figures (eq. 3.47 objective,
max and mean deviation) and the practitioner's (edge deviation max and mean, centreline max
and mean; sphfem.diw.fitness) of the naive and the optimised toolpath, with the ratio
naive / optimised.  With ``--png``: best objective so far against evaluations, one line per
run (the runs' own objective, so compare runs of one objective).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

KEYS = ("objective", "thesis", "max_dev_D", "mean_dev_D", "edge_dev_max_D", "edge_dev_mean_D",
        "centre_dev_max_D", "centre_dev_mean_D", "gap_D")


def rows(folder: Path, name: str) -> list[str]:
    """Markdown rows of one run: naive, optimised and naive / optimised."""
    s = json.loads((folder / "best_parameters.json").read_text())
    naive, best = s.get("naive", {}), s.get("best", {})
    out = [f"run `{name}`: {s['method']}, {s['evaluations']} evaluations ({s['failed']} "
           f"failed), {s['wall_s']:.0f} s wall", "",
           "| toolpath | " + " | ".join(KEYS) + " |", "|---" * (len(KEYS) + 1) + "|"]
    for label, rec in (("naive", naive), ("optimised", best)):
        out.append(f"| {label} | " + " | ".join(
            f"{rec[k]:.4g}" if isinstance(rec.get(k), (int, float)) else "-" for k in KEYS)
            + " |")
    ratio = [naive[k] / best[k] if best.get(k) and naive.get(k) is not None else None
             for k in KEYS]
    out.append("| naive / optimised | " + " | ".join(
        f"{r:.2f}" if r is not None else "-" for r in ratio) + " |")
    return out


def plot(folders, names, png) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for folder, name in zip(folders, names, strict=True):
        h = json.loads((folder / "history.json").read_text())["rows"]
        ax.semilogy([r["n_eval"] for r in h], [r["best"] for r in h], "o-", ms=3, label=name)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best objective so far")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--names", nargs="*")
    ap.add_argument("--png")
    args = ap.parse_args(argv)
    names = args.names or [f.name for f in args.folders]
    for folder, name in zip(args.folders, names, strict=True):
        print("\n".join(rows(folder, name)) + "\n")
    if args.png:
        plot(args.folders, names, args.png)


if __name__ == "__main__":
    main()
