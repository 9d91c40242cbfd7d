"""The spreading ratio D(t) / D of several axisymmetric droplet runs on one plot.

    python examples/droplet_impact/spread_histories.py RUN[:LABEL] [RUN[:LABEL] ...] --out PNG
                                                      [--band LO HI]

RUN a run folder with a ``summary.json`` (``level_run.py``, ``sphfem run``): its fluid's
spreading history (``diagnostics.fluid.spreading``: the main body's wetted diameter over
D0, sampled through the run) against t / t_c, t_c = D0 / V with V the droplet block's
speed.  ``--band`` shades the published correlations' band (e.g. the validation's
``correlations`` figure).  Prints each run's maximum and when it came.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def history(run: Path):
    """(t / t_c, D / D0, label-ready maximum) of a run folder."""
    s = json.loads((run / "summary.json").read_text())
    sp = s["diagnostics"]["fluid"]["spreading"]
    blk = next(b for b in s["scene"]["blocks"] if b["kind"] == "fluid")
    v = math.hypot(*blk["velocity"])
    tc = sp["D0_m"] / v
    t = [x / tc for x in sp["history_t_s"]]
    return t, sp["history_ratio"], sp["max_ratio"], sp["max_t_s"] / tc


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="RUN or RUN:LABEL")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--band", type=float, nargs=2, default=None, metavar=("LO", "HI"))
    a = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    if a.band:
        ax.axhspan(*a.band, color="0.85", label="correlations")
    for item in a.runs:
        path, _, label = item.partition(":")
        t, d, dmax, tmax = history(Path(path))
        ax.plot(t, d, lw=1.2, label=f"{label or Path(path).name} (max {dmax:.2f})")
        print(f"{label or path}: D_max/D {dmax:.3f} at {tmax:.2f} t_c")
    ax.set_xlabel("t / t_c")
    ax.set_ylabel("D / D0 (main body, wetted)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(a.out, dpi=120)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
