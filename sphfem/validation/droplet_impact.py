"""Validation case ``droplet-impact``: the axisymmetric droplet job converged (issue 16).

The scene is the packaged axisymmetric droplet impact (``sphfem/scenes/droplet_impact_
axisymmetric.toml``: water D = 0.1 mm at 100 C onto alumina at 20 C, fluid + ring heat +
fem-contact substrate heat + fem-axisymmetric stress), run at each impact speed V (c0 =
10 V, so the Mach number and the steps per t_c stay fixed, or the capillary bound of the
level where that is larger: :func:`sound_speed_for`) at three spacings dx (every
resolution length scaled together, :func:`sphfem.resolution.scaled_resolution`; the SPH
wall kept one kernel support deep): the finest puts three particles across the residual
film of the spreading (:func:`levels_for`), and the runs end past the maximum spreading
(:func:`t_end_for`: 4 t_c at 10 m/s, 6 at 30 and 50).  This is expensive on purpose
(at 50 m/s D/dx 128 / 181 / 256, hours of CPU each): below that resolution the lamella is
one or two particles thick and its figures are decided by the spacing.
``examples/droplet_impact/convergence.py SPEED --out DIR`` runs one speed resumably.
For each speed the four figures a user reads are extracted from ``summary.json``:

* ``spread``: the maximum spreading ratio D_max / D (the wetted diameter of the fluid's main
  body, :func:`sphfem.fluid.spreading.body_contact_diameter`: shed and stray rings do not
  count; the mass broken off the body is reported);
* ``heat``: the heat into the substrate by the end time [J];
* ``T_impact``: the impact point's surface temperature rise, time-averaged over the window
  [t_contact + 0.1 t_c, t_contact + 2 t_c] [K];
* ``vm_peak``: the peak von Mises stress in the substrate [Pa], with its time and place.

Each figure gets an observed order, a Richardson limit and a GCI error bar
(:mod:`sphfem.validation.richardson`).  Criteria (each can fail):

* converged: the finest level lies within 10 % of the Richardson limit, the error bar
  included (|f_h - f_0| + GCI |f_h| <= 0.1 |f_0|); an oscillatory or diverging sequence
  gets a 3x-spread error bar and fails unless the spread is small; an observed order above
  the formal :data:`FORMAL_ORDER` is capped to it (Roache's rule: the coarse level is ahead
  of the asymptotic range, the estimate comes from the two finest), and so is a sequence
  read as oscillatory or diverging whose finest step lies within the ensembles' sampling
  noise (the data cannot classify it).  The spread and the heat
  are chaotic: a perturbation of 1e-3 dx moves one run's by ~5 % (the rim's breakup, the
  contact line's pauses), so single runs cannot show them converged to 10 %.  The full case
  therefore runs an ensemble per level (:data:`MEMBERS_FULL` members, :func:`scene_at`'s
  ``member``: the droplet jittered by :data:`ENSEMBLE_JITTER` dx with seed k), takes the
  Richardson estimate of the level means (:func:`ensemble`) and adds the means' sampling
  uncertainty to the distance: u = t_95 se (1 + q, q) propagated through f_0 = f_3 +
  q (f_3 - f_2), q = 1 / (r^p - 1), se from the scatter pooled over the levels
  (:func:`ensemble_uncertainty`);
* contact temperature: at the finest level the impact-point rise stays within 10 % of the
  rise of the strained contact (:mod:`sphfem.heat.strained_contact`: the 1D stagnation-line
  layer w = -a z on the conducting substrate, solved by finite volumes, independent of the
  SPH/FEM path) driven by the run's own strain history a(t) at the impact point, over the
  window above.  The static contact of two semi-infinite bodies, (e_f T_f + e_s T_s) /
  (e_f + e_s) with e = sqrt(k rho c) (Carslaw & Jaeger 1959, sec. 2.15), holds only while
  a t << 1: the spreading flow holds the fluid layer thin, so the impact point warms above
  it (1.2x at a t = 1, 1.7x at a t = 4 for constant a); its ratio is reported;
* conservation: heat lost by the fluid = heat gained by the substrate to 1e-9;
* the maximum spreading is reached before the end (the run goes past it);
* independent physics of the spreading, at the finest level: (a) the early diameter of
  the lamella's root against Wagner's law D_r / D = sqrt(6 t / t_c) (the turnover point of
  a sphere meeting a plane in potential flow, sqrt(3 R V t); Wagner 1932, Riboux &
  Josserand 2014, who measured the root), its mean ratio over [0.1, 0.3] t_c after the
  surfaces touch within 10 % (the root: :func:`sphfem.fluid.spreading.lamella_root_radius`,
  where the wall-attached fluid becomes thinner than R0 / 10; the contact diameter is the
  tip of the sheet ejected ahead of the root, 1.12-1.27 x Wagner at D/dx 64-181 at 10 m/s,
  reported); (b) the lamella's thickness at the axis against the inviscid law h(0, t) =
  0.39 D / (tau + 0.25)^2 (Roisman, Berberovic & Tropea 2009; tau in t_c from the
  touching; :func:`sphfem.fluid.spreading.lamella_thickness_inviscid`), its mean ratio
  over [0.75, 1.25] t_c within 10 % (before that the body is still turning into the
  lamella, after it the viscous layer holds the film above the law); (c) D_max / D inside the
  band of the published correlations (:func:`sphfem.fluid.spreading.correlation_table` at
  the run's We and Re, contact angle 90 deg: Pasandideh-Fard 1996, Ukiwe & Kwok 2005, Clanet
  2004, Roisman 2009, Laan 2014) widened by 10 % on each side (their own scatter).  The
  lamella's thickness at maximum spreading in particles, 2 D / (3 beta^2 dx) (the droplet's
  volume as a disc), is reported: below ~3 the spreading is decided below the spacing; so is
  the residual film the spreading leaves, h_res = 0.79 D Re^-0.4 (Roisman 2009), in
  particles (the run warns below 3: D/dx >= 3.8 Re^0.4, i.e. 97 / 151 / 185 at 10 / 30 /
  50 m/s for the packaged water droplet).

Quick mode (``validate all --quick``, inside the test suite): 50 m/s only, D/dx = 16, 20,
24 to 0.6 t_c: conservation and the contact temperature are gated, the Richardson figures
reported (the spreading and stress have not settled by then).
"""

