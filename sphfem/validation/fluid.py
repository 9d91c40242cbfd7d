"""Fluid validation cases: ``poiseuille``, ``hydrostatic``, ``dambreak`` and
``droplet-oscillation`` (issue 4).

All runs use the WCSPH delta-SPH solver of :mod:`sphfem.fluid` with the Wendland C2 kernel,
support radius R = 3 dx, Adami walls of 3 particle layers, cell-centred lattices.

* ``poiseuille``: body-force-driven channel of width L between no-slip walls, periodic in x
  (Morris et al. 1997 parameters: L = 1 mm, nu = 1e-6 m^2/s, F = 2e-4 m/s^2, Re = 0.025).
  The SPH velocity is compared with the transient series solution (the steady parabola
  minus decaying sine modes) during the start-up, t = 0.1 L^2/nu, where the transient is
  ~40 % of u_max, and at t = 0.5 L^2/nu, where it is below 1 %.
* ``hydrostatic``: 2D water column H = 1 m in a square tank, at rest for 2 s (Tait fluid with
  c0 = 10 sqrt(g H), gravity ramped in over 0.5 s), started from a packed particle
  arrangement (:mod:`sphfem.fluid.packing`): pressure vs rho0 g depth, and the largest
  speed over the second second vs sqrt(g H), also carried to the full run's finest
  resolution with its observed growth.
* ``dambreak``: 2D column a x 2a (a = 0.146 m, Koshizuka & Oka 1996) in a 4a-long tank: surge
  front Z = x/a against T = t sqrt(2 g / a), compared with the experiments of Koshizuka & Oka
  (1996) and Martin & Moyce (1952, n^2 = 2, a = 2.25 in), as digitised in PySPH's
  ``pysph/examples/db_exp_data.py``; bounded above by the shallow-water (Ritter) front
  Z = 1 + 2 T; the front curve must converge (successive differences shrinking).
"""

from __future__ import annotations

import math
import time

import numpy as np

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.eos import density
from sphfem.fluid.packing import pack
from sphfem.fluid.setup import (
    box_walls,
    droplet_packing,
    hydrostatic_density,
    lattice,
    make_particles,
)
from sphfem.particles import ParticleKind
from sphfem.validation import CaseResult, Criterion, Run, Timer, register, relative_errors

SUPPORT = 3.0
LAYERS = 3


# ----------------------------------------------------------------------------- poiseuille


def poiseuille_series(y, t, L, nu, F, terms: int = 200):
    """Start-up Poiseuille flow between plates at y = 0 and L driven by body force F (Morris
    et al. 1997, eq. 21): u = F/(2 nu) y (L - y) - sum_n 4 F L^2/(nu pi^3 (2n+1)^3)
    sin(pi y (2n+1)/L) exp(-(2n+1)^2 pi^2 nu t / L^2)."""
    y = np.asarray(y, float)
    u = F / (2 * nu) * y * (L - y)
    for n in range(terms):
        k = 2 * n + 1
        u -= (4 * F * L**2 / (nu * math.pi**3 * k**3) * np.sin(math.pi * y * k / L)
              * math.exp(-(k**2) * math.pi**2 * nu * t / L**2))
    return u


def channel(n_across: int, L: float, rho0: float, Lx: float | None = None):
    """Plane channel 0 < y < L, periodic in x: a cell-centred fluid lattice of ``n_across``
    particles across L and LAYERS wall layers on each side; the periodic length ``Lx``
    (default max(L, 8 dx), > 2 list radii) is rounded up to whole spacings.  Returns
    (particles, lo, hi, period)."""
    dx = L / n_across
    Lx = max(L, 8 * SUPPORT * dx / 3.0) if Lx is None else Lx  # > 2 list radii
    Lx = dx * math.ceil(Lx / dx)
    xf = lattice([0.0, 0.0], [Lx, L], dx)
    xw_lo = lattice([0.0, -LAYERS * dx], [Lx, 0.0], dx)
    xw_hi = lattice([0.0, L], [Lx, L + LAYERS * dx], dx)
    ps = make_particles(xf, np.concatenate([xw_lo, xw_hi]), dx, rho0)
    lo = [0.0, -(LAYERS + 1) * dx]
    hi = [Lx, L + (LAYERS + 1) * dx]
    return ps, lo, hi, [Lx, 0.0]


def run_poiseuille(n_across: int, t_over_tnu=(0.5,), L: float = 1e-3, nu: float = 1e-6,
                   F: float = 2e-4, rho0: float = 1000.0, **fluid):
    """One channel run with ``n_across`` particles across L, sampled at the times
    ``t_over_tnu`` (in units of L^2/nu, ascending); returns (profiles, solver) with
    ``profiles[k] = (t, y, u)`` of the fluid particles at the k-th time.  ``fluid``: further
    :class:`FluidParams` (e.g. ``viscosity="morris"``)."""
    ps, lo, hi, period = channel(n_across, L, rho0)
    u_max = F * L**2 / (8 * nu)
    par = FluidParams(rho0=rho0, c0=400 * u_max, mu=nu * rho0, gravity=(F, 0.0), delta=0.1,
                      **fluid)
    s = FluidSolver(ps, SUPPORT * L / n_across, lo, hi, period=period, params=par)
    profiles = []
    for tt in np.atleast_1d(t_over_tnu):
        s.run(float(tt) * L**2 / nu)
        fl = s.p.kind == ParticleKind.FLUID
        profiles.append((s.t, s.p.x[fl, 1].copy(), s.p.v[fl, 0].copy()))
    return profiles, s


