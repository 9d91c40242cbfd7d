"""Validation case ``sessile-drop``: equilibrium contact angle of the Akinci et al. (2013)
adhesion against the prescribed one (Young).

A 2D drop (a half disc of radius R0 = 1 mm, the area of a cap of any angle) starts on a
flat wall (Adami wall particles, 3 layers) without gravity (Bond number 0, so the
equilibrium shape is a circular cap).  With ``surface_tension = "akinci"`` and
``akinci_contact_angle = theta`` the wall adhesion is gamma_a = gamma (1 + cos theta) / 2
(Young-Dupre, :mod:`sphfem.fluid.surface_tension_akinci2013`).  The drop relaxes under a
viscosity of Ohnesorge number ~0.2 for ``T_RELAX`` capillary times sqrt(rho R0^3 / sigma);
then a circle is fitted to its free surface (the outermost particle of each angular bin
about the drop's centroid, moved out by dx/2, above 2 dx from the wall), and the contact
angle follows from the circle's centre height y_c and radius r_c over the wall face y = 0:
cos theta = -y_c / r_c.

Status (issue 17): NOT registered with ``sphfem validate`` (the module is not in
``sphfem.validation._CASE_MODULES``) because it does not pass.  The model's relation is
cos theta = 2 psi - 1 with the wall colour psi = (1 + cos theta) / 2 (derived in
:mod:`sphfem.fluid.surface_tension_akinci2013`), but the measured contact line barely moves
from the start (a half disc, 90 deg) on the no-slip Adami wall: with the final model
(kernel-weighted curvature pairs) prescribed 60 / 120 deg gave 100 / 101 deg at R0/dx = 10
after 6 capillary times (82-100 / 96-106 deg over the last 3); with the paper's equal
weights 78 / 112 deg at R0/dx = 10 and 86 / 96 deg at R0/dx = 15 after 12 capillary times
(the drop stays a half disc, base unchanged); with kinetic damping or without viscosity
the R0/dx = 10 drop stayed at 89-99 deg.  Before the wall particles took part
in the curvature pairs, a flat wall could push fluid particles only along its normal and
nothing moved; with the adhesion pair force alone (no cohesion) a one-particle film spread
along the wall and the drop beaded up on it.  Run it with
``python -c "from sphfem.validation.sessile_drop import sessile_case; ..."``.
"""

from __future__ import annotations

import math

import numpy as np

from sphfem.fluid import FluidParams, FluidSolver
from sphfem.fluid.setup import lattice, make_particles
from sphfem.particles import ParticleKind
from sphfem.validation import CaseResult, Criterion, Run, Timer, register

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


def run_sessile(n_radius: int, theta: float, R0: float = 1e-3, rho0: float = 1000.0,
                sigma: float = 0.072, Oh: float = 0.2, t_relax: float = T_RELAX,
                fluid: dict | None = None, samples: int = 12, damping: float | None = None,
                extra: dict | None = None, method: str = "akinci"):
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
    xf = lattice([-R0, 0.0], [R0, R0], dx)
    xf = xf[np.hypot(xf[:, 0], xf[:, 1]) < R0]
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
    par = FluidParams(rho0=rho0, c0=c0, mu=mu, gravity=(0.0, 0.0), delta=0.1,
                      surface_tension=method, sigma=sigma, rho_ratio_band=(0.5, 2.0),
                      st_params={f"{method}_contact_angle": theta, **(fluid or {})},
                      **(extra or {}))
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


#: prescribed contact angles [deg] of the case
ANGLES = (60.0, 90.0, 120.0)
#: largest |theta - theta_prescribed| [deg] accepted at the finest resolution
TOLERANCE_DEG = 10.0


@register("sessile-drop")
def sessile_case(quick: bool = False) -> CaseResult:
    """2D sessile drops (Akinci adhesion, Young-Dupre calibration): equilibrium contact
    angle vs the prescribed one for three angles."""
    runs = []
    ns = (10,) if quick else (10, 15)
    for n in ns:
        for th in ANGLES:
            with Timer() as tm:
                ang, s, hist, res = run_sessile(n, th)
            err = abs(ang - th) / th
            late = [a for t, a in hist if t >= 0.5 * T_RELAX]
            runs.append(Run(f"akinci theta={th:g}", 1.0 / n, int(s.p.n), err, err, tm.s,
                            {"theta_deg": ang, "theta_prescribed_deg": th,
                             "abs_error_deg": abs(ang - th),
                             "theta_spread_deg": float(np.ptp(late)) if late else float("nan"),
                             "fit_residual_over_dx": res, "steps": s.step_count,
                             "history": [(round(a, 2), round(b, 2)) for a, b in hist]}))
    fin = [r for r in runs if r.resolution == 1.0 / ns[-1]]
    crit = {
        "angle": Criterion(f"largest |theta - theta_Young| [deg] at R0/dx = {ns[-1]}",
                           max(r.extra["abs_error_deg"] for r in fin), TOLERANCE_DEG),
    }
    notes = ["2D drop, R0 = 1 mm (half disc at the start), rho = 1000 kg/m^3, sigma = 0.072 "
             "N/m, no gravity, Ohnesorge 0.2 (mu = 0.054 Pa s), Adami no-slip wall (3 "
             f"layers), delta = 0.1, {T_RELAX:g} capillary times sqrt(rho R0^3/sigma) of "
             "relaxation; c0 from 1 % density change under the Laplace plus the cohesion's "
             "internal pressure.",
             "Akinci cohesion (gamma from sigma), curvature weight 0.1, adhesion gamma_a = "
             "gamma (1 + cos theta)/2 (Young-Dupre for pair potentials); the angle from a "
             "circle fitted to the free surface above 2 dx from the wall; 'theta_spread_deg' "
             "is the range of the angle over the second half of the relaxation (samples "
             "every half capillary time)."]
    return CaseResult("sessile-drop", runs, criteria=crit, notes=notes,
                      resolution_label="dx/R0",
                      extra_columns={"theta_deg": "theta", "theta_prescribed_deg": "Young",
                                     "abs_error_deg": "|err| deg",
                                     "theta_spread_deg": "spread", "steps": "steps"})