from __future__ import annotations

import ast
import json
import math
import tempfile
from importlib import resources
from pathlib import Path

from sphfem.validation import CaseResult, Criterion, Run, Timer, register
from sphfem.validation.richardson import richardson

SCENE = "droplet_impact_axisymmetric.toml"
#: impact speeds of the full case [m/s]
SPEEDS = (10.0, 30.0, 50.0)
#: particles across the droplet diameter: the rungs the full case picks its three levels
#: from (ratio sqrt 2), and the quick case's levels
LADDER = (32, 45, 64, 90, 128, 181, 256, 362)
LEVELS_QUICK = (16, 20, 24)
#: end times in t_c (t_c = D / V from t = 0; contact is ~R / V later)
#: (the full case's per speed: past the maximum spreading, which comes at 2.5 t_c at 10 m/s
#: (D/dx 128) while at 50 m/s the spread still grows at 3.9 t_c (D/dx 64))
T_END_FULL = {10.0: 4.0, 30.0: 6.0, 50.0: 6.0}
T_END_QUICK = 0.6
#: output interval of the case's runs [t_c]; the step is not shortened to land on the output
#: times (``output.exact_times = false``), so a run does not depend on it
OUTPUT_EVERY_TC = 0.1
#: an ensemble's members k > 0 move every droplet ring by up to this many dx at random (the
#: fluid block's ``jitter`` with scene seed k): a perturbation far below the spacing that
#: samples the run-to-run scatter of the chaotic figures (the spread and the heat)
ENSEMBLE_JITTER = 1e-3
#: ensemble members per level of the full case (the quick case runs one)
MEMBERS_FULL = 3
#: figures an ensemble reports by its members' worst value, not their mean (gates of each run)
ENSEMBLE_WORST = ("balance", "T_impact_dev", "T_impact_static", "spread_t_tc")


def t_end_for(speed: float) -> float:
    """The full case's end time at ``speed`` in t_c (:data:`T_END_FULL`; 6 for a speed
    not listed)."""
    return T_END_FULL.get(float(speed), 6.0)
#: window of the impact-point temperature, in t_c after contact
T_WINDOW = (0.1, 2.0)
#: window of the early contact diameter against Wagner's law, in t_c after contact
T_WAGNER = (0.1, 0.3)
TOL_WAGNER = 0.10
#: window of the lamella's thickness at the axis against the inviscid law, t_c after the
#: surfaces touch (after the droplet's body has turned into the lamella, before viscosity
#: holds it: module docstring)
T_LAMELLA = (0.75, 1.25)
TOL_LAMELLA = 0.10
#: the correlations' band is widened by this fraction on each side
TOL_CORRELATIONS = 0.10
TOL_CONVERGED = 0.10
#: the formal order of the discretisation (the Wendland kernel's second-order consistency;
#: the heat and fluid unit cases observe 2.0 and 1.6-2): an observed order above it is
#: capped to it (:func:`sphfem.validation.richardson.richardson`, Roache's rule)
FORMAL_ORDER = 2.0
TOL_CONTACT = 0.10
TOL_BALANCE = 1e-9

FIGURES = {"spread": "max spreading D_max/D", "heat": "heat into substrate [J]",
           "T_impact": "impact-point rise (window mean) [K]", "vm_peak": "peak von Mises [Pa]"}


def base_scene():
    """The packaged scene (a :class:`sphfem.scene.Scene`)."""
    from sphfem.scene import parse_scene_toml

    text = resources.files("sphfem").joinpath("scenes", SCENE).read_text()
    return parse_scene_toml(text, source=f"sphfem/scenes/{SCENE}")


