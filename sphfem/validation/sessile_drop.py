"""Validation case ``sessile-drop``: equilibrium contact angle of a 2D drop on a flat wall
against the prescribed (Young) angle.

A 2D drop (a half disc of radius R0 = 1 mm; ``theta0`` starts it as a cap of the same area
at another angle) sits on a flat wall (Adami wall particles, 3 layers) without gravity
(Bond number 0: the equilibrium shape is a circular cap).  It relaxes for ``T_RELAX``
capillary times sqrt(rho R0^3 / sigma) under a viscosity of Ohnesorge number 0.2; the
angle is then measured from a circle fitted to the drop's outer layer (the particles with
|grad C| R > 0.9, moved out by dx/2, above 2 dx from the wall: lattice caps of 45-150 deg
give their angle within 2.5 deg at R0/dx = 10-20) over the wall face y = 0:
cos theta = -y_c / r_c.  Criterion: |theta - theta_Young| <= 5 deg (the issue's
acceptance: twice the measurement's own lattice error) at the finest resolution for every
angle, every run completed, the surface smooth (fit residual < 0.5 dx; lattice caps: 0.25).

Model of the case: CSF with ``csf_contact_angle`` (Young's normals at the wall in the
curvature, :mod:`sphfem.fluid.contact_angle_breinlinger2013`) on a free-slip wall
(``wall_slip = "free-slip"``, :mod:`sphfem.fluid.wall_slip`).

Status (issue 17): NOT registered with ``sphfem validate`` (the module is not in
``sphfem.validation._CASE_MODULES``) because it does not pass.  Measured (8 capillary
times from a half disc, mean angle over the second half; R0/dx = 10 / 15 / 20):

    prescribed [deg]   45                  60                  90
    measured [deg]     50.0 / 56.1 / 46.9  62.6 / 65.7 / 67.6  86.4 / 88.8 / 89.2
    prescribed [deg]   120                 150
    measured [deg]     103.3 / stop / 106.4   stop / stop / stop

("stop": the drop leaves the wall and the run stops on the domain guard; 45 deg at 20:
42-59 deg over the second half.)  The contact line moves (a no-slip wall pins it: 60 deg
gave 66 deg at R0/dx = 10), but the final angle depends on the start: at Ohnesorge 1,
120 deg from a half disc gave 105.7 / 109.3 / 114.1 deg (R0/dx 10 / 15 / 20), from a
150 deg cap 118.5 deg (R0/dx 10); 60 deg at R0/dx = 20 (Ohnesorge 0.2) from a 45 deg cap
57.2 deg, from the half disc 67.6 deg: contact-line hysteresis.  A wall of half the
particle spacing (less corrugation) gave 65.9 / 68.4 deg (60) and 109.7 / 108.7 deg (120)
at R0/dx = 15 / 20: the wall lattice is not the cause.  In a stuck state (120 deg
prescribed, 104 deg reached) the CSF pulls the bottom 3 layers inwards with 0.4 sigma
per unit length and the pressure of the particles at the contact line pushes back as much:
the contact line moves only by particles leaving the first layer, and the particle
arrangement resists that like a solid.  Non-wetting drops (120-150 deg) can jump off the
wall: the CSF with walls counted as liquid has no wall-normal adhesion.

Why it does not converge (session 9).  The contact-line force is a line force of order
sigma at every resolution, and with R = 3 dx its discretisation shrinks with dx: an error of
a fixed fraction of sigma there gives the same angle error at every resolution.
:func:`contact_line_force` measures the wall-tangential force on the right half within 4 R
of the contact line of static lattice caps (it should equal Young's imbalance sigma
(cos theta - cos theta_cap)); [sigma], R0/dx = 20 / 40:

    prescribed   cap 60                cap 90               cap 120
    none         -0.31 / -0.34  (0)    +0.16 / +0.21  (0)   +0.56 / +0.55  (0)
    60 deg       -0.18 / -0.21  (0)    +0.22 / +0.25 (0.5)  +0.55 / +0.55 (1.0)
    120 deg      -1.20 / -1.23 (-1.0)  -0.60 / -0.58 (-0.5) -0.18 / -0.17  (0)

The pressure / wall part of it halves with dx (+0.28 / +0.15 at cap 60, +0.74 / +0.37 at cap
120); the CSF part does not (none: -0.59 / -0.50 at cap 60).  Without any condition the
model already pushes the line towards ~90 deg (the colour gradient that counts the dry wall
as liquid tilts the normals of the particles at the line towards the wall normal, ~75 deg
on a 90 deg cap).  Relative to no condition, the 60 deg condition changes the CSF part by
+0.06 / -0.01 sigma at caps 90 / 120 and the 120 deg condition by -0.75 / -0.74 sigma (R0/dx
20; Young: the two should differ by 1.0 sigma): the equilibria lie between the prescribed
angle and 90 deg (cos theta_measured = 0.56-0.86 cos theta_Young at R0/dx = 20).

Tried in session 9, none converging (R0/dx 10 / 15 / 20): no density diffusion (delta = 0;
45 -> 49.5 / 51.0 / 52.3, 60 -> 62.0 / - / 61.9, 90 -> 86.4 / 88.4 / 89.0, 120 -> 102.6 /
107.2 / stop, 150 stops); particle shifting "all" (60 -> 61.0, 120 oscillates 92-145 deg at
R0/dx 20); Young's normals over the whole wall support instead of the first layer (erratic:
60 -> 72 at 20, 120 stops). A local dynamic angle for Huber et al.'s (2016) contact-line
force sigma (cos theta_eq - cos theta_d) from the colour gradient at the line is biased the
same way (90 / 120 / 150 deg caps: 75 / 79 / 97-102 deg, resolution-independent) and jumps
with the lattice (60 deg caps: 44 deg at R0/dx 10, 63 at 20): not used.
Kinetic damping (``damping`` = 0.05 capillary times, 24 capillary times): 60 deg -> 63.8 /
67.0 deg final at R0/dx 10 / 20 (Young's normals on the first layer) and 63.7 / 64.4 deg (on
the first two layers, WALL_LO, WALL_HI = 0, 0.25); 120 deg -> 110.9 / leaves the wall, and
138 (still rising) / stop: a non-wetting drop does not stay on the wall.

Akinci et al. (2013) with its adhesion (``run_sessile(..., method="akinci")``, delta = 0 and
the SPH-pressure calibration of session 9): 60 / 120 deg prescribed gave 72.7 / 97.7 deg
(free slip) and 72.5 / 103.2 deg (no slip) at R0/dx = 10, mean over capillary times 3-6
(before: 88.0 / 89.8 free slip, 90.2 / 94.1 no slip; see
:mod:`sphfem.fluid.surface_tension_akinci2013`).  Run the case with
``python -c "from sphfem.validation.sessile_drop import sessile_case; ..."``.
"""