@register("poiseuille")
def poiseuille_case(quick: bool = False) -> CaseResult:
    """Body-force channel flow, periodic in x, no-slip Adami walls: u(y) vs the series,
    during the start-up (t = 0.1 L^2/nu) and near steady state (t = 0.5 L^2/nu)."""
    L, nu, F = 1e-3, 1e-6, 2e-4
    t_up, t_end = 0.1, 0.5
    run_poiseuille(6, (0.01,))  # compile outside the timed runs
    runs = []
    for n in ((10, 20, 30) if quick else (10, 20, 40, 80)):
        with Timer() as tm:
            prof, s = run_poiseuille(n, (t_up, t_end), L, nu, F)
        (t1, y1, u1), (t2, y, u) = prof
        e2, einf = relative_errors(u, poiseuille_series(y, t2, L, nu, F))
        s2, sinf = relative_errors(u1, poiseuille_series(y1, t1, L, nu, F))
        steady = F / (2 * nu) * y * (L - y)
        transient = float(np.abs(poiseuille_series(y1, t1, L, nu, F) - F / (2 * nu) * y1
                                 * (L - y1)).max() / (F * L**2 / (8 * nu)))
        runs.append(Run("morris+adami", L / n / L, int(s.p.n), e2, einf, tm.s,
                        {"steps": s.step_count,
                         "startup_l2": s2, "startup_linf": sinf,
                         "startup_transient_over_umax": transient,
                         "err_vs_steady": relative_errors(u, steady)[0],
                         "max_rho_dev": float(np.abs(s.p.rho[s.p.kind == ParticleKind.FLUID]
                                                     / 1000.0 - 1).max())}))
    errs = [r.error_l2 for r in runs]
    ups = [r.extra["startup_l2"] for r in runs]
    criteria = {
        "finest_l2": Criterion("relative L2 error at t = 0.5 L^2/nu, finest resolution",
                               errs[-1], 0.02),
        "startup_l2": Criterion("relative L2 error at t = 0.1 L^2/nu (start-up, the "
                                "transient is ~40 % of u_max), finest resolution", ups[-1],
                                0.02),
        "decreasing": Criterion("largest ratio err(finer)/err(coarser) at both times "
                                "(< 1: decreasing)",
                                max(b / a for es in (errs, ups)
                                    for a, b in zip(es, es[1:], strict=False)), 1.0),
    }
    notes = [f"L = {L} m, nu = {nu} m^2/s, F = {F} m/s^2, Re = {F * L**3 / (8 * nu**2):.3g}; "
             "compared with the transient series (Morris et al. 1997 eq. 21) during the "
             "start-up at t = 0.1 L^2/nu ('startup' columns; the transient is then ~40 % of "
             "u_max) and at t = 0.5 L^2/nu ('err L2', where the transient is < 1 % of u_max); "
             "'err_vs_steady' is the distance to the steady parabola at t = 0.5 L^2/nu.",
             "c0 = 400 u_max (time step viscous-limited); delta = 0.1; 3 wall layers."]
    return CaseResult("poiseuille", runs, criteria, notes, resolution_label="dx/L",
                      extra_columns={"steps": "steps", "startup_l2": "start-up L2",
                                     "err_vs_steady": "vs steady"})


# ----------------------------------------------------------------------------- hydrostatic


def run_hydrostatic(n_high: int, t_end: float = 2.0, H: float = 1.0, g: float = 9.81,
                    rho0: float = 1000.0, sample_from: float = 1.0, alpha: float = 0.02,
                    ramp: float = 0.5, stats: dict | None = None, packing: bool = True,
                    pack_tol: float = 1e-5):
    """Water column H x H at rest; returns (solver, max speed over t >= sample_from).

    ``packing``: start from the packed arrangement of :func:`sphfem.fluid.packing.pack`
    (relaxed against the walls to max |grad Gamma| R <= ``pack_tol``) instead of the
    Cartesian lattice.  ``stats`` (optional dict) receives the integral measures over the
    same samples: the largest rms fluid speed ``vrms`` [m/s], the largest kinetic energy
    ``ke`` [J/m], and the packing's report ``packing`` (or None) and seconds ``pack_s``.
    """
    dx = H / n_high
    c0 = 10 * math.sqrt(g * H)
    xf = lattice([0.0, 0.0], [H, H], dx)
    xw = box_walls([0.0, 0.0], [H, 1.5 * H], dx, LAYERS)
    m = (LAYERS + 1) * dx
    rep, t0 = None, time.perf_counter()
    if packing:
        xf, rep = pack(xf, xw, dx, SUPPORT * dx, [-m, -m], [H + m, 1.5 * H],
                       iterations=50_000, tol=pack_tol)
    pack_s = time.perf_counter() - t0
    rhof = hydrostatic_density(H - xf[:, 1], rho0, c0, g) if not ramp else rho0
    ps = make_particles(xf, xw, dx, rho0, rhof)
    par = FluidParams(rho0=rho0, c0=c0, mu=1e-3, gravity=(0.0, -g), alpha=alpha,
                      gravity_ramp=ramp)
    s = FluidSolver(ps, SUPPORT * dx, [-m, -m], [H + m, 1.5 * H], params=par)
    out = {"vmax": 0.0, "vrms": 0.0, "ke": 0.0}

    def sample(sv):
        if sv.t >= sample_from * (1 - 1e-9):
            fl = sv.p.kind == ParticleKind.FLUID
            v2 = (sv.p.v[fl] ** 2).sum(axis=1)
            out["vmax"] = max(out["vmax"], float(np.sqrt(v2.max())))
            out["vrms"] = max(out["vrms"], float(np.sqrt(v2.mean())))
            out["ke"] = max(out["ke"], float(0.5 * (sv.p.m[fl] * v2).sum()))

    s.run(t_end, callback=sample, every=0.05)
    if stats is not None:
        stats.update(vrms=out["vrms"], ke=out["ke"], packing=rep, pack_s=pack_s)
    return s, out["vmax"]