def levels_for(speed: float, scene=None) -> tuple[int, int, int]:
    """The full case's three levels at impact speed ``speed`` [m/s]: the finest is the first
    rung of :data:`LADDER` with at least
    :data:`~sphfem.fluid.spreading.MIN_FILM_PARTICLES` particles across the residual film
    h_res = 0.79 D Re^-0.4 (:func:`~sphfem.fluid.spreading.residual_film`), the other two
    the rungs below it.  Packaged scene: (64, 90, 128) at 10 m/s, (90, 128, 181) at 30,
    (128, 181, 256) at 50.  ``scene``: a :class:`sphfem.scene.Scene` (default: the
    packaged one)."""
    from sphfem.fluid.spreading import MIN_FILM_PARTICLES, residual_film

    d = (scene or base_scene()).to_dict()
    drop = next(b for b in d["blocks"] if b["kind"] == "fluid")
    mat = d["materials"][drop["material"]]
    D = 2.0 * drop["radius"]
    h = residual_film(D, mat["rho0"] * speed * D / mat["mu"])
    for k, n in enumerate(LADDER):
        if k >= 2 and h * n / D >= MIN_FILM_PARTICLES:
            return LADDER[k - 2], LADDER[k - 1], n
    raise ValueError(f"droplet-impact: at {speed:g} m/s the residual film ({h:.3g} m) needs "
                     f"more than D/dx = {LADDER[-1]} for {MIN_FILM_PARTICLES:g} particles")


def sound_speed_for(speed: float, material: dict, d: dict) -> float:
    """c0 of a level [m/s]: 10 x the impact ``speed`` (Mach 0.1), or the capillary bound
    of the level's kernel scale h = R / 2 when that is larger
    (:func:`sphfem.sound_speed.capillary_sound_speed`: low Weber numbers; the 10, 30 and
    50 m/s levels up to D/dx 181 / 256 keep 10 V).  ``material`` and ``d``: the droplet's
    material and the scene dict (its ``sph.dx``, ``sph.support_factor``)."""
    from sphfem.sound_speed import capillary_sound_speed

    c0 = 10.0 * float(speed)
    sigma = material.get("sigma")
    if sigma and d.get("fluid", {}).get("surface_tension", "none") != "none":
        h = 0.5 * d["sph"]["support_factor"] * d["sph"]["dx"]
        c0 = max(c0, float(math.ceil(capillary_sound_speed(sigma, material["rho0"], h))))
    return c0


def scene_at(speed: float, per_diameter: int, t_end_tc: float, *,
             wall_radius: float | None = None, overrides=(), member: int = 0) -> dict:
    """The scene dict at impact speed ``speed`` (c0: :func:`sound_speed_for`), ``per_diameter``
    particles across the droplet, ending at ``t_end_tc`` t_c.  ``wall_radius`` [m] widens
    the SPH wall, the domain and the lateral heat refinement to that radius;
    ``overrides``: ``"section.key=value"`` strings (the value a Python literal, else the
    text), applied last, e.g. ``"fluid.wall_friction=sph"``; ``member`` k > 0: an
    ensemble's member, the droplet's rings jittered by up to :data:`ENSEMBLE_JITTER` dx with
    scene seed k (member 0 is the scene as it is)."""
    from sphfem.resolution import scaled_resolution

    sc = base_scene()
    d0 = sc.to_dict()
    drop = next(b for b in d0["blocks"] if b["kind"] == "fluid")
    dx0 = drop.get("dx") or d0["sph"]["dx"]
    d = scaled_resolution(sc, (2.0 * drop["radius"] / per_diameter) / dx0)
    drop = next(b for b in d["blocks"] if b["kind"] == "fluid")
    v = [0.0] * (len(drop["velocity"]) - 1) + [-float(speed)]
    drop["velocity"] = v
    mat = d["materials"][drop["material"]]
    mat["c0"] = sound_speed_for(speed, mat, d)
    d["time"]["t_end"] = f"{t_end_tc} tc"
    d["output"]["every"] = f"{OUTPUT_EVERY_TC:g} tc"
    # the late spreading is chaotic: landing the steps on the output times would make the
    # output interval a perturbation of the run
    d["output"]["exact_times"] = False
    if member < 0:
        raise ValueError(f"droplet-impact: ensemble member must be >= 0, got {member}")
    if member:
        drop["jitter"] = ENSEMBLE_JITTER
        d["scene"]["seed"] = int(member)
    d["scene"]["name"] = f"droplet_impact_axi_V{speed:g}_D{per_diameter}"
    d["scene"]["description"] = (f"the packaged axisymmetric droplet scene at {speed:g} m/s, "
                                 f"D/dx = {per_diameter}, to {t_end_tc:g} tc")
    # the SPH wall one kernel support deep at every level (the packaged scene's 3 dx): deeper
    # rows have no fluid neighbour (the substrate's heat and stress are the FEM's), and a
    # fixed depth would carry 8 rows at D/dx 64, 24 at 128 (60 % of the particles there)
    wall = next(b for b in d["blocks"] if b["kind"] == "wall")
    wall["lo"][-1] = wall["hi"][-1] - d["sph"]["support_factor"] * d["sph"]["dx"]
    if wall_radius is not None:
        d["domain"]["hi"][0] = wall["hi"][0] = wall_radius
        d["coupling"]["heat"]["lateral"] = [[0.0, wall_radius]]
    return apply_overrides(d, overrides)