from __future__ import annotations

import math

import numpy as np

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.setup import lattice, make_particles
from sphfem.particles import ParticleKind
from sphfem.validation import CaseResult, Criterion, Run, Timer

SUPPORT = 3.0
LAYERS = 3
#: relaxation time in capillary times sqrt(rho R0^3 / sigma)
T_RELAX = 6.0


def fit_circle(p: np.ndarray):
    """Least-squares (Kasa) circle through points ``p`` (n, 2): (centre, radius)."""
    A = np.column_stack([2 * p[:, 0], 2 * p[:, 1], np.ones(len(p))])
    b = (p**2).sum(1)
    (cx, cy, c), *_ = np.linalg.lstsq(A, b, rcond=None)
    return np.array([cx, cy]), math.sqrt(c + cx * cx + cy * cy)


def surface_points(x: np.ndarray, dx: float, y_min: float) -> np.ndarray:
    """The free surface of a 2D drop: the particles of its outer layer, those whose
    fluid colour gradient |grad C| R exceeds 0.9 (Wendland C2, R = 3 dx; ~1.3 on the outer
    layer of a flat surface, ~0.25 on the second, as the CSF's normal weight), moved out
    along -grad C by dx/2 (the outer layer lies dx/2 inside the surface); only points with
    y >= ``y_min`` (the layer along the wall is no free surface)."""
    from scipy.spatial import cKDTree

    R = SUPPORT * dx
    pairs = cKDTree(x).query_pairs(R, output_type="ndarray")
    r = x[pairs[:, 1]] - x[pairs[:, 0]]  # x_j - x_i
    d = np.hypot(r[:, 0], r[:, 1])
    q = d / R
    F = (7.0 / math.pi / R**2) * 20.0 * (1.0 - q) ** 3 / R**2  # -W'(d)/d
    t = (dx * dx * F)[:, None] * r  # V_j grad_i W_ij (points to j)
    g = np.zeros_like(x)
    np.add.at(g, pairs[:, 0], t)
    np.add.at(g, pairs[:, 1], -t)
    gn = np.hypot(g[:, 0], g[:, 1])
    keep = gn * R > 0.9
    pts = x[keep] - 0.5 * dx * g[keep] / gn[keep, None]
    return pts[pts[:, 1] >= y_min]