#: finest resolution (particles per H) of the full hydrostatic run
HYDROSTATIC_FULL = (20, 40, 80)


def extrapolated_growth(n, values, n_target) -> float:
    """``values[-1]`` carried from resolution ``n[-1]`` to ``n_target`` with the growth
    observed between the two finest runs, values ~ n^s (no credit for a decrease:
    s >= 0).  Equal to ``values[-1]`` when ``n[-1] == n_target``."""
    s = math.log(values[-1] / values[-2]) / math.log(n[-1] / n[-2]) if len(n) > 1 else 0.0
    return values[-1] * (n_target / n[-1]) ** max(s, 0.0)


@register("hydrostatic")
def hydrostatic_case(quick: bool = False) -> CaseResult:
    """2D water column at rest for 2 s: pressure vs rho g depth, spurious speed."""
    H, g, rho0 = 1.0, 9.81, 1000.0
    run_hydrostatic(6, 0.01)  # compile
    runs = []
    ns = (20, 30) if quick else HYDROSTATIC_FULL
    for n in ns:
        st: dict = {}
        with Timer() as tm:
            s, vmax = run_hydrostatic(n, 2.0, H, g, rho0, stats=st)
        ps = s.p
        fl = ps.kind == ParticleKind.FLUID
        # depth below the free surface, whose height follows from the mass per column
        p_ex = rho0 * g * (H - ps.x[fl, 1])
        e2, einf = relative_errors(ps.p[fl], p_ex)
        wall = ps.kind == ParticleKind.WALL
        bottom = wall & (ps.x[:, 1] < 0) & (ps.x[:, 1] > -H / n) & (ps.x[:, 0] > 0.25 * H) \
            & (ps.x[:, 0] < 0.75 * H)
        p_bottom = float(ps.p[bottom].mean())
        rep = st["packing"]
        runs.append(Run("packed+adami", 1.0 / n, int(ps.n), e2, einf, tm.s,
                        {"steps": s.step_count, "vmax_over_sqrt_gH": vmax / math.sqrt(g * H),
                         "vrms_over_sqrt_gH": st["vrms"] / math.sqrt(g * H),
                         "ke_over_MgH": st["ke"] / (float(ps.m[fl].sum()) * g * H),
                         "wall_p_over_rho_g_H": p_bottom / (rho0 * g * (H + 0.5 / n * H)),
                         "pack_s": st["pack_s"],
                         "packing": rep.to_dict() if rep is not None else None}))
    fin = runs[-1]
    vm = [r.extra["vmax_over_sqrt_gH"] for r in runs]
    n_full = HYDROSTATIC_FULL[-1]
    criteria = {
        "pressure_l2": Criterion("relative L2 error of p vs rho0 g depth (finest)",
                                 fin.error_l2, 0.02),
        "spurious_speed": Criterion("max speed / sqrt(g H) over t in [1, 2] s (finest)",
                                    vm[-1], 0.01),
        "spurious_speed_at_full": Criterion(
            f"max speed / sqrt(g H) carried to dx = H/{n_full} with its growth between the "
            "two finest runs (no credit for a decrease; = 'spurious_speed' in the full run)",
            extrapolated_growth(ns, vm, n_full), 0.01),
        "wall_pressure": Criterion("|bottom wall pressure / rho0 g depth - 1| (finest)",
                                   abs(fin.extra["wall_p_over_rho_g_H"] - 1.0), 0.02),
        "packed": Criterion("largest packing residual max |grad Gamma| R (tolerance 1e-5)",
                            max(r.extra["packing"]["residual"] for r in runs), 1e-5),
    }
    notes = ["H = 1 m, square tank, c0 = 10 sqrt(g H), mu = 1e-3 Pa s, delta = 0.1, artificial "
             "viscosity alpha = 0.02; the column starts at rho0 and gravity is ramped smoothly "
             "over the first 0.5 s (a hydrostatic start excites an undamped acoustic mode of "
             "~1-3 % pressure amplitude); 2 s of physical time in all; the depth is measured "
             "from the initial free surface y = H; pressures are instantaneous values at "
             "t = 2 s (a residual acoustic oscillation of ~1 % remains; its velocity "
             "amplitude 0.01 g H / c0 = 0.001 sqrt(g H) is the floor of vrms).",
             "Start: the particle packing of sphfem.fluid.packing (Colagrossi et al. 2012, "
             "CPC 183; the kernel energy minimised by FIRE against the fixed wall particles "
             "and the fluid lattice's empty sites above the free surface) from the lattice "
             "with a seeded 0.1 dx random displacement, to max |grad Gamma| R <= 1e-5; "
             "'wall s' includes it ('pack_s').  From the Cartesian lattice instead the "
             "column resettles under the hydrostatic compression by column-wise slip bands "
             "seeded at the side walls, growing with the particle count: max speed 0.0058, "
             "0.0097, 0.0159 sqrt(gH) at H/20, H/40, H/80 (criterion failed at H/80).",
             "spurious_speed_at_full: a quick run must not pass on a speed that grows with "
             "refinement: its finest value is carried to H/80 with the observed growth.",
             "wall_p: mean pressure of the first wall layer (y = -dx/2) in the middle half of "
             "the bottom, vs rho0 g (H + dx/2).",
             "vrms, KE: largest rms fluid speed and kinetic energy / (M g H) over the samples of "
             "t in [1, 2] s (every 0.05 s)."]
    return CaseResult("hydrostatic", runs, criteria, notes, resolution_label="dx/H",
                      extra_columns={"steps": "steps", "vmax_over_sqrt_gH": "vmax/sqrt(gH)",
                                     "vrms_over_sqrt_gH": "vrms/sqrt(gH)",
                                     "ke_over_MgH": "KE/(MgH)",
                                     "wall_p_over_rho_g_H": "wall p/ref",
                                     "pack_s": "pack s"})