def apply_overrides(d: dict, overrides) -> dict:
    """Set ``"section.key=value"`` strings (the value a Python literal, else the text) in
    the scene dict ``d``, in order; a number in the path indexes a list (``"blocks.1.
    sampling=shells"``); returns ``d``."""
    for kv in overrides:
        key, _, text = kv.partition("=")
        try:
            value = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            value = text
        node = d
        *path, last = key.split(".")
        for depth, k in enumerate([*path, last]):
            if isinstance(node, list) and not k.isdigit():
                raise ValueError(f"override {kv!r}: {k!r} indexes a list (expected a number)")
            if depth < len(path):
                node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    return d


def inert_override(kv: str, scene: dict) -> bool:
    """True when the override ``"section.key=value"`` leaves the run of ``scene`` (a
    :func:`scene_at` dict) as it is, so figures run without it stand for a run with it.
    Today one key: ``fluid.bulk_damping_length`` l at or below the fluid's h = support_factor
    dx / 2, since the damper's length is max(h, l) (:class:`sphfem.fluid.axisymmetric.
    AxisymmetricFluid`; ``test_damper_length_floor_scales_the_damping`` shows l <= h
    changes no bit): a length floor set at one level leaves the coarser levels alone."""
    if kv.partition("=")[0].strip() != "fluid.bulk_damping_length":
        return False
    try:  # the value as apply_overrides reads it
        length = float(apply_overrides({}, [kv])["fluid"]["bulk_damping_length"])
    except (ValueError, TypeError, KeyError):
        return False
    sph = scene["sph"]
    dx = min([sph["dx"]] + [b["dx"] for b in scene["blocks"]
                            if b.get("kind") == "fluid" and b.get("dx")])
    return 0.0 <= length <= 0.5 * sph["support_factor"] * dx


def figures(summary: dict, speed: float, diameter: float) -> dict:
    """The four figures (module docstring) and their context from one run's summary."""
    dg = summary["diagnostics"]
    fl, cp = dg["fluid"], dg["coupling"]
    sh = cp["substrate_heat"]
    tc = diameter / speed
    t_contact = cp.get("t_contact_s") or 0.0
    T_s0, T_c = sh["substrate_initial_temperature_K"], sh["ideal_contact_temperature_K"]
    lo, hi = t_contact + T_WINDOW[0] * tc, t_contact + T_WINDOW[1] * tc
    win = [h for h in sh["history"] if lo <= h["t"] <= hi]
    rises = [h["T_impact"] - T_s0 for h in win]
    ideal = T_c - T_s0
    strained = strained_reference(summary, t_contact, win)
    sp = fl["spreading"]
    mat = summary["scene"]["materials"][summary["scene"]["coupling"]["material"]]
    fluid = next(b for b in summary["scene"]["blocks"] if b["kind"] == "fluid")
    dx = float(fluid.get("dx") or summary["scene"]["sph"]["dx"])
    # Wagner's clock starts when the surfaces touch: the coupling's contact is the first
    # pair within the support R, the surfaces (dx / 2 beyond the outer particle centres)
    # meet when the centres are dx apart, (R - dx) / V later
    t_touch = t_contact + (float(summary["scene"]["sph"]["support_factor"]) - 1.0) * dx / speed
    hist_t = sp.get("history_t_s", ())

    def wagner_mean(key):
        """Mean ratio of the history ``key`` (diameter / D) to sqrt(6 t / t_c) over the
        Wagner window (nan when the run has no such history)."""
        rs = [r / math.sqrt(6.0 * (t - t_touch) / tc)
              for t, r in zip(hist_t, sp.get(key) or [math.nan] * len(hist_t), strict=True)
              if T_WAGNER[0] <= (t - t_touch) / tc <= T_WAGNER[1]]
        return sum(rs) / len(rs) if rs else math.nan

    from sphfem.fluid.spreading import lamella_thickness_inviscid

    # the lamella at the axis against the inviscid h = 0.39 D / (tau + 0.25)^2
    lam = [h / float(lamella_thickness_inviscid((t - t_touch) / tc, diameter))
           for t, h in zip(hist_t, sp.get("history_centre_thickness_m")
                           or [math.nan] * len(hist_t), strict=True)
           if T_LAMELLA[0] <= (t - t_touch) / tc <= T_LAMELLA[1]]
    fmat = summary["scene"]["materials"][fluid["material"]]
    from sphfem.fluid.spreading import correlation_table, reynolds, weber

    We = Re = math.nan
    band = [math.nan]
    if fmat.get("sigma") and fmat.get("mu"):  # the correlations need both
        We = weber(fmat["rho0"], speed, diameter, fmat["sigma"])
        Re = reynolds(fmat["rho0"], speed, diameter, fmat["mu"])
        band = list(correlation_table(We, Re, 90.0).values())
    # a surface held at the ideal contact rise over a spot wider than the heated depth is in
    # equal biaxial constraint: s_rr = s_tt = -E alpha dT / (1 - nu), s_zz = 0, so its von
    # Mises stress is E alpha dT / (1 - nu) (the thermal plateau the peak approaches)
    vm_thermal = mat["E"] * mat["alpha"] * ideal / (1.0 - mat["nu"])
    return {
        "vm_thermal": vm_thermal,
        "spread": sp["max_ratio"], "spread_t_tc": sp["max_t_s"] / tc,
        "spread_wall_row": sp.get("max_ratio_wall_row", math.nan),
        "detached_at_max": sp.get("detached_mass_fraction_at_max", math.nan),
        "wagner_ratio": wagner_mean("history_root_ratio"),
        "wagner_tip_ratio": wagner_mean("history_ratio"),
        "lamella_ratio": sum(lam) / len(lam) if lam else math.nan,
        "correlations": (min(band), max(band)), "We": We, "Re": Re,
        "lamella_particles": 2.0 * diameter / (3.0 * sp["max_ratio"] ** 2 * dx),
        "film_particles": fl.get("residual_film", {}).get("particles_across", math.nan),
        "heat": sh["heat_to_substrate_J"], "heat_ideal": sh["ideal_contact_heat_J"],
        "T_impact": sum(rises) / len(rises) if rises else math.nan,
        "T_impact_static": max((abs(r / ideal - 1.0) for r in rises), default=math.nan),
        "T_impact_dev": (max((abs(r / x - 1.0) for r, x in zip(rises, strained, strict=True)),
                             default=math.nan) if strained is not None else math.nan),
        "strain_tc": (sum(h.get("strain_impact", 0.0) for h in win) / len(win) * tc
                      if win else math.nan),
        "T_impact_samples": len(rises),
        "vm_peak": cp["peak_von_mises_Pa"],
        # the impact force: its peak over rho V^2 D^2, and when (t_c after contact)
        "force_peak": (cp.get("peak_normal_force_N", math.nan)
                       / (fmat["rho0"] * speed ** 2 * diameter ** 2)),
        "force_t_tc": (cp.get("peak_normal_force_t_s", math.nan) - t_contact) / tc,
        "vm_t_tc": (cp.get("peak_von_mises_t_after_contact_s") or math.nan) / tc,
        "vm_r_m": cp["peak_von_mises_location_m"][0],
        "vm_z_m": cp["peak_von_mises_location_m"][-1],
        "balance": abs(sh.get("fluid_substrate_residual_rel", math.nan)),
        "mass_kg": fl["mass_kg"], "t_end": summary["t"], "tc": tc,
        "steps": summary["steps"], "particles": summary["particles"]["total"],
        "wall_s": summary["wall_s"],
    }