def contact_angle(x: np.ndarray, dx: float, y_wall: float = 0.0) -> tuple[float, float]:
    """(contact angle [deg], rms distance of the surface points to the fitted circle / dx)
    of a 2D drop on the wall face ``y = y_wall``."""
    pts = surface_points(x, dx, y_wall + 2.0 * dx)
    c, rc = fit_circle(pts)
    res = float(np.sqrt(np.mean((np.hypot(*(pts - c).T) - rc) ** 2)) / dx)
    cos_t = -(c[1] - y_wall) / rc
    return math.degrees(math.acos(max(-1.0, min(1.0, cos_t)))), res


def cap_lattice(R0: float, dx: float, theta0: float = 90.0) -> np.ndarray:
    """Cell-centred lattice points (y > 0) inside the circular cap of contact angle
    ``theta0`` [deg] on the wall y = 0 whose area is that of the half disc of radius R0:
    r^2 (t - sin t cos t) = pi R0^2 / 2, centre height -r cos t."""
    t = math.radians(theta0)
    r = R0 * math.sqrt(0.5 * math.pi / (t - math.sin(t) * math.cos(t)))
    yc = -r * math.cos(t)
    a = math.ceil(r / dx) * dx  # box of whole cells: spacing exactly dx
    x = lattice([-a, 0.0], [a, math.ceil((yc + r) / dx) * dx], dx)
    return x[np.hypot(x[:, 0], x[:, 1] - yc) < r]


def run_sessile(n_radius: int, theta: float, R0: float = 1e-3, rho0: float = 1000.0,
                sigma: float = 0.072, Oh: float = 0.2, t_relax: float = T_RELAX,
                fluid: dict | None = None, samples: int = 12, damping: float | None = None,
                extra: dict | None = None, method: str = "akinci", theta0: float = 90.0):
    """One drop with ``n_radius`` particles per R0 and prescribed angle ``theta`` [deg];
    returns (final angle, solver, history [(t / t_cap, angle)], fit residual / dx).
    ``damping``: zero the velocities every ``damping`` capillary times (kinetic damping:
    the drop descends to a static equilibrium; the no-slip wall's viscous force, which
    pins the contact line, vanishes with the velocities)."""
    from sphfem.fluid.surface_tension_akinci2013 import CURVATURE_DEFAULT, akinci_c0_pressure
    from sphfem.fluid.surface_tension_csf import capillary_wave_speed

    dx = R0 / n_radius
    R = SUPPORT * dx
    L = 2.5 * R0
    xf = cap_lattice(R0, dx, theta0)
    xw = lattice([-L, -LAYERS * dx], [L, 0.0], dx)
    if method == "akinci":
        # c0: 1 % density change under the largest pressure (Laplace + cohesion's internal)
        share = (fluid or {}).get("akinci_curvature", CURVATURE_DEFAULT)
        p_max = akinci_c0_pressure(sigma, rho0, R, dx, 2, R0, share)
        c0 = math.sqrt(100.0 * p_max / rho0)
    else:  # CSF: 1 % under the Laplace pressure, at least the capillary wave speed
        c0 = max(math.sqrt(100.0 * sigma / (R0 * rho0)),
                 capillary_wave_speed(sigma, rho0, 0.5 * R))
    mu = Oh * math.sqrt(rho0 * sigma * R0)
    ps = make_particles(xf, xw, dx, rho0)
    # Akinci without density diffusion (sphfem.fluid.surface_tension_akinci2013)
    kw = {"delta": 0.0 if method == "akinci" else 0.1, "rho_ratio_band": (0.5, 2.0),
          **(extra or {})}
    par = FluidParams(rho0=rho0, c0=c0, mu=mu, gravity=(0.0, 0.0), surface_tension=method,
                      sigma=sigma, st_params={f"{method}_contact_angle": theta, **(fluid or {})},
                      **kw)
    m = (LAYERS + 1) * dx
    s = FluidSolver(ps, R, [-L - m, -m], [L + m, 3 * R0], params=par)
    t_cap = math.sqrt(rho0 * R0**3 / sigma)
    hist = []

    every = t_relax * t_cap / samples
    k = max(1, int(round(every / (damping * t_cap)))) if damping else 1

    def sample(sv):
        if damping:
            sv.p.v.fill(0.0)
        if int(round(sv.t / (every / k))) % k == 0:
            fl = sv.p.kind == ParticleKind.FLUID
            hist.append((sv.t / t_cap, contact_angle(sv.p.x[fl], dx)[0]))

    s.run(t_relax * t_cap, callback=sample, every=every / k)
    fl = s.p.kind == ParticleKind.FLUID
    ang, res = contact_angle(s.p.x[fl], dx)
    return ang, s, hist, res


