"""The droplet impact's axis, frame by frame: is the fluid at r = 0 doing what the rest does?

    python examples/droplet_impact/axis_frames.py RUN_DIR N [--speed V] [--every TC]
                                                  [--plot OUT.png --frames K K ...]

RUN_DIR a run of ``level_run.py`` (its ``particles_*.vtu``; ``--fluid-only --every 0.02`` is
the cheap way to get frames), N its particles across the droplet (D = 0.1 mm, so dx = D /
N).  Per frame, in dx: the top of the fluid at r < 2 dx against r in [8, 12) dx (a mound or
dimple at the axis shows as a difference that grows), the lowest ring at r < 2 dx (the first
row sits at ~0.5-0.7 dx; more is fluid lifting off the wall at the impact point), the mean
and largest pressure of the rings at r < 4 dx, z < 4 dx (the stagnation corner) in
rho V^2, and the axial speed of the top ring at the axis.  ``--plot`` draws the corner
(r, z < 16 dx) of the listed frames coloured by pressure.

Written for the session-25 diagnosis of the axis at D/dx 181 (docs/validation/
droplet_impact/README.md): what the figures mean is said there.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

DIAMETER = 1.0e-4  # m, the packaged droplet
RHO0 = 1000.0


def frame(path: Path):
    """Fluid positions (n, 2), velocities (n, 2), pressures (n,) of one frame, and the wall
    positions."""
    import meshio

    m = meshio.read(path)
    kind = m.point_data["kind"]
    fl = kind == 0
    return (m.points[fl, :2], m.point_data["v"][fl, :2], m.point_data["p"][fl],
            m.points[~fl, :2])


def axis_row(x, v, p, dx, speed) -> dict:
    """The axis figures of one frame (module docstring), lengths in dx."""
    r, z = x[:, 0] / dx, x[:, 1] / dx

    def top(lo, hi):
        s = (r >= lo) & (r < hi)
        return float(z[s].max()) if s.any() else float("nan")

    ax = r < 2.0
    corner = (r < 4.0) & (z < 4.0)
    q = RHO0 * speed**2
    i_top = np.flatnonzero(ax)[np.argmax(z[ax])] if ax.any() else None
    return {"top_axis": top(0.0, 2.0), "top_ring": top(8.0, 12.0),
            "bottom_axis": float(z[ax].min()) if ax.any() else float("nan"),
            "p_corner_mean": float(p[corner].mean() / q) if corner.any() else float("nan"),
            "p_corner_max": float(p[corner].max() / q) if corner.any() else float("nan"),
            "vz_top_axis": float(v[i_top, 1]) if i_top is not None else float("nan")}


def plot(files, dx, speed, out: Path) -> None:
    """The stagnation corner of the given frames, rings coloured by p / (rho V^2)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, len(files), figsize=(3.6 * len(files), 4.0), squeeze=False)
    sc = None
    for ax, f in zip(axs[0], files, strict=True):
        x, _, p, xw = frame(f)
        s = (x[:, 0] < 16 * dx) & (x[:, 1] < 16 * dx)
        w = (xw[:, 0] < 16 * dx) & (xw[:, 1] > -2 * dx)
        sc = ax.scatter(x[s, 0] / dx, x[s, 1] / dx, c=p[s] / (RHO0 * speed**2), s=10,
                        cmap="coolwarm", vmin=-2.0, vmax=2.0)
        ax.scatter(xw[w, 0] / dx, xw[w, 1] / dx, c="k", s=4)
        ax.set_aspect("equal")
        ax.set_xlim(0, 16)
        ax.set_ylim(-2, 16)
        ax.set_title(f.stem)
        ax.set_xlabel("r / dx")
    axs[0][0].set_ylabel("z / dx")
    fig.colorbar(sc, ax=axs[0].tolist(), label="p / (rho V^2)")
    fig.savefig(out, dpi=90)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("per_diameter", type=int)
    ap.add_argument("--speed", type=float, default=10.0, help="impact speed [m/s]")
    ap.add_argument("--every", type=float, default=None,
                    help="output interval of the run [t_c] (labels the frames)")
    ap.add_argument("--plot", type=Path, default=None)
    ap.add_argument("--frames", type=int, nargs="+", default=None)
    a = ap.parse_args(argv)
    files = sorted(a.run.glob("particles_*.vtu"))
    if not files:
        ap.error(f"no particles_*.vtu in {a.run}")
    dx = DIAMETER / a.per_diameter
    print(f"{'frame':>8} {'top axis':>9} {'top r8-12':>9} {'bottom axis':>11} "
          f"{'p corner':>9} {'max':>7} {'vz top':>7}")
    for k, f in enumerate(files):
        row = axis_row(*frame(f)[:3], dx, a.speed)
        label = f"{k * a.every:.2f} tc" if a.every else f.stem[-5:]
        print(f"{label:>8} {row['top_axis']:9.1f} {row['top_ring']:9.1f} "
              f"{row['bottom_axis']:11.2f} {row['p_corner_mean']:9.2f} "
              f"{row['p_corner_max']:7.2f} {row['vz_top_axis']:7.2f}")
    if a.plot is not None:
        ks = a.frames or [0, len(files) // 2, len(files) - 1]
        plot([files[k] for k in ks], dx, a.speed, a.plot)
        print(f"wrote {a.plot}")


if __name__ == "__main__":
    main()