# ----------------------------------------------------------------------------- dam break

#: Koshizuka & Oka (1996) front Z = x/a against T = t sqrt(2 g / a), column a x 2a
#: (digitised values as published with PySPH, pysph/examples/db_exp_data.py)
KOSHIZUKA_OKA = np.array([
    [0.0, 1.000], [0.381, 1.111], [0.769, 1.252], [1.153, 1.505], [1.537, 1.892],
    [1.935, 2.241], [2.323, 2.615], [2.719, 3.003], [3.096, 3.624]])
#: Martin & Moyce (1952) n^2 = 2, a = 2.25 in (same source), first points up to Z = 4
MARTIN_MOYCE = np.array([
    [0.832, 1.217], [1.219, 1.474], [1.997, 2.292], [2.547, 2.995], [3.345, 4.134]])


def run_dambreak(n_width: int, T_end: float = 3.2, a: float = 0.146, g: float = 9.81,
                 rho0: float = 1000.0, alpha: float = 0.02):
    """Column a x 2a at the left of a 4a x 3a tank; returns (T, Z, solver)."""
    dx = a / n_width
    c0 = 10 * math.sqrt(g * 2 * a)
    xf = lattice([0.0, 0.0], [a, 2 * a], dx)
    xw = box_walls([0.0, 0.0], [4 * a, 3 * a], dx, LAYERS)
    rhof = hydrostatic_density(2 * a - xf[:, 1], rho0, c0, g)
    ps = make_particles(xf, xw, dx, rho0, rhof)
    par = FluidParams(rho0=rho0, c0=c0, mu=1e-3, gravity=(0.0, -g), alpha=alpha)
    m = (LAYERS + 1) * dx
    s = FluidSolver(ps, SUPPORT * dx, [-m, -m], [4 * a + m, 3 * a + m], params=par)
    scale = math.sqrt(2 * g / a)
    T, Z = [0.0], [1.0]

    def sample(sv):
        fl = sv.p.kind == ParticleKind.FLUID
        T.append(sv.t * scale)
        Z.append((float(sv.p.x[fl, 0].max()) + 0.5 * dx) / a)

    s.run(T_end / scale, callback=sample, every=0.02 / scale)
    return np.array(T), np.array(Z), s


def cauchy_ratio(curves, T_eval) -> float:
    """Self-convergence of front curves {n: (T, Z)} of three resolutions n1 < n2 < n3:
    ||Z_n3 - Z_n2|| / ||Z_n2 - Z_n1|| (L2 over ``T_eval``); < 1 when the difference
    between successive resolutions shrinks (observed order log2(1/ratio) for doubling)."""
    n1, n2, n3 = sorted(curves)[-3:]
    z = {n: np.interp(T_eval, *curves[n]) for n in (n1, n2, n3)}
    d12 = float(np.sqrt(np.mean((z[n2] - z[n1]) ** 2)))
    d23 = float(np.sqrt(np.mean((z[n3] - z[n2]) ** 2)))
    return d23 / d12 if d12 > 0 else math.inf