def contact_line_force(n_radius: int, theta_cap: float, theta: float | None,
                       R0: float = 1e-3, rho0: float = 1000.0, sigma: float = 0.072,
                       reach: float = 4.0) -> tuple[float, float, float]:
    """Force balance at the contact line of a static cap (the CSF case of
    :func:`run_sessile`, free-slip wall): the lattice cap of angle ``theta_cap`` at the
    Laplace density sigma / r, at rest, prescribed angle ``theta`` (None: no contact-angle
    condition); one force evaluation.  Returns (F_csf, F_rest, F_young) / sigma: the wall-
    tangential (x) force per unit depth on the fluid particles of the right half within
    ``reach`` R of the contact line, from the CSF and from all the other terms (pressure,
    wall, viscosity), and Young's imbalance sigma (cos theta - cos theta_cap) it should
    equal (a uniform pressure and a constant curvature cancel over the region; Young's
    balance of the line is what remains: ~0 without a condition)."""
    from sphfem.fluid import surface_tension_csf as csf
    from sphfem.fluid.eos import density

    dx = R0 / n_radius
    R = SUPPORT * dx
    L = 2.5 * R0
    xf = cap_lattice(R0, dx, theta_cap)
    ps = make_particles(xf, lattice([-L, -LAYERS * dx], [L, 0.0], dx), dx, rho0)
    c0 = max(math.sqrt(100.0 * sigma / (R0 * rho0)),
             csf.capillary_wave_speed(sigma, rho0, 0.5 * R))
    t = math.radians(theta_cap)
    r = R0 * math.sqrt(0.5 * math.pi / (t - math.sin(t) * math.cos(t)))
    fl = ps.kind == ParticleKind.FLUID
    ps.rho[fl] = density(sigma / r, rho0, c0, 7.0)
    ps.m[fl] = ps.rho[fl] * dx * dx
    par = FluidParams(rho0=rho0, c0=c0, mu=0.2 * math.sqrt(rho0 * sigma * R0),
                      gravity=(0.0, 0.0), delta=0.1, surface_tension="csf", sigma=sigma,
                      rho_ratio_band=(0.5, 2.0), wall_slip="free-slip",
                      st_params={} if theta is None else {"csf_contact_angle": theta})
    m = (LAYERS + 1) * dx
    s = FluidSolver(ps, R, [-L - m, -m], [L + m, 3 * R0], params=par)
    s.evaluate()
    x = s.p.x
    near = ((s.p.kind == ParticleKind.FLUID) & (x[:, 0] > 0)
            & (np.hypot(x[:, 0] - xf[:, 0].max(), x[:, 1]) < reach * R))
    total = float((s.p.m[near] * s.p.acc[near, 0]).sum())
    s.p.acc[:] = 0.0
    csf._accelerate(s, None)
    f_csf = float((s.p.m[near] * s.p.acc[near, 0]).sum())
    young = 0.0 if theta is None else math.cos(math.radians(theta)) - math.cos(t)
    return f_csf / sigma, (total - f_csf) / sigma, young