def ensemble(members: list[dict]) -> dict:
    """One level's figures from those of its ensemble members (:func:`figures` of each run,
    :func:`scene_at`'s ``member``): the members' mean of every number, their worst (largest)
    of :data:`ENSEMBLE_WORST`, the sum of their wall seconds, other values from the first
    member; for each of :data:`FIGURES` the members' values ``{key}_members`` and sample
    standard deviation ``{key}_sd`` (0 for one member); ``members`` their count."""
    if not members:
        raise ValueError("droplet-impact: an ensemble needs at least one member")
    k = len(members)
    out = dict(members[0])
    for key, v in members[0].items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        # a member read from an older JSON may lack a context figure: nan, not a KeyError
        vals = [float(m.get(key, math.nan)) for m in members]
        out[key] = (max(vals) if key in ENSEMBLE_WORST else sum(vals) if key == "wall_s"
                    else sum(vals) / k)
    for key in FIGURES:
        vals = [float(m[key]) for m in members]
        mean = sum(vals) / k
        out[f"{key}_members"] = vals
        out[f"{key}_sd"] = (math.sqrt(sum((v - mean) ** 2 for v in vals) / (k - 1))
                            if k > 1 else 0.0)
    out["members"] = k
    return out


def ensemble_uncertainty(figs: list[dict], key: str) -> tuple[list[float], float, int]:
    """The standard errors of the level means of ``key`` (``figs``: :func:`ensemble` of each
    level) and the Student t factor of their two-sided 95 % interval.  The run-to-run
    scatter is taken as the same at every level and pooled, s_p^2 = sum_i (K_i - 1) s_i^2 /
    sum_i (K_i - 1) (three members alone give 2 degrees of freedom, t = 4.3), so se_i =
    s_p / sqrt(K_i) and t at sum_i (K_i - 1) degrees of freedom; ([0, ...], 0, 0) when no
    level has more than one member (single runs: no scatter measured)."""
    from scipy.stats import t as student_t

    ks = [int(f.get("members", 1)) for f in figs]
    dof = sum(k - 1 for k in ks)
    if dof == 0:
        return [0.0] * len(figs), 0.0, 0
    var = sum((k - 1) * float(f.get(f"{key}_sd", 0.0)) ** 2
              for k, f in zip(ks, figs, strict=True)) / dof
    sp = math.sqrt(var)
    return [sp / math.sqrt(k) for k in ks], float(student_t.ppf(0.975, dof)), dof