@register("dambreak")
def dambreak_case(quick: bool = False) -> CaseResult:
    """2D dam break (column a x 2a): surge front vs Koshizuka & Oka / Martin & Moyce, and
    self-convergence of the front curve."""
    run_dambreak(5, 0.05)  # compile
    runs = []
    ritter_ok = 0.0
    curves = {}
    for n in ((20, 30, 40) if quick else (20, 40, 80)):
        with Timer() as tm:
            T, Z, s = run_dambreak(n)
        zi = np.interp(KOSHIZUKA_OKA[:, 0], T, Z)
        e2, einf = relative_errors(zi, KOSHIZUKA_OKA[:, 1])
        zm = np.interp(MARTIN_MOYCE[:, 0], T, Z)
        em = relative_errors(zm, MARTIN_MOYCE[:, 1])[0]
        ritter_ok = max(ritter_ok, float(np.max(Z - (1 + 2 * T))))
        curves[n] = (T, Z)
        runs.append(Run("delta-sph+adami", 1.0 / n, int(s.p.n), e2, einf, tm.s,
                        {"steps": s.step_count, "err_vs_martin_moyce": em,
                         "Z_at_T3": float(np.interp(3.0, T, Z)),
                         "curve_T": T[::5].round(3).tolist(), "curve_Z": Z[::5].round(4).tolist()}))
    T_eval = np.linspace(0.25, 3.0, 12)
    criteria = {
        "ritter_bound": Criterion("max of Z - (1 + 2T) (shallow-water front, must be <= 0)",
                                  ritter_ok, 0.0),
        "self_convergence": Criterion(
            "||Z_finest - Z_middle|| / ||Z_middle - Z_coarsest|| over T in [0.25, 3] "
            "(< 1: the front curve converges; catches an error growing with resolution)",
            cauchy_ratio(curves, T_eval), 1.0),
        "koshizuka_oka": Criterion("relative L2 distance to Koshizuka & Oka (finest)",
                                   runs[-1].error_l2, 0.15),
    }
    notes = ["a = 0.146 m, c0 = 10 sqrt(2 g a), mu = 1e-3 Pa s, delta = 0.1, alpha = 0.02; "
             "Z = (max x of fluid + dx/2)/a, T = t sqrt(2g/a); 'err L2' is the relative "
             "distance to Koshizuka & Oka (1996) at their sample times.",
             "Why the distance to the experiments grows with refinement (7.6, 10.7, 12.1 % at "
             "a/20, a/40, a/80): the artificial viscosity alpha h c0 (h = 1.5 dx) slows the "
             "coarse fronts; the front depends on alpha h, not on dx itself: at the same alpha h "
             "(alpha = 0.005, 0.01, 0.02 at a/20, a/40, a/80) Z(T=3) = 3.915, 3.921, 3.916 "
             "and the distance to Koshizuka & Oka 11.8, 12.1, 12.1 %; at a/20 alpha = 0.02 "
             "gives Z(3) = 3.693 and 7.6 %.  The converging SPH front approaches the "
             "nearly inviscid flow, whose front speed dZ/dT over T in [2, 3] (1.37 at a/80) "
             "exceeds the experiments' (Koshizuka & Oka 0.94, Martin & Moyce 1.14 over "
             "T = 1.2-2.5): gate removal and bottom friction slow the real front; no time "
             "shift reconciles the slopes (best-fit shifts 0.16, 0.22, 0.26 leave 2.9, 3.7, "
             "4.0 %).  The front definition is not the cause: the furthest particle of the "
             "bottom layer (y < 2 dx) gives the same Z.  Hence the accuracy criterion is the "
             "self-convergence of the computed front, and the experiments bound the model "
             "error (<= 15 %).",
             "Self-convergence from a/20 on: the L2 differences of Z over T in [0.25, 3] per "
             "unit 1/n are 2.6, 3.4, 2.8, 3.1 for a/20-a/30, a/30-a/40, a/20-a/40, a/40-a/80 "
             "(first order, as the O(h) artificial viscosity); a/10 is not yet in that range "
             "(ratio 1.31 for a/10, a/20, a/40), so the quick run uses a/20, a/30, a/40.",
             "the curve (T, Z) of every run is in 'extra' of --json."]
    return CaseResult("dambreak", runs, criteria, notes, resolution_label="dx/a",
                      extra_columns={"steps": "steps", "err_vs_martin_moyce": "vs M&M",
                                     "Z_at_T3": "Z(T=3)"})


# ----------------------------------------------------------------------------- droplet


def rayleigh_period(dim: int, sigma: float, rho: float, R: float, l: int = 2) -> float:
    """Period of mode l of an inviscid droplet: omega^2 = l(l-1)(l+2) sigma/(rho R^3) (3D,
    Rayleigh 1879), (l^3 - l) sigma/(rho R^3) (2D)."""
    k = (l**3 - l) if dim == 2 else l * (l - 1) * (l + 2)
    return 2 * math.pi / math.sqrt(k * sigma / (rho * R**3))


def outermost_particles(x: np.ndarray, dx: float):
    """The outermost particle of each angular bin (width ~1.5 dx on the outer radius) about
    the centroid of a 2D particle set: (their indices, the positions relative to the
    centroid ``d``, radii ``r`` and angles ``th`` of all particles)."""
    d = x - x.mean(0)
    r = np.hypot(d[:, 0], d[:, 1])
    th = np.arctan2(d[:, 1], d[:, 0])
    M = max(8, int(2 * math.pi * r.max() / (1.5 * dx)))
    b = ((th + math.pi) / (2 * math.pi) * M).astype(int) % M
    best = np.full(M, -1)
    for k in np.argsort(r):  # ascending radius: the last write per bin is the outermost
        best[b[k]] = k
    return best[best >= 0], d, r, th


