"""How the axisymmetric droplet job's peak figures depend on the fluid's speed of sound c0,
and quasi-static against elastodynamic substrate (issue 16).

The scene is droplet_impact_axisymmetric.toml (water D = 0.1 mm, 50 m/s, 100 C onto
alumina at 20 C) scaled to the spacing as axisymmetric_resolutions.scaled_scene does, with

* ``c0``: a number (10 V = 500, 20 V = 1000 m/s) or "physical" (sound_speed = 1480 m/s,
  sphfem/sound_speed.py);
* ``--mech-only``: the substrate's alpha removed (no thermal strain; the heat still flows),
  so the stress is that of the fluid's load alone;
* ``--dynamic``: the substrate stepped by sphfem.fem.elastodynamic (HHT-alpha, consistent
  mass, K + M/(beta dt^2) factorised per coupling interval).  The scene schema accepts
  ``backend = "fem-axisymmetric-dynamic"`` neither for axisymmetric scenes nor at all
  (coupling/scene_section.py lists fem, fem-dynamic, tlsph, fem-axisymmetric), so this
  script swaps the scene's RingBackend for a dynamic one at set-up (:func:`_patched`);
* the substrate solved every SPH step (``every_k_steps = 1``): the water hammer lasts
  about R V / c0^2 (1 ns at 1480 m/s), a few SPH steps.

Wall pressure.  Each coupling step the sensors' ring forces F (N, total over the ring) are
summed per wall column (r within dx) and divided by the column's annulus area 2 pi r dx:
p_w(r, t) = -sum F_z / (2 pi r dx).  The run's peak wall pressure is the largest p_w.

Compared with the water-hammer pressure of a liquid hitting a rigid wall, rho c V (Lesser &
Field 1983, Annu. Rev. Fluid Mech. 15, 97: rho c V at the first contact, up to
rho c V (1 + k V / c) with k ~ 2 for water at the contact edge).

    python examples/droplet_impact/c0_study.py --out DIR --dx 6.25e-6 --c0 500 \
        [--mech-only] [--dynamic --hht-alpha -0.05] [--t-end-after-contact 1e-6]

writes ``DIR/<tag>/`` (the run) and ``DIR/<tag>.json`` (figures, :func:`figures`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from axisymmetric_resolutions import SCENE, scaled_scene  # noqa: E402

from coupling.axisymmetric_scene import RingBackend  # noqa: E402
from coupling.backend_fem_dynamic import _DynamicMixin  # noqa: E402

V = 50.0
RHO_F = 1000.0
SOUND_SPEED = 1480.0


def tag(dx: float, c0, mech_only: bool, dynamic: bool, hht_alpha: float) -> str:
    kind = "mech" if mech_only else "full"
    sub = f"dyn{hht_alpha:g}" if dynamic else "qs"
    return f"D{round(1e-4 / dx)}_c0{c0}_{kind}_{sub}"


def study_scene(dx: float, c0, mech_only: bool, t_end: float) -> dict:
    """The scaled scene with the speed of sound ``c0`` (m/s or "physical"), the substrate
    solved every step, ``t_end`` [s] and, if ``mech_only``, no thermal strain."""
    data = scaled_scene(dx, f"{t_end!r}")
    data["time"]["t_end"] = t_end
    water = data["materials"]["water"]
    water["c0"] = c0 if c0 == "physical" else float(c0)
    water["sound_speed"] = SOUND_SPEED
    if mech_only:
        data["materials"]["alumina"].pop("alpha", None)
    data["coupling"]["every_k_steps"] = 1
    data["coupling"]["vtu_every"] = 0
    data["output"]["every"] = t_end
    return data


class WallPressure:
    """p_w(r, t) (module docstring) from the ring forces handed to the backend: ``columns``
    at each :meth:`record`, kept with the time of the following :meth:`commit` (the
    driver calls ``apply`` then ``solve(t)``)."""

    def __init__(self, dx: float):
        self.dx = dx
        self.peak = {"p_Pa": 0.0, "t_s": None, "r_m": None}
        self.axis = []  # (t, p_w of the column at the axis)
        self._p = None

    def columns(self, points, forces):
        """(r, p_w) of the wall columns [dx k, dx (k + 1)): centres and pressures [Pa]."""
        pts = np.atleast_2d(np.asarray(points, float)).reshape(-1, 2)
        F = np.reshape(np.asarray(forces, float), (-1, 2))
        col = np.floor(pts[:, 0] / self.dx).astype(int)
        fz = np.bincount(col, weights=-F[:, 1])
        r = (np.arange(len(fz)) + 0.5) * self.dx
        return r, fz / (2.0 * math.pi * r * self.dx)

    def record(self, points, forces) -> None:
        self._p = self.columns(points, forces) if len(points) else None

    def commit(self, t: float) -> None:
        if self._p is None:
            return
        r, p = self._p
        k = int(np.argmax(p))
        if p[k] > self.peak["p_Pa"]:
            self.peak = {"p_Pa": float(p[k]), "t_s": float(t), "r_m": float(r[k])}
        self.axis.append((float(t), float(p[0])))
        self._p = None


class _Recorder:
    """Backend mix-in: hands the sensor forces to ``self.wall`` (a :class:`WallPressure`)."""

    wall: WallPressure

    def apply(self, points, forces, T_points=None, T=None, vol=None):
        self.wall.record(points, forces)
        return super().apply(points, forces, T_points, T, vol)

    def solve(self, t):
        self.wall.commit(t)
        return super().solve(t)


class _QuasiStatic(_Recorder, RingBackend):
    name = "fem-axisymmetric"


class _Dynamic(_Recorder, _DynamicMixin, RingBackend):
    name = "fem-axisymmetric-dynamic"


def study_backend(backend, wall: WallPressure, dynamic: bool = False, rho: float = 0.0,
                  hht_alpha: float = 0.0, mass: str = "consistent", t0: float = 0.0):
    """The scene's :class:`coupling.axisymmetric_scene.RingBackend` ``backend``, recording
    the wall pressure into ``wall`` and, if ``dynamic``, stepping its substrate with
    :class:`sphfem.fem.elastodynamic.ElastodynamicSubstrate` (density ``rho``, ``hht_alpha``,
    ``mass``) from rest at ``t0`` as coupling.backend_fem_dynamic does."""
    backend.__class__ = _Dynamic if dynamic else _QuasiStatic
    backend.wall = wall
    if dynamic:
        backend._init_dynamic(rho, hht_alpha, mass, t0)
    return backend


def _patch(dx: float, dynamic: bool, hht_alpha: float) -> WallPressure:
    """Make coupling.axisymmetric_scene.build_axisymmetric_backend return a
    :func:`study_backend` (the scene schema has no axisymmetric dynamic backend)."""
    import coupling.axisymmetric_scene as axs

    wall = WallPressure(dx)
    original = axs.build_axisymmetric_backend

    def build(scene, cfg, lo, hi, T0, ctx):
        rho = scene.materials[cfg.material].rho0
        return study_backend(original(scene, cfg, lo, hi, T0, ctx), wall, dynamic, rho,
                             hht_alpha, t0=float(ctx.t))

    axs.build_axisymmetric_backend = build
    return wall


def probe_maxima(folder: Path) -> list:
    """[(r, z, largest von Mises over the run [Pa])] at each probe of ``folder``'s run."""
    h = json.loads((folder / "substrate" / "history.json").read_text())
    rows = [r for r in h["history"] if "probes" in r]
    return [(*pt, max(r["probes"][k]["von_mises"] for r in rows))
            for k, pt in enumerate(h["probes"])]


