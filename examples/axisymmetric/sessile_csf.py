"""Axisymmetric sessile drop with the CSF: which contact angle does the (r, z) fluid settle at?

    python examples/axisymmetric/sessile_csf.py R0_OVER_DX T_END_TSIGMA OUT [--mu MU]

A water-like drop (R0 = 50 um, rho 1000, sigma 0.072 N/m, mu 0.05 Pa s by default, c0 20 m/s,
no gravity) starts as a sphere touching a 3-layer wall (the packaged axisymmetric droplet
scene with the fluid module only) and relaxes for T_END_TSIGMA capillary times
t_sigma = sqrt(rho R0^3 / sigma).  Printed: the wetted radius (the fluid module's spreading
measure) and the contact angle of the spherical cap of the drop's volume with that radius.
Measured 2026-12-02 (docs/validation/droplet_impact/README.md, session 9): R0/dx 16, mu 0.01
(Oh 0.17): 165 deg at the start, 90 deg after 12 t_sigma and still creeping; mu 0.05: 150-165
deg over 8 t_sigma.
"""

from __future__ import annotations

import argparse
import json
import math
import tomllib
from importlib import resources
from pathlib import Path

R0, RHO, SIGMA = 50e-6, 1000.0, 0.072


def cap_angle(a: float, volume: float) -> float:
    """Contact angle [deg] of the spherical cap of ``volume`` on a disc of radius ``a``."""
    from scipy.optimize import brentq

    def f(th):
        return (math.pi * a**3 * (2 + math.cos(th)) * (1 - math.cos(th)) ** 2
                / (3 * math.sin(th) ** 3) - volume)

    return math.degrees(brentq(f, 1e-3, math.pi - 1e-3))


def scene(n: int, t_end_ts: float, mu: float) -> dict:
    dx = R0 / n
    ts = math.sqrt(RHO * R0**3 / SIGMA)
    d = tomllib.loads(resources.files("sphfem.scenes").joinpath(
        "droplet_impact_axisymmetric.toml").read_text())
    d["physics"]["modules"] = ["fluid"]
    for k in ("heat", "coupling"):
        d.pop(k, None)
    d["sph"]["dx"] = dx
    d["domain"] = {"lo": [0.0, -4 * dx], "hi": [6 * R0, 3 * R0]}
    d["materials"] = {"water": {"rho0": RHO, "c": 4000.0, "k": 0.6, "mu": mu, "c0": 20.0,
                                "sigma": SIGMA},
                      "wallmat": {"rho0": 3950.0, "c": 900.0, "k": 10.0}}
    wall, drop = d["blocks"]
    wall.update(material="wallmat", lo=[0.0, -3 * dx], hi=[6 * R0, 0.0])
    wall.pop("temperature", None)
    drop.update(material="water", radius=R0, velocity=[0.0, 0.0], center=[0.0, R0 + 0.5 * dx])
    for k in ("temperature", "above", "gap"):
        drop.pop(k, None)
    d["time"] = {"t_end": t_end_ts * ts}
    d["output"] = {"every": t_end_ts * ts / 10, "fields": ["v", "rho", "p", "kind"]}
    return d


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("per_radius", type=int)
    ap.add_argument("t_end_tsigma", type=float)
    ap.add_argument("out", type=Path)
    ap.add_argument("--mu", type=float, default=0.05)
    a = ap.parse_args(argv)

    from sphfem.api import run
    from sphfem.scene import parse_scene

    run(parse_scene(scene(a.per_radius, a.t_end_tsigma, a.mu), source="sessile_csf"), a.out,
        overwrite=True)
    s = json.loads((a.out / "summary.json").read_text())
    sp = s["diagnostics"]["fluid"]["spreading"]
    ts = math.sqrt(RHO * R0**3 / SIGMA)
    volume = 4.0 / 3.0 * math.pi * R0**3
    rows = list(zip(sp["history_t_s"], sp["history_ratio"], strict=True))
    for t, ratio in rows[:: max(1, len(rows) // 12)]:
        a_r = ratio * R0  # the ratio is a diameter over the drop's diameter 2 R0
        print(f"t/t_sigma {t / ts:5.2f}  wetted radius/R0 {a_r / R0:.3f}  cap angle "
              f"{cap_angle(a_r, volume):6.1f} deg")


if __name__ == "__main__":
    main()