def surface_ripple(x: np.ndarray, dx: float, lmax: int = 4) -> float:
    """Particle-scale roughness of a 2D drop's surface [units of dx]: the radii r_k(theta_k)
    of the outermost particles (:func:`outermost_particles`); the rms of r_k minus its
    least-squares Fourier series up to mode ``lmax`` (the drop's shape modes: l = 2 and its
    nonlinear harmonics; l = 1, 3 from a slightly off centroid).  0 for any smooth shape; a
    ring of particles gives ~0.01."""
    idx, _, r, th = outermost_particles(x, dx)
    rm, tm = r[idx], th[idx]
    A = np.column_stack([np.ones_like(tm)] + [f(lm * tm) for lm in range(1, lmax + 1)
                                             for f in (np.cos, np.sin)])
    coef, *_ = np.linalg.lstsq(A, rm, rcond=None)
    return float(np.sqrt(np.mean((rm - A @ coef) ** 2)) / dx)


def _zero_crossings(t, D):
    z = []
    for k in range(1, len(D) - 1):
        if D[k] != 0 and D[k] * D[k + 1] < 0:
            z.append(t[k] - D[k] * (t[k + 1] - t[k]) / (D[k + 1] - D[k]))
    return np.array(z)


def droplet_c0(dim: int, sigma: float, rho: float, Rd: float, v_max: float,
               p_max: float | None = None, h: float | None = None) -> float:
    """Artificial speed of sound of the droplet runs: the usual WCSPH rules c0 >= 10 |v|max
    and a density variation <= 1 % under the largest pressure of the model, p_max <= 0.01
    rho c0^2 (default p_max: the Laplace pressure (dim - 1) sigma / Rd), and, given the
    smoothing length ``h``, c0 >= the capillary wave speed sqrt(2 pi sigma/(rho h)) (below
    it particle-scale surface ripples grow, see :mod:`sphfem.fluid.surface_tension_csf`)."""
    from sphfem.fluid.surface_tension_csf import capillary_wave_speed

    if p_max is None:
        p_max = (dim - 1) * sigma / Rd
    c_cap = capillary_wave_speed(sigma, rho, h) if h else 0.0
    return max(10.0 * v_max, math.sqrt(100.0 * p_max / rho), c_cap)


def droplet_pressures(model: str, dim: int, sigma: float, Rd: float, R: float,
                      rho0: float = 1000.0, dx: float | None = None, fluid: dict | None = None):
    """(start pressure, largest pressure) [Pa] of a drop at rest under ``model``: the
    Laplace pressure, plus for "akinci" the cohesion's internal (virial) pressure, which
    the EOS balances in the bulk (:func:`sphfem.fluid.surface_tension_akinci2013.
    akinci_c0_pressure`, of order sigma / R_kernel)."""
    p_L = (dim - 1) * sigma / Rd
    if model == "akinci":
        from sphfem.fluid import surface_tension_akinci2013 as ak
        share = ((fluid or {}).get("st_params") or {}).get("akinci_curvature",
                                                            ak.CURVATURE_DEFAULT)
        p = ak.akinci_c0_pressure(sigma, rho0, R, dx or R / SUPPORT, dim, Rd, share)
        return p, p
    return p_L, p_L