def figures(folder: Path, wall: WallPressure, c0_used: float) -> dict:
    """Peak wall pressure, peak von Mises (value, t, place), the impact-point probe
    history and the run's cost, from ``folder``'s summary and substrate history."""
    s = json.loads((folder / "summary.json").read_text())
    c = s["diagnostics"]["coupling"]
    hist = json.loads((folder / "substrate" / "history.json").read_text())["history"]
    # (t, von Mises, sigma_zz, T) at the first probe (the impact point); (r, z, theta) order
    probe0 = [(h["t"], h["probes"][0]["von_mises"], h["probes"][0]["yy"], h["probes"][0]["T"])
              for h in hist if "probes" in h]
    return {
        "status": s["status"], "t_reached_s": s["t"], "steps": s["steps"],
        "wall_s": s["wall_s"], "peak_rss_mb": s["peak_rss_mb"],
        "c0_m_s": c0_used, "t_contact_s": c.get("t_contact_s"),
        "rho_c0_V_Pa": RHO_F * c0_used * V,
        "peak_wall_pressure": wall.peak,
        "axis_wall_pressure": wall.axis,
        "peak_von_mises_Pa": c.get("peak_von_mises_Pa"),
        "peak_von_mises_t_s": c.get("peak_von_mises_t_s"),
        "peak_von_mises_location_m": c.get("peak_von_mises_location_m"),
        "peak_history": [(h["t"], h["peak_von_mises"], h["peak_location"]) for h in hist],
        "impact_point": probe0,
        "probe_max": probe_maxima(folder),
        "every_k_steps": c.get("every_k_steps"),
        "backend": c.get("backend", {}).get("dynamics") if isinstance(c.get("backend"), dict)
        else None,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--dx", type=float, default=6.25e-6)
    ap.add_argument("--c0", default="500", help='m/s or "physical"')
    ap.add_argument("--mech-only", action="store_true")
    ap.add_argument("--dynamic", action="store_true")
    ap.add_argument("--hht-alpha", type=float, default=-0.05)
    ap.add_argument("--t-end-after-contact", type=float, default=1.0e-6,
                    help="run to the contact time (gap / V) plus this [s]")
    a = ap.parse_args(argv)
    from sphfem.errors import SimulationStopped
    from sphfem.scene import parse_scene
    from sphfem.simulation import Simulation

    c0 = a.c0 if a.c0 == "physical" else float(a.c0)
    t_end = 3.0 * a.dx / V + a.t_end_after_contact
    name = tag(a.dx, a.c0, a.mech_only, a.dynamic, a.hht_alpha)
    folder = a.out / name
    wall = _patch(a.dx, a.dynamic, a.hht_alpha)
    t0 = time.perf_counter()
    sim = Simulation(parse_scene(study_scene(a.dx, c0, a.mech_only, t_end), source=str(SCENE)))
    try:
        sim.run(folder, progress=False)
    except SimulationStopped:
        pass  # summary.json holds the figures up to the stop
    fig = figures(folder, wall, SOUND_SPEED if c0 == "physical" else c0)
    fig.update(dx_m=a.dx, D_over_dx=1e-4 / a.dx, c0=a.c0, mech_only=a.mech_only,
               dynamic=a.dynamic, hht_alpha=a.hht_alpha if a.dynamic else None,
               t_end_s=t_end, process_wall_s=time.perf_counter() - t0)
    (a.out / f"{name}.json").write_text(json.dumps(fig, indent=1))
    pw = fig["peak_wall_pressure"]
    print(f"{name}: p_w {pw['p_Pa'] / 1e6:.2f} MPa at t {pw['t_s']}, r {pw['r_m']}; "
          f"vM {fig['peak_von_mises_Pa'] / 1e6:.2f} MPa at {fig['peak_von_mises_t_s']} "
          f"{fig['peak_von_mises_location_m']}; {fig['process_wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
