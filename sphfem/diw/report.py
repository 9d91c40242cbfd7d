"""Report of a toolpath optimisation: the fitness history and top views of the naive and
the optimised toolpath over their deposits (PNG, matplotlib's Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_history", "plot_top_view", "write_report"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_history(history: list[dict], path, title: str = "",
                 ylabel: str = "objective (thesis eq. 3.47)") -> None:
    """Best objective of each iteration and best so far against evaluations (log y)."""
    plt = _pyplot()
    n = [r["n_eval"] for r in history]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogy(n, [r["iteration_best"] for r in history], "o", ms=3, label="iteration best")
    ax.semilogy(n, [r["best"] for r in history], "-", label="best so far")
    ax.set_xlabel("evaluations")
    ax.set_ylabel(ylabel)
    ax.set_title(title or "fitness history")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_top_view(job, path, x=None, positions=None, metrics=None, title="") -> None:
    """Top view: the deposit's particles, the desired path (red dashes), the nozzle path
    (blue dashes) and its offset waypoints; lengths in mm."""
    plt = _pyplot()
    tp = job.toolpath(x)
    fig, ax = plt.subplots(figsize=(6, 6))
    if positions is not None and len(positions):
        p = np.asarray(positions)
        ax.scatter(p[:, 0] * 1e3, p[:, 1] * 1e3, s=2, c="0.55", lw=0, label="deposit")
    des = job.desired.polyline(job.desired.length / 400)
    ax.plot(des[:, 0] * 1e3, des[:, 1] * 1e3, "r--", lw=1.2, label="desired path")
    noz = tp.point(np.linspace(0, 1, 801))
    ax.plot(noz[:, 0] * 1e3, noz[:, 1] * 1e3, "b--", lw=1.2, label="nozzle path")
    if x is not None:
        ax.plot(tp.waypoints[:, 0] * 1e3, tp.waypoints[:, 1] * 1e3, "bo", ms=4,
                label="waypoints")
    text = title
    if metrics:
        text += (f"\nobjective {metrics['objective']:.4g}, max dev "
                 f"{metrics['max_dev_D']:.2f} D, mean {metrics['mean_dev_D']:.2f} D, "
                 f"gaps {metrics['gap_D']:.2f} D")
        if "edge_dev_max_D" in metrics:
            text += (f"\nedge dev max {metrics['edge_dev_max_D']:.2f} D, mean "
                     f"{metrics['edge_dev_mean_D']:.2f} D; centreline max "
                     f"{metrics['centre_dev_max_D']:.2f} D, mean "
                     f"{metrics['centre_dev_mean_D']:.2f} D")
    ax.set_title(text, fontsize=9)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_report(out, job, history, best_x, finals: dict) -> list[Path]:
    """fitness_history.png, toolpath_naive.png and toolpath_best.png in ``out``;
    ``finals``: name -> the final runs' records (``result``, ``positions``)."""
    out = Path(out)
    files = []
    if history:
        label = {"thesis": "objective (thesis eq. 3.47)",
                 "edge": "objective (edge: beyond the desired bead)",
                 "centre": "objective (centre: power mean of centreline / h)"}
        plot_history(history, out / "fitness_history.png", title=f"{job.case}: fitness",
                     ylabel=label.get(getattr(job, "objective", "thesis"), "objective"))
        files.append(out / "fitness_history.png")
    for name, x in (("naive", None), ("best", best_x)):
        fr = finals.get(name, {})
        ok = fr.get("status") == "ok"
        plot_top_view(job, out / f"toolpath_{name}.png", x=x,
                      positions=fr.get("positions") if ok else None,
                      metrics=fr.get("result") if ok else None,
                      title=f"{job.case}: {'naive' if x is None else 'optimised'} toolpath")
        files.append(out / f"toolpath_{name}.png")
    return files