#: prescribed contact angles [deg] of the case
ANGLES = (45.0, 60.0, 90.0, 120.0, 150.0)
#: largest |theta - theta_prescribed| [deg] accepted at the finest resolution
TOLERANCE_DEG = 5.0
#: the model of the case (run_sessile keywords)
MODEL = {"method": "csf", "extra": {"wall_slip": "free-slip"}}


# Not decorated with @register("sessile-drop") while it fails its 5 deg tolerance: a
# decorator would register the case whenever a test imports this module (the quick suite
# then ran it, depending on import order).  Run it with sessile_case(quick).
def sessile_case(quick: bool = False) -> CaseResult:
    """2D sessile drops (CSF with Young's normals at the wall, free-slip wall): equilibrium
    contact angle vs the prescribed one."""
    from sphfem.errors import SimulationStopped

    runs = []
    ns = (10,) if quick else (10, 15, 20)
    angles = (60.0, 120.0) if quick else ANGLES
    t_relax = 8.0
    for n in ns:
        for th in angles:
            status = "completed"
            with Timer() as tm:
                try:
                    ang, s, hist, res = run_sessile(n, th, t_relax=t_relax, samples=32,
                                                    **MODEL)
                except SimulationStopped as e:
                    status, ang, s, hist, res = str(e), float("nan"), None, [], float("nan")
            late = [a for t, a in hist if t >= 0.5 * t_relax]
            mean = float(np.mean(late)) if late and s is not None else float("nan")
            err = abs(mean - th) / th
            runs.append(Run(f"csf theta={th:g}", 1.0 / n, int(s.p.n) if s else 0, err, err,
                            tm.s,
                            {"theta_deg": mean, "theta_final_deg": ang,
                             "theta_prescribed_deg": th, "abs_error_deg": abs(mean - th),
                             "theta_spread_deg": float(np.ptp(late)) if late else float("nan"),
                             "fit_residual_over_dx": res, "status": status,
                             "steps": s.step_count if s else 0,
                             "history": [(round(a, 2), round(b, 2)) for a, b in hist]}))
    fin = [r for r in runs if r.resolution == 1.0 / ns[-1]]

    def worst(vals):
        return max((v if np.isfinite(v) else math.inf) for v in vals)

    crit = {
        "angle": Criterion(f"largest |theta - theta_Young| [deg] at R0/dx = {ns[-1]} (mean over "
                           "the second half of the relaxation)",
                           worst(r.extra["abs_error_deg"] for r in fin), TOLERANCE_DEG),
        "completed": Criterion("runs stopped by a guard", sum(r.extra["status"] != "completed"
                                                              for r in runs), 0),
        "smooth": Criterion("largest circle-fit residual [dx] (lattice caps: 0.25)",
                            worst(r.extra["fit_residual_over_dx"] for r in runs), 0.5),
    }
    notes = ["2D drop, R0 = 1 mm (half disc at the start), rho = 1000 kg/m^3, sigma = 0.072 "
             "N/m, no gravity, Ohnesorge 0.2 (mu = 0.054 Pa s), Adami wall (3 layers) with "
             "wall_slip = free-slip, delta = 0.1, CSF with csf_contact_angle, c0 = max(10 "
             "sqrt(sigma/(rho R0)), capillary wave speed at h = R/2), "
             f"{t_relax:g} capillary times sqrt(rho R0^3/sigma) of relaxation.",
             "The angle: mean over the second half of the relaxation (32 samples) of the "
             "angle of a circle fitted to the drop's outer layer above 2 dx from the wall; "
             "'theta_spread_deg' is its range there."]
    return CaseResult("sessile-drop", runs, criteria=crit, notes=notes,
                      resolution_label="dx/R0",
                      extra_columns={"theta_deg": "theta", "theta_prescribed_deg": "Young",
                                     "abs_error_deg": "|err| deg",
                                     "theta_spread_deg": "spread", "steps": "steps"})