def strained_reference(summary: dict, t_contact: float, window: list[dict]):
    """The strained-contact rise [K] (:func:`sphfem.heat.strained_contact.strained_contact_fv`)
    at the ``window`` samples of the run's impact-point history, driven by the run's own
    strain history (linear in time between samples; None when the run has none: a
    stagnant-layer run)."""
    import numpy as np

    from sphfem.heat.strained_contact import strained_contact_fv

    sh = summary["diagnostics"]["coupling"]["substrate_heat"]
    hist = sh["history"]
    if not window or any("strain_impact" not in h for h in hist):
        return None
    mats = summary["scene"]["materials"]
    fluid = next(b for b in summary["scene"]["blocks"] if b["kind"] == "fluid")["material"]
    solid = summary["scene"]["coupling"]["material"]
    props = [tuple(float(mats[m][k]) for k in ("k", "rho0", "c")) for m in (fluid, solid)]
    t = np.array([h["t"] for h in hist])
    a = np.array([h["strain_impact"] for h in hist])
    tw = np.array([h["t"] for h in window]) - t_contact
    T_s0 = sh["substrate_initial_temperature_K"]

    def strain(x):
        return float(np.interp(x + t_contact, t, a))

    velocity = None
    if summary["scene"]["coupling"]["heat"].get("layer") == "strained-viscous":
        # the run's closure reads the outer strain through the Homann layer (eq. 3 of
        # sphfem.heat.stagnation_layer): the reference takes the same flow, resolved
        from sphfem.heat.stagnation_layer import outer_strain, stagnation_velocity

        nu = float(mats[fluid]["mu"]) / float(mats[fluid]["rho0"])
        dx = float(summary["scene"]["sph"]["dx"])

        def velocity(z, x):
            a1 = strain(x)
            if a1 <= 0.0:
                return -a1 * z
            a_o, d = (float(v[0]) for v in outer_strain(np.array([a1]), dx, nu, 2))
            return stagnation_velocity(z, a_o, d, 2)

    Ti, _ = strained_contact_fv(strain, tw, sh["fluid_initial_temperature_K"], T_s0, *props,
                                velocity=velocity)
    return list(Ti - T_s0)


def run_one(speed: float, per_diameter: int, t_end_tc: float, out: Path | None = None,
            member: int = 0):
    """Run one level (ensemble ``member``, :func:`scene_at`); returns (figures, wall
    seconds)."""
    from sphfem.api import run
    from sphfem.scene import parse_scene

    d = scene_at(speed, per_diameter, t_end_tc, member=member)
    sc = parse_scene(d, source=f"droplet-impact V={speed:g} D/dx={per_diameter} "
                               f"member {member}")
    drop = next(b for b in d["blocks"] if b["kind"] == "fluid")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(out) if out is not None else Path(tmp) / "run"
        with Timer() as t:
            res = run(sc, folder, overwrite=True)
        summary = json.loads((folder / "summary.json").read_text())
        if res.status != "completed":
            raise RuntimeError(f"droplet-impact V={speed:g} D/dx={per_diameter} member "
                               f"{member}: run {res.status}: {summary.get('message')}")
    return figures(summary, speed, 2.0 * drop["radius"]), t.s


def _one_decimal(v) -> str:
    """``v`` with one decimal, "-" when missing (a level read from an older JSON)."""
    return "-" if v is None else f"{v:.1f}"


def figure_estimate(hs, figs: list[dict], key: str):
    """The Richardson estimate of ``key`` over the levels' figures ``figs`` (ensembles or
    single runs, :func:`ensemble`) at spacings ``hs`` (coarse to fine), with the formal order
    and the ensembles' noise, and the 95 % sampling uncertainty u of its limit: f_0 = f_3 +
    q (f_3 - f_2), q = 1 / (r^p - 1), to first order at the order used (f_0 = f_3 without
    one).  Returns (estimate, u, the levels' standard errors, degrees of freedom)."""
    se, t95, dof = ensemble_uncertainty(figs, key)
    est = richardson(hs, [f[key] for f in figs], formal_order=FORMAL_ORDER,
                     noise=[t95 * e for e in se] if dof else None)
    q = 1.0 / ((hs[-2] / hs[-1]) ** est.order - 1.0) if est.order is not None else 0.0
    return est, t95 * math.hypot((1.0 + q) * se[-1], q * se[-2]), se, dof


