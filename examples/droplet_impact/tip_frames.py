"""The lamella's tip, frame by frame, for several axisymmetric droplet runs side by side.

    python examples/droplet_impact/tip_frames.py RUN[:LABEL] [RUN[:LABEL] ...] --n N
                                                 --times T [T ...] --out PNG
                                                 [--speed V] [--width W] [--height H]

RUN a run folder with ``particles.pvd`` (its frames; ``convergence.py`` and ``level_run.py``
write them), N its particles across the droplet (D = 0.1 mm, so dx = D / N).  For each time
T [t_c] the frame nearest to it is drawn around the tip of the sheet on the wall (the
outermost fluid ring within 2 dx of the wall top): the rings within ``--width`` D behind the
tip and ``--height`` D above the wall, coloured by their wall-normal speed (red: rising,
blue: falling), the wall's rings in black.  One column per run, one row per time.

Written for the session-36 look at why ensemble members of one level end at different
spreads (docs/validation/droplet_impact/README.md): members that differ by 1e-3 dx at the
start part at the tip, where the rim rolls over the sheet.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

D0 = 1e-4  #: the droplet diameter of the validation scene [m]


def frames(run: Path) -> list[tuple[float, Path]]:
    """(t [s], file) of the frames listed in ``run/particles.pvd``."""
    from sphfem.output import pvd_frames

    return pvd_frames(run / "particles.pvd")


def tip_window(path: Path, dx: float, width: float, height: float):
    """(r, z, v_z of the fluid rings, r, z of the wall rings, r of the tip) around the tip of
    the sheet in the frame ``path``; lengths in D."""
    import meshio

    m = meshio.read(path)
    kind = np.asarray(m.point_data["kind"])
    fl, wall = kind == 0, kind != 0
    top = m.points[wall, 1].max() + 0.5 * dx if wall.any() else 0.0
    r, z = m.points[fl, 0] / D0, (m.points[fl, 1] - top) / D0
    vz = np.asarray(m.point_data["v"])[fl, 1]
    on_wall = z < 2.0 * dx / D0
    tip = float(r[on_wall].max()) if on_wall.any() else float(r.max())
    near = (r > tip - width) & (r < tip + 0.1 * width) & (z < height)
    rw, zw = m.points[wall, 0] / D0, (m.points[wall, 1] - top) / D0
    sw = (rw > tip - width) & (rw < tip + 0.1 * width) & (zw > -3.0 * dx / D0)
    return r[near], z[near], vz[near], rw[sw], zw[sw], tip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="RUN[:LABEL]")
    ap.add_argument("--n", type=float, required=True, help="particles across the droplet")
    ap.add_argument("--times", type=float, nargs="+", required=True, help="times [t_c]")
    ap.add_argument("--speed", type=float, default=10.0, help="impact speed [m/s]")
    ap.add_argument("--width", type=float, default=0.3, help="window behind the tip [D]")
    ap.add_argument("--height", type=float, default=0.06, help="window above the wall [D]")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    if a.n <= 0 or a.speed <= 0 or a.width <= 0 or a.height <= 0:
        ap.error("--n, --speed, --width and --height must be > 0")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dx, tc = D0 / a.n, D0 / a.speed
    runs = [(Path(s.split(":", 1)[0]), s.split(":", 1)[-1]) for s in a.runs]
    for run, _ in runs:
        if not (run / "particles.pvd").is_file():
            ap.error(f"{run}: no particles.pvd (a run folder with its frames is needed)")
    fig, axes = plt.subplots(len(a.times), len(runs), squeeze=False, layout="constrained",
                             figsize=(4.0 * len(runs) + 1.0, 1.3 * len(a.times) + 0.5))
    sc = None
    for j, (run, label) in enumerate(runs):
        fr = frames(run)
        for i, t in enumerate(a.times):
            tf, path = min(fr, key=lambda f: abs(f[0] / tc - t))
            r, z, vz, rw, zw, tip = tip_window(path, dx, a.width, a.height)
            ax = axes[i, j]
            sc = ax.scatter(r, z, c=vz / a.speed, s=4, cmap="coolwarm", vmin=-0.3, vmax=0.3)
            ax.scatter(rw, zw, s=2, c="k")
            ax.set_xlim(tip - a.width, tip + 0.1 * a.width)
            ax.set_aspect("equal")
            ax.set_title(f"{label}, t = {tf / tc:.2f} t_c, tip at r = {tip:.3f} D", fontsize=9)
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("r / D")
    for ax in axes[:, 0]:
        ax.set_ylabel("z / D")
    fig.colorbar(sc, ax=axes, shrink=0.6, label="v_z / V")
    fig.savefig(a.out, dpi=90)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
