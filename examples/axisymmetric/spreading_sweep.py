"""Maximum spreading of an axisymmetric droplet impact against the published correlations
(issue 16).

Water-like droplet D = 0.1 mm, rho = 1000 kg/m^3, no gravity, onto a rigid wall of 3
layers of Adami particles (the set-up of impact_robustness.build: lattice rings, surface
R = 3 dx above the wall top z = 0, the no-penetration correction; fixed h unless
``--adaptive-h``), with the axisymmetric CSF surface tension sigma and c0 = 10 V.  A case
is (V, mu, sigma) -> We = rho V^2 D / sigma, Re = rho V D / mu.  Every 0.05 t_c (t_c = D / V,
counted from the start, 3 dx / V before contact) the spread diameter is measured as twice
the colour contact radius (:func:`sphfem.fluid.spreading.colour_contact_radius`, measuring
kernel R = 3 dx); the run stops at ``--tc`` or 0.75 t_c after the maximum once the diameter
has fallen 3 % below it.

    python examples/axisymmetric/spreading_sweep.py run --case we139_re1000 --n 16 --out x.json
    python examples/axisymmetric/spreading_sweep.py table docs/validation/spreading/axi/*.json
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import droplet_crosscheck as dc  # noqa: E402
import impact_robustness as ir  # noqa: E402

#: name -> (V [m/s], mu [Pa s], sigma [N/m])
CASES = {
    "we35_re100": (5.0, 5.0e-3, 0.072),
    "we139_re1000": (10.0, 1.0e-3, 0.072),
    "we139_re10000": (10.0, 1.0e-4, 0.072),
    "we1250_re3000": (30.0, 1.0e-3, 0.072),
    "we3000_re2000": (20.0, 1.0e-3, 0.04 / 3.0),
}


#: fraction of the maximum the diameter must fall to for the maximum to count as reached
FALL = 0.97


class _Done(Exception):
    pass


def groups(v, mu, sigma):
    """(We, Re) of a case."""
    return dc.RHO * v * v * dc.D / sigma, dc.RHO * v * dc.D / mu


def run(case, n, tc=4.0, verbose=True, adaptive_h=False, **kw):
    """One impact at D/dx = n; returns the record with the spread history.  Fixed h by
    default: with adaptive h the D/dx = 32 runs throw rings along the wall from 1.4 t_c
    (sphfem.fluid.axisymmetric's docstring; seen here at We 139, Re 1000)."""
    from sphfem.fluid.spreading import colour_contact_radius

    v, mu, sigma = CASES[case]
    f, dx = ir.build(n, v, 10.0 * v, mu, adaptive_h=adaptive_h, surface_tension=sigma, **kw)
    hist = []
    t0 = time.perf_counter()

    def measure(s):
        fl = s.fluid
        r, z = s.x[fl, 0], s.x[fl, 1]
        area = s.M[fl] / (2.0 * math.pi * np.maximum(r, 1e-300) * s.rho[fl])
        rc = colour_contact_radius(r, z, area, 0.0, 3.0 * dx)
        near = z < 1.5 * dx
        rw = r[near].max() + 0.5 * dx if near.any() else 0.0
        hist.append((s.t * v / dc.D, 2 * rc / dc.D, 2 * rw / dc.D, 2 * r.max() / dc.D))
        if verbose:
            print(f"t/tc {hist[-1][0]:.2f} beta_colour {hist[-1][1]:.4f} "
                  f"beta_row {hist[-1][2]:.4f} {time.perf_counter() - t0:.0f} s", flush=True)
        b = np.array([h[1] for h in hist])
        k = int(b.argmax())
        if b[-1] < FALL * b[k] and hist[-1][0] > hist[k][0] + 0.75:
            raise _Done

    measure(f)
    error = None
    try:
        f.run(tc * dc.D / v, measure, every=0.05 * dc.D / v)
    except _Done:
        pass
    except Exception as e:  # noqa: BLE001 -- a blow-up ends the run; its history is kept
        error = f"{type(e).__name__}: {e}"
    h = np.array(hist)
    k = int(h[:, 1].argmax())
    We, Re = groups(v, mu, sigma)
    return dict(case=case, n=n, dx=dx, adaptive_h=adaptive_h, options=kw, V=v, mu=mu, sigma=sigma,
                We=We, Re=Re,
                fluid=int(f.fluid.sum()), steps=f.step_count,
                seconds=time.perf_counter() - t0, t_reached=f.t * v / dc.D, error=error,
                beta_max=float(h[k, 1]), t_max=float(h[k, 0]), at_end=k == len(h) - 1,
                beta_row_max=float(h[:, 2].max()),
                corrections=int(getattr(f, "penetration_corrections", 0)),
                columns=("t/tc", "beta_colour", "beta_row", "2 max r/D"), history=hist)


def table(files, out_dir, theta_deg=90.0):
    """Markdown table and PNG of the runs in ``files`` (JSON of :func:`run`) against the
    correlations of :mod:`sphfem.fluid.spreading` at contact angle ``theta_deg``."""
    from sphfem.fluid.spreading import CORRELATIONS, artificial_nu, effective_reynolds
    from sphfem.validation.richardson import richardson

    by = {}
    for fn in files:
        d = json.load(open(fn))
        # a maximum counts only once the diameter has fallen FALL below it afterwards (the
        # runs' own stop criterion); otherwise (still spreading, a plateau, or a run that
        # broke off) it is a lower bound
        b = np.array([row[1] for row in d["history"]])
        k = int(b.argmax())
        d["at_end"] = not (b[k:] < FALL * b[k]).any()
        by.setdefault(d["case"], []).append(d)
    names = list(CORRELATIONS)
    head = ("| case | We | Re | D/dx | beta_max (colour) | t_max / t_c | s per run | "
            "Richardson limit; finest +- GCI bar (order) | Re_eff | PF96 at Re_eff | "
            + " | ".join(names) + " |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    pts = []
    for case, runs in sorted(by.items(), key=lambda kv: groups(*CASES[kv[0]])):
        runs.sort(key=lambda d: d["n"])
        We, Re = groups(*CASES[case])
        ns = [d["n"] for d in runs]
        b = [d["beta_max"] for d in runs]
        est, e = "-", None
        # lower bounds stay out of the extrapolation
        ok = [(n, x) for n, x, d in zip(ns, b, runs, strict=True) if not d["at_end"]]
        if len(ok) >= 3:
            e = richardson([dc.D / n for n, _ in ok], [x for _, x in ok])
            order = f"{e.order:.2f}" if e.order is not None else "none"
            est = f"{e.value:.3f}; {ok[-1][1]:.3f} +- {e.error_bar:.3f} ({order})"
        cor = [float(CORRELATIONS[c](We, Re, theta_deg)) for c in names]
        vals = " / ".join(f"{'>= ' if d['at_end'] else ''}{x:.3f}"
                          for x, d in zip(b, runs, strict=True))
        tmax = " / ".join(f"{d['t_max']:.2f}" for d in runs)
        secs = " / ".join(f"{d['seconds']:.0f}" for d in runs)
        # artificial viscosity alpha h c0 (alpha = 0.02, h = 1.5 dx, c0 = 10 V; the
        # meridian kernel's d = 2) on top of mu: the Reynolds number each level behaves like
        v, mu = CASES[case][:2]
        re_eff = [effective_reynolds(v, dc.D, mu / dc.RHO,
                                     artificial_nu(0.02, 1.5 * dc.D / n, 10.0 * v, 2))
                  for n in ns]
        pf_eff = [float(CORRELATIONS["pasandideh-fard-1996"](We, r, theta_deg)) for r in re_eff]
        est += (" | " + " / ".join(f"{r:.0f}" for r in re_eff) + " | "
                + " / ".join(f"{x:.2f}" for x in pf_eff))
        lines.append(f"| {case} | {We:.0f} | {Re:.0f} | {' / '.join(map(str, ns))} | {vals} | "
                     f"{tmax} | {secs} | {est} | " + " | ".join(f"{c:.2f}" for c in cor) + " |")
        pts.append((We, Re, ns, b, cor, e, runs))
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    (Path(out_dir) / "axisymmetric_table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    idx = np.arange(len(pts))
    marks = "os^vD"
    for k, c in enumerate(names):
        ax.plot(idx, [p[4][k] for p in pts], marks[k % 5], mfc="none", ms=8, label=c)
    for i, (_, _, ns, b, _, e, runs) in enumerate(pts):
        for n, x, d in zip(ns, b, runs, strict=True):
            ax.plot(i + 0.12, x, "k^" if d["at_end"] else "k.", ms=3 + n / 10)
            ax.annotate(f"{n}", (i + 0.15, x), fontsize=7)
        if e is not None:
            ax.errorbar(i + 0.3, e.finest, yerr=e.error_bar, fmt="none", ecolor="r", capsize=3)
            ax.plot(i + 0.3, e.value, "rx")
    ax.plot([], [], "k.", label="SPH axisymmetric (label: D/dx)")
    ax.plot([], [], "k^", label="SPH, lower bound (no 3 % fall after the maximum)")
    ax.plot([], [], "rx", label="Richardson limit (bar: GCI band about the finest level)")
    ax.set_xlim(-0.5, len(pts) - 0.4)
    ax.set_xticks(idx, [f"We {p[0]:.0f}\nRe {p[1]:.0f}" for p in pts])
    ax.set_ylabel("D_max / D")
    ax.set_title(f"maximum spreading; correlations at theta = {theta_deg:.0f} deg")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(Path(out_dir) / "axisymmetric_spreading.png", dpi=120)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["run", "table"])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--dir", default="docs/validation/spreading")
    ap.add_argument("--case", choices=sorted(CASES))
    ap.add_argument("--n", type=int, default=16, help="D / dx")
    ap.add_argument("--tc", type=float, default=4.0)
    ap.add_argument("--adaptive-h", action="store_true")
    ap.add_argument("--kw", action="append", default=[], metavar="KEY=VALUE",
                    help="more AxisymmetricFluid keywords (Python literals), repeatable")
    ap.add_argument("--out")
    a = ap.parse_args()
    extra = {k: ast.literal_eval(x) for k, x in (s.split("=", 1) for s in a.kw)}
    if a.mode == "table":
        table(a.files, a.dir)
        return
    res = run(a.case, a.n, a.tc, adaptive_h=a.adaptive_h, **extra)
    print(json.dumps({k: x for k, x in res.items() if k not in ("history", "columns")}))
    if a.out:
        with open(a.out, "w") as fh:
            json.dump(res, fh)


if __name__ == "__main__":
    main()