def members_needed(est, hs, sd: float, n_levels: int, tol: float = TOL_CONVERGED,
                   most: int = 1000) -> int | None:
    """The members per level K that would bring a figure's ``converged`` criterion under
    ``tol`` with the run-to-run scatter ``sd`` (the pooled standard deviation of one run)
    unchanged: the smallest K with |f_fine - f_0| + error bar + u(K) <= tol |f_0|, u(K) =
    t_{n_levels (K - 1)} sd sqrt((1 + q)^2 + q^2) / sqrt(K) the sampling term of
    :func:`figure_estimate` with K members at every level (the estimate ``est``: its limit,
    finest value, error bar and order kept).  None when the part without the sampling
    already exceeds ``tol`` (no ensemble can pass it) or K would exceed ``most``."""
    from scipy.stats import t as student_t

    room = tol * abs(est.value) - abs(est.finest - est.value) - est.error_bar
    if not room > 0.0:
        return None
    q = 1.0 / ((hs[-2] / hs[-1]) ** est.order - 1.0) if est.order is not None else 0.0
    spread = sd * math.hypot(1.0 + q, q)
    for k in range(2, most + 1):
        if student_t.ppf(0.975, n_levels * (k - 1)) * spread / math.sqrt(k) <= room:
            return k
    return None


def speed_criteria(speed: float, levels, figs: list[dict], quick: bool = False):
    """The criteria (name -> :class:`Criterion`) and notes of one impact speed from the
    figures (:func:`figures`) of its ``levels`` (particles across the droplet, coarse to
    fine); the Richardson figures from all of them (module docstring)."""
    D = figs[-1]["tc"] * speed
    hs = [D / n for n in levels]
    fin = figs[-1]
    tag = f"{speed:g} m/s"
    crit: dict[str, Criterion] = {}
    notes: list[str] = []
    crit[f"{tag} balance"] = Criterion(
        f"{tag}: |heat lost by the fluid / heat gained by the substrate - 1| (all levels)",
        max(f["balance"] for f in figs), TOL_BALANCE)
    crit[f"{tag} contact T"] = Criterion(
        f"{tag}, D/dx={levels[-1]}: max |impact-point rise / strained-contact rise - 1| "
        f"(the run's strain history) over [{T_WINDOW[0]}, {T_WINDOW[1]}] t_c after "
        "contact", fin["T_impact_dev"], TOL_CONTACT)
    ks = [int(f.get("members", 1)) for f in figs]
    for key, label in FIGURES.items():
        est, u, se, dof = figure_estimate(hs, figs, key)
        rel = ((abs(est.finest - est.value) + est.error_bar + u) / abs(est.value)
               if est.value else math.inf)
        order = f"{est.order:.2f}" if est.order is not None else "none"
        scatter = ""
        if dof:
            sd = se[-1] * math.sqrt(ks[-1])
            need = members_needed(est, hs, sd, len(figs))
            scatter = (f"; members {ks}, pooled sd {sd:.3g} ({dof} dof), sampling +- {u:.2g} "
                       f"(95 %); members per level for {TOL_CONVERGED:.0%} at these means "
                       "and scatter: " + (f"{need}" if need else "none suffices"))
        notes.append(f"{tag} {label}: levels {[f'{f[key]:.4g}' for f in figs]}, order "
                     f"{order}, limit {est.value:.4g} +- {est.error_bar:.2g}"
                     f"{' (' + est.note + ')' if est.note else ''}{scatter}")
        if not quick:
            what = ("the means' Richardson limit, error bar and sampling uncertainty "
                    "included" if dof else "the Richardson limit, error bar included")
            crit[f"{tag} {key} converged"] = Criterion(
                f"{tag}: {label} at D/dx={levels[-1]} within {TOL_CONVERGED:.0%} of {what}",
                rel, TOL_CONVERGED)
    if not quick:
        crit[f"{tag} spread max reached"] = Criterion(
            f"{tag}: time of maximum spreading / end time (< 1: the run goes past it)",
            fin["spread_t_tc"] * fin["tc"] / fin["t_end"], 0.98)
        crit[f"{tag} Wagner"] = Criterion(
            f"{tag}, D/dx={levels[-1]}: |mean lamella-root diameter / Wagner's sqrt(6 t / "
            f"t_c) - 1| over [{T_WAGNER[0]}, {T_WAGNER[1]}] t_c after the surfaces touch",
            abs(fin["wagner_ratio"] - 1.0), TOL_WAGNER)
        crit[f"{tag} lamella"] = Criterion(
            f"{tag}, D/dx={levels[-1]}: |mean lamella thickness at the axis / the inviscid "
            f"0.39 D / (tau + 0.25)^2 - 1| over [{T_LAMELLA[0]}, {T_LAMELLA[1]}] t_c after "
            "the surfaces touch (Roisman, Berberovic & Tropea 2009)",
            abs(fin["lamella_ratio"] - 1.0), TOL_LAMELLA)
        lo, hi = fin["correlations"]
        crit[f"{tag} correlations"] = Criterion(
            f"{tag}, D/dx={levels[-1]}: distance of D_max/D = {fin['spread']:.2f} outside "
            f"the correlations' band [{lo:.2f}, {hi:.2f}] (We {fin['We']:.0f}, Re "
            f"{fin['Re']:.0f}), relative to the band's edge",
            max(lo / fin["spread"] - 1.0, fin["spread"] / hi - 1.0, 0.0), TOL_CORRELATIONS)
    notes.append(f"{tag}: maximum spreading of the main body (D_max/D) "
                 + ", ".join(f"{f['spread']:.3f}" for f in figs)
                 + ", mass broken off it then "
                 + ", ".join(f"{f.get('detached_at_max', math.nan):.1%}" for f in figs)
                 + "; the wall row's maximum (stray rings ahead of the rim count) "
                 + ", ".join(f"{f.get('spread_wall_row', math.nan):.3f}" for f in figs)
                 + f" at D/dx = {list(levels)}")
    notes.append(f"{tag}: lamella at maximum spreading, particles across (2 D / (3 beta^2 "
                 "dx)): " + ", ".join(_one_decimal(f.get('lamella_particles')) for f in figs)
                 + "; residual film 0.79 D Re^-0.4 (Roisman 2009), particles across: "
                 + ", ".join(_one_decimal(f.get('film_particles')) for f in figs)
                 + f"; over [{T_WAGNER[0]}, {T_WAGNER[1]}] t_c, lamella root / Wagner: "
                 + ", ".join(f"{f['wagner_ratio']:.3f}" for f in figs)
                 + "; contact diameter (the sheet's tip) / Wagner: "
                 + ", ".join(f"{f.get('wagner_tip_ratio', math.nan):.3f}" for f in figs)
                 + f"; over [{T_LAMELLA[0]}, {T_LAMELLA[1]}] t_c, lamella at the axis / "
                 "inviscid law: "
                 + ", ".join(f"{f.get('lamella_ratio', math.nan):.3f}" for f in figs)
                 + f" at D/dx = {list(levels)}")
    notes.append(f"{tag}: peak von Mises at D/dx={levels[-1]}: {fin['vm_peak'] / 1e6:.2f} "
                 f"MPa at {fin['vm_t_tc']:.2f} t_c after contact, r = "
                 f"{fin['vm_r_m'] * 1e6:.1f} um, z = {fin['vm_z_m'] * 1e6:.2f} um; heat "
                 f"{fin['heat'] * 1e6:.3f} uJ = {fin['heat'] / fin['heat_ideal']:.3f} of the "
                 "ideal contact over the run's wetted-area history; peak / thermal plateau "
                 f"E alpha dT_c / (1 - nu) = {fin['vm_thermal'] / 1e6:.1f} MPa: "
                 + ", ".join(f"{f['vm_peak'] / f['vm_thermal']:.3f}" for f in figs)
                 + f" at D/dx = {list(levels)}")
    notes.append(f"{tag}: peak wall-normal force / (rho V^2 D^2): "
                 + ", ".join(f"{f.get('force_peak', math.nan):.3f} at "
                             f"{f.get('force_t_tc', math.nan):.2f} t_c" for f in figs)
                 + f" at D/dx = {list(levels)}")
    notes.append(f"{tag}: impact point, window [{T_WINDOW[0]}, {T_WINDOW[1]}] t_c: max "
                 "|rise / strained-contact rise - 1| "
                 + ", ".join(f"{f['T_impact_dev']:.3f}" for f in figs)
                 + "; max |rise / static contact rise - 1| "
                 + ", ".join(f"{f['T_impact_static']:.3f}" for f in figs)
                 + "; mean strain a t_c " + ", ".join(f"{f['strain_tc']:.2f}" for f in figs)
                 + f" at D/dx = {list(levels)}")
    return crit, notes