def run_droplet(dim: int, n_radius: int, model: str = "csf", periods: float = 1.6,
                eps: float = 0.1, Rd: float = 1e-3, rho0: float = 1000.0,
                sigma: float = 0.072, mu: float = 1e-3, c0: float | None = None,
                alpha: float = 0.02, fluid: dict | None = None, relax: float = 0.0):
    """A disc / sphere of radius Rd (concentric rings / shells of n_radius layers,
    :func:`droplet_packing`), zero gravity, started at the density of the Laplace pressure
    (dim - 1) sigma / Rd and given the l = 2 velocity field of Rayleigh's mode (2D:
    v = V0 (x, -y)/Rd; 3D: v = V0 (-x/2, -y/2, z)/Rd, divergence-free) with V0 = eps omega
    Rd.  The shape moment D = <x^2 - y^2> (3D: <z^2 - (x^2 + y^2)/2>) then oscillates as
    sin(omega t); the period is twice the mean spacing of its zero crossings.  c0 from
    :func:`droplet_c0` with :func:`droplet_pressures` unless given; ``fluid``: further
    :class:`FluidParams` keys (e.g. ``st_params``).  ``relax`` > 0: first ``relax``
    Rayleigh periods at rest under the model (velocities zeroed every T/400, kinetic
    damping), so that the mode starts from the model's own equilibrium.  The surface ripple
    (:func:`surface_ripple`) is sampled with D; ``extra`` holds its largest value over the
    first and over the last third of the run.

    Returns (period or nan, Rayleigh period, solver, status message, D / max |D|, extra).
    """
    from sphfem.simulation import SimulationStopped

    dx = Rd / n_radius
    xf = droplet_packing(dim, Rd, dx)
    T = rayleigh_period(dim, sigma, rho0, Rd)
    V0 = eps * 2 * math.pi / T * Rd
    p_start, p_max = droplet_pressures(model, dim, sigma, Rd, SUPPORT * dx, rho0, dx, fluid)
    if c0 is None:
        c0 = droplet_c0(dim, sigma, rho0, Rd, V0, p_max, 0.5 * SUPPORT * dx)
    rho = density(p_start, rho0, c0, 7.0)
    ps = make_particles(xf, None, dx, rho0, np.full(len(xf), rho))
    vol = math.pi * Rd**2 if dim == 2 else 4.0 / 3.0 * math.pi * Rd**3
    ps.m[:] = rho * vol / len(xf)
    ps.add_field("v", dim)

    def mode(x):
        if dim == 2:
            return V0 * np.column_stack([x[:, 0], -x[:, 1]]) / Rd
        return V0 * x * np.array([-0.5, -0.5, 1.0]) / Rd

    if relax <= 0:
        ps.v[:] = mode(xf)
    kw = {"delta": 0.1, "rho_ratio_band": (0.5, 2.0), **(fluid or {})}
    par = FluidParams(rho0=rho0, c0=c0, mu=mu, alpha=alpha, gravity=(0.0,) * dim,
                      surface_tension=model, sigma=sigma, **kw)
    s = FluidSolver(ps, SUPPORT * dx, [-2 * Rd] * dim, [2 * Rd] * dim, params=par)
    msg = "completed"
    if relax > 0:
        try:
            s.run(relax * T, callback=lambda sv: sv.p.v.fill(0.0), every=T / 400)
        except SimulationStopped as e:
            msg = "relaxation: " + str(e)
        s.p.v[:] = mode(s.p.x - s.p.x.mean(0))
        s.t = 0.0
        s.evaluate()

    def shape(x):
        x = x - x.mean(0)
        return (np.mean(x[:, 0] ** 2 - x[:, 1] ** 2) if dim == 2
                else np.mean(x[:, 2] ** 2 - 0.5 * (x[:, 0] ** 2 + x[:, 1] ** 2)))

    D0 = shape(s.p.x)
    ts, Ds, rip = [0.0], [0.0], [surface_ripple(s.p.x, dx) if dim == 2 else float("nan")]

    def sample(sv):
        ts.append(sv.t)
        Ds.append(shape(sv.p.x) - D0)
        rip.append(surface_ripple(sv.p.x, dx) if dim == 2 else float("nan"))

    if msg == "completed":
        try:
            s.run(periods * T, callback=sample, every=T / 100)
        except SimulationStopped as e:
            msg = str(e)
    z = _zero_crossings(np.array(ts), np.array(Ds))
    Tm = 2 * float(np.mean(np.diff(z))) if len(z) >= 2 else float("nan")
    Dn = np.array(Ds) / (max(abs(np.array(Ds)).max(), 1e-300))
    P = (s.p.m[:, None] * s.p.v).sum(0)
    extra = {"c0": c0, "zero_crossings_over_T": (z / T).round(3).tolist(),
             "com_drift_over_R": float(np.abs(s.p.x.mean(0)).max() / Rd),
             "momentum_over_M_V0": float(np.abs(P).max() / (s.p.m.sum() * V0)),
             "Oh": mu / math.sqrt(rho0 * sigma * Rd)}
    k = max(1, len(rip) // 3)
    extra["ripple_early_over_dx"] = float(np.max(rip[:k]))
    extra["ripple_late_over_dx"] = float(np.max(rip[-k:]))
    return Tm, T, s, msg, Dn, extra


#: relaxation at rest (Rayleigh periods) of the Akinci runs before the mode is imposed
AKINCI_RELAX = 0.3
#: largest surface ripple (rms radial deviation from the l <= 4 shape) accepted [dx]
RIPPLE_MAX = 0.25


def _ripple_growth(r: Run) -> float:
    """Late ripple minus 1.5 x the early one (+ 0.02 dx of sampling noise): <= 0 when the
    surface ripple does not grow over the run."""
    return r.extra["ripple_late_over_dx"] - 1.5 * r.extra["ripple_early_over_dx"] - 0.02


@register("droplet-oscillation")
def droplet_case(quick: bool = False) -> CaseResult:
    """2D and 3D droplets in mode l = 2, zero gravity: period vs Rayleigh (CSF 10 %, Akinci
    5 %) and the surface ripple (2D: bounded; CSF: not growing)."""
    run_droplet(2, 4, "csf", periods=0.05)  # compile
    plan = [(2, n, "csf") for n in ((10, 20) if quick else (10, 20, 30, 40))]
    plan += [(3, n, "csf") for n in ((8,) if quick else (8, 12))]
    plan += [(2, n, "akinci") for n in ((10, 20) if quick else (10, 20, 30))]
    if not quick:  # the IIF model, reported (not calibrated to pass)
        plan += [(2, 20, "iif"), (3, 8, "iif")]
    runs = []
    for dim, n, model in plan:
        relax = AKINCI_RELAX if model == "akinci" else 0.0
        # Akinci: no density diffusion (it relaxes the surface layers' pressure step that
        # holds the curvature forces: ripples grow; sphfem.fluid.surface_tension_akinci2013)
        fluid = {"delta": 0.0} if model == "akinci" else None
        with Timer() as tm:
            Tm, T, s, msg, Dn, extra = run_droplet(dim, n, model, relax=relax, fluid=fluid)
        err = abs(Tm / T - 1) if np.isfinite(Tm) else float("nan")
        runs.append(Run(f"{model} {dim}D", 1.0 / n, int(s.p.n), err, err, tm.s,
                        {"steps": s.step_count, "period_s": Tm, "rayleigh_s": T,
                         "D_final_over_max": float(Dn[-1]),
                         "D_min_over_max": float(Dn.min()), "status": msg, **extra}))
    crit = {}

    def worst(rs):
        return max((r.error_l2 if np.isfinite(r.error_l2) else math.inf) for r in rs)

    for dim in (2, 3):
        rs = [r for r in runs if r.variant == f"csf {dim}D"]
        crit[f"csf_{dim}d_period"] = Criterion(
            f"largest |T/T_Rayleigh - 1| of the CSF model (recommended), {dim}D, all "
            "resolutions", worst(rs), 0.10)
    ak = [r for r in runs if r.variant == "akinci 2D"]
    crit["akinci_2d_period"] = Criterion(
        "|T/T_Rayleigh - 1| of the Akinci model, 2D, finest resolution", worst(ak[-1:]), 0.05)
    crit["akinci_2d_converging"] = Criterion(
        "Akinci 2D: resolutions whose |T/T_Rayleigh - 1| is not below the coarser one's",
        sum(not b.error_l2 < a.error_l2 for a, b in zip(ak, ak[1:], strict=False)), 0)
    flat = [r for r in runs if r.variant in ("csf 2D", "akinci 2D")]
    crit["ripple_bounded"] = Criterion(
        "largest surface ripple over the last third of the run [dx], CSF and Akinci 2D",
        max(r.extra["ripple_late_over_dx"] for r in flat), RIPPLE_MAX)
    crit["ripple_not_growing"] = Criterion(
        "largest (late ripple - 1.5 early ripple - 0.02 dx), CSF and Akinci 2D (> 0: grows)",
        max(_ripple_growth(r) for r in flat), 0.0)
    notes = ["R = 1 mm, rho = 1000 kg/m^3, sigma = 0.072 N/m, mu = 1e-3 Pa s "
             "(Ohnesorge 0.0037: the period is the inviscid one, Lamb's viscous correction "
             "is < 0.01 %), c0 = max(10 V0, sqrt(100 p_max/rho), sqrt(2 pi sigma/(rho h))) "
             "(1 % density change under the model's largest pressure p_max: the Laplace "
             "pressure, for Akinci with a cohesion also its internal pressure; the capillary "
             "wave speed at h = R_kernel/2: below it particle-scale ripples grow, see "
             "sphfem.fluid.surface_tension_csf), delta = 0.1, artificial viscosity alpha = "
             "0.02, R_kernel = 3 dx.  Ring / shell packing started at the Laplace density, "
             "l = 2 velocity perturbation of amplitude eps = 0.1 of R; 1.6 Rayleigh periods; "
             "period = 2 x mean zero-crossing spacing of the shape moment D.",
             f"Akinci rows: first {AKINCI_RELAX} Rayleigh periods at rest (velocities zeroed "
             "every T/400) so that the mode starts from the model's own equilibrium; default "
             "share of the curvature term (1, no cohesion: with the cohesion's pair potential "
             "the lattice is elastic and the period was 0.39-0.45 T_Rayleigh), constants from "
             "hexagonal-lattice sums of the flat-interface tension, curvature pairs weighted "
             "by V_j W_ij (sphfem.fluid.surface_tension_akinci2013; with the paper's equal "
             "weights the tension depends on the particle arrangement and the period was "
             "1.07 T_Rayleigh with hexagonal, 0.89 with square-lattice constants).",
             "Akinci rows run with delta = 0: the density diffusion relaxes the pressure step "
             "of the surface layers that holds the curvature forces; with delta = 0.1 the "
             "ripple grew from 0.006 to ~0.10 dx within 1.2 periods at R/dx = 20.  Their "
             "curvature constant holds sigma under the SPH pressure (sph_curvature_tension): "
             "period 1.056 / 1.036 / 1.024 T_Rayleigh at R/dx 10 / 20 / 30 (measured, 2 "
             "periods), hence the criterion at the finest resolution plus convergence.",
             "Surface ripple (2D): rms deviation [dx] of the outermost particle per angular bin "
             "from the drop's Fourier shape up to l = 4 (sphfem.validation.fluid."
             "surface_ripple), largest value over the first ('early') and last ('late') third "
             "of the samples; before the capillary-speed rule the CSF run at R/dx = 40 grew "
             "from 0.01 to > 1 dx between 1.2 and 1.6 periods.",
             "IIF rows (eq. 2.78, calibrated from sigma) are reported variants ('status' in "
             "--json): the 2D run stops on the speed guard, the 3D droplet never oscillates "
             "through the sphere (elasto-plastic pair-force lattice).",
             "'com_drift_over_R' and 'momentum_over_M_V0' measure the CSF's lack of exact "
             "momentum conservation (0 for the pairwise IIF / Akinci forces)."]
    return CaseResult("droplet-oscillation", runs, criteria=crit, notes=notes,
                      resolution_label="dx/R",
                      extra_columns={"steps": "steps", "period_s": "T sph",
                                     "rayleigh_s": "T Rayleigh",
                                     "D_min_over_max": "Dmin/Dmax",
                                     "ripple_late_over_dx": "ripple/dx"})