@register("droplet-impact")
def droplet_impact(quick: bool) -> CaseResult:
    """The axisymmetric droplet job at three spacings per speed (module docstring): the
    quick case at 50 m/s and :data:`LEVELS_QUICK`, one run each; the full one at
    :data:`SPEEDS` with :func:`levels_for` each, :data:`MEMBERS_FULL` ensemble members per
    level."""
    speeds = (50.0,) if quick else SPEEDS
    D = 2.0 * next(b for b in base_scene().to_dict()["blocks"] if b["kind"] == "fluid")["radius"]
    runs: list[Run] = []
    crit: dict[str, Criterion] = {}
    notes: list[str] = []
    for V in speeds:
        levels = LEVELS_QUICK if quick else levels_for(V)
        t_end = T_END_QUICK if quick else t_end_for(V)
        figs = []
        for n in levels:
            members = []
            for m in range(1 if quick else MEMBERS_FULL):
                f, wall = run_one(V, n, t_end, member=m)
                members.append(f)
                runs.append(Run(f"{V:g} m/s member {m}", D / n, f["particles"],
                                f["T_impact_dev"], f["T_impact_dev"], wall,
                                {k: f[k] for k in ("spread", "heat", "T_impact", "vm_peak",
                                                   "vm_t_tc", "steps")}))
            figs.append(ensemble(members))
        c, nt = speed_criteria(V, levels, figs, quick)
        crit.update(c)
        notes.extend(nt)
    return CaseResult("droplet-impact", runs, crit, notes, resolution_label="dx [m]",
                      extra_columns={"spread": "D_max/D", "heat": "heat J",
                                     "T_impact": "rise K", "vm_peak": "vM Pa"})
