"""The ``[fluid]`` scene section (declared once: validation, defaults and docs/scenes.md).

Pure declarations: importing this module compiles nothing (the method keys ``pressure``,
``viscosity``, ``surface_tension``, ``walls`` and ``integrator`` take their choices,
documentation and the methods' own keys from the registries of :mod:`sphfem.fluid`).  Material
properties of the fluid (``rho0``, ``c0``, ``mu``, ``sigma``) come from the
``[materials.<name>]`` tables of the fluid blocks; this section holds the numerical model.
"""

from __future__ import annotations

from sphfem.fluid import integrators, pressure, rheology, surface_tension, viscosity, walls
from sphfem.schema import VECTOR, Param, Section

#: the [fluid] keys that choose a method -> their registry (sphfem.methods.MethodRegistry)
REGISTRIES = {m.REGISTRY.key: m.REGISTRY
              for m in (pressure, viscosity, rheology, surface_tension, walls, integrators)}


def _choice(registry, default: str | None = None, doc: str = "") -> tuple:
    """The key choosing a method of ``registry`` (its choices and documentation from the
    registered methods) and the methods' own keys."""
    r = registry.REGISTRY
    return (Param(r.key, str, default or r.default, choices=r.names(),
                  doc=(doc + "; " if doc else "") + r.choices_doc()),
            *r.scene_params())


def _fluid_materials(ctx):
    blocks = ctx.core.get("blocks", ())
    mats = ctx.core.get("materials", {})
    names = list(dict.fromkeys(b.material for b in blocks if b.kind == "fluid"))
    return names, mats


def _check(rec, ctx, path):
    lo, hi = rec.rho_ratio_band
    if not 0.0 < lo < 1.0 < hi:
        ctx.error(f"{path}.rho_ratio_band", f"expected 0 < lo < 1 < hi, got [{lo:g}, {hi:g}]")
    if rec.rheology != "newtonian" and rec.viscosity == "none":
        ctx.error(f"{path}.rheology", f"rheology = \"{rec.rheology}\" needs a viscosity "
                                      "model (viscosity = \"none\" is inviscid)")
    for key in rheology.missing_keys(rec):
        ctx.error(f"{path}.{key}", f"missing: rheology = \"{rec.rheology}\" needs {key}")
    meta = ctx.core.get("scene")
    if rec.wall_friction != "sph" and getattr(meta, "geometry", None) != "axisymmetric":
        ctx.error(f"{path}.wall_friction", f"wall_friction = \"{rec.wall_friction}\" is "
                  "implemented for geometry = \"axisymmetric\" only (use \"sph\")")
    if rec.contact_line != "no-slip" and rec.wall_friction != "layer":
        ctx.error(f"{path}.contact_line", f"contact_line = \"{rec.contact_line}\" is a model "
                  "of the wall layer's friction: it needs wall_friction = \"layer\"")
    if (getattr(meta, "geometry", None) == "axisymmetric" and rec.walls == "adami2012"
            and rec.wall_slip != "no-slip" and rec.wall_friction != "viscous"):
        ctx.error(f"{path}.wall_slip", f"wall_slip = \"{rec.wall_slip}\" in an axisymmetric "
                  "scene acts on the plain viscous wall term: it needs wall_friction = "
                  f"\"viscous\" (got \"{rec.wall_friction}\")")
    for key in ("bulk_damping", "bulk_damping_length"):
        if getattr(rec, key) and getattr(meta, "geometry", None) != "axisymmetric":
            ctx.error(f"{path}.{key}", f"{key} is implemented for geometry = "
                      "\"axisymmetric\" only")
    if rec.film_tension and getattr(meta, "geometry", None) != "axisymmetric":
        ctx.error(f"{path}.film_tension", "film_tension is implemented for geometry = "
                  "\"axisymmetric\" only")
    if rec.csf_meridian != "csf" and getattr(meta, "geometry", None) != "axisymmetric":
        ctx.error(f"{path}.csf_meridian", "csf_meridian is a switch of the axisymmetric "
                  "CSF (geometry = \"axisymmetric\"); planar scenes have surface_tension = "
                  "\"akinci\"")
    if rec.shifting_speed == "strain" and getattr(meta, "geometry", None) != "axisymmetric":
        ctx.error(f"{path}.shifting_speed", "shifting_speed = \"strain\" is implemented for "
                  "geometry = \"axisymmetric\" only (use \"local\" or \"max\")")
    if rec.csf_meridian != "csf" and rec.film_tension:
        ctx.error(f"{path}.csf_meridian", f"csf_meridian = \"{rec.csf_meridian}\" and "
                  "film_tension = true both replace the CSF's pull on films: choose one")
    names, mats = _fluid_materials(ctx)
    if not names:
        ctx.error("physics.modules", "the fluid module needs at least one block of kind "
                                     "\"fluid\"")
    first = mats[names[0]]
    for name in names:
        m = mats[name]
        where = f"materials.{name}"
        if m.c0 is None:
            ctx.error(f"{where}.c0", "missing: a fluid material needs the artificial speed of "
                                     "sound c0 [m/s] (>= 10 x the largest expected speed)")
        if rec.viscosity != "none" and rec.rheology == "newtonian" and m.mu is None:
            ctx.error(f"{where}.mu", f"missing: viscosity = \"{rec.viscosity}\" needs the "
                                     "dynamic viscosity mu [Pa s] (or set [fluid] viscosity "
                                     "= \"none\")")
        if rec.surface_tension != "none":
            # the calibration constant's key exists only for its own model (Param.when)
            key = surface_tension.lookup(rec.surface_tension).constant_key
            const = rec[key] if key is not None else None
            if const is None and m.sigma is None:
                ctx.error(f"{where}.sigma", f"missing: surface_tension = "
                          f"\"{rec.surface_tension}\" needs the material's surface tension "
                          f"sigma [N/m] (or the model's calibration constant in [fluid])")
        for key in ("rho0", "c0", "sigma"):
            if m[key] != first[key]:
                ctx.error(f"{where}.{key}", f"all fluid materials must share {key} (the "
                          f"fluid uses one value): {m[key]} != {first[key]} of "
                          f"materials.{names[0]}")


FLUID = Section("fluid", (
    *_choice(pressure, doc="pressure model, owns the time step"),
    Param("gamma", float, 7.0, positive=True,
          doc="Tait exponent of p = rho0 c0^2/gamma ((rho/rho0)^gamma - 1)"),
    Param("delta", float, 0.1, ge=0.0,
          doc="delta-SPH density diffusion coefficient (Antuono et al. 2010 with the "
              "renormalised density gradient; 0 = off)"),
    *_choice(viscosity, "laminar", doc="viscosity model (each fluid particle's material "
                                       "mu)"),
    *_choice(rheology, "newtonian", doc="apparent viscosity mu(gamma_dot) of each fluid "
                                        "particle, updated every evaluation"),
    Param("alpha", float, 0.0, ge=0.0,
          doc="artificial viscosity coefficient (Monaghan 1992 in the always-on form of "
              "Marrone et al. 2011, pair coefficient alpha h c0, h = R/2; 0 = off, "
              "0.01-0.05 for violent free-surface flows)"),
    Param("wall_friction", str, "sph", choices=("sph", "viscous", "layer", "none"),
          doc="friction of the no-slip walls (axisymmetric fluid): sph = the viscous term "
              "and the artificial viscosity on wall pairs; viscous = the viscous term alone; "
              "layer = the viscous term scaled to the traction mu U / delta of a wall layer "
              "thinner than the spacing, d(delta^2)/dt = pi nu - 2 a delta^2 "
              "(sphfem.fluid.wall_layer), no artificial viscosity on wall pairs; none = free "
              "slip (neither term on wall pairs)"),
    Param("contact_line", str, "no-slip", choices=("no-slip", "slip", "cox-voinov"),
          doc="the moving contact line's friction (axisymmetric fluid, wall_friction = "
              "\"layer\"): no-slip = the plain no-slip wall term on the rings at the end of a "
              "wall row; slip = none there (they slide freely); cox-voinov = the friction of "
              "the liquid wedge between contact_line_slip_length and dx / 2 from Cox's (1986) "
              "law at each ring's speed, 90-degree static angle "
              "(sphfem.fluid.contact_line_cox1986)"),
    Param("contact_line_slip_length", float, 1.0e-9, gt=0.0, unit="m",
          doc="slip length lambda [m] of contact_line = \"cox-voinov\": the molecular scale "
              "where the wedge's viscous stress is cut off"),
    Param("bulk_damping", float, None, ge=0.0,
          doc="axisymmetric fluid: alpha_b of the acoustic damper, a bulk viscous stress "
              "nu_b D rho / D t added to the fluid's pressure in the momentum equation with "
              "nu_b = alpha_b c0 max(h, bulk_damping_length) (sphfem.fluid.axisymmetric."
              "AxisymmetricFluid); it acts on the compressible part of the flow alone and "
              "damps the artificial acoustic waves of the weakly compressible fluid; unset: "
              "the module's 0.5; 0 = off"),
    Param("bulk_damping_length", float, 0.0, ge=0.0, unit="m", quantity="length",
          doc="axisymmetric fluid: the acoustic damper's length floor l [m], nu_b = alpha_b "
              "c0 max(h, l); 0 = h, so the damper vanishes with the spacing; l > h holds the "
              "damping of a given wavelength fixed under refinement (a bulk viscosity rho "
              "alpha_b c0 l; it enters the time step as a viscous limit)"),
    Param("film_tension", bool, False,
          doc="axisymmetric CSF: films thinner than about the kernel support carry the "
              "line tension of their faces as a membrane stress (2 sigma free, sigma on a "
              "wall) instead of the CSF, whose truncated colour field gives their ends "
              "0-76 % of it (sphfem.fluid.axisymmetric_surface_tension, \"Thin films\")"),
    Param("csf_meridian", str, "csf", choices=("csf", "pair", "stress"),
          doc="axisymmetric CSF: the force of the meridian curvature as the CSF's sigma "
              "kappa_m grad C (csf) or as the pair force of Akinci et al. (2013) in the "
              "(r, z) plane (pair: equal and opposite pair terms, so a film's end is pulled "
              "by the line force whatever its shape, and a retracting rim stays compact; "
              "the surface rings are then held at rho >= rho0 only next to the axis, where "
              "the CSF's meridian part acts, elsewhere the tension lives in their pressure; "
              "sphfem.fluid.axisymmetric_pair_tension); the hoop part stays the CSF's; "
              "stress (experimental): the whole surface force as the divergence of a "
              "surface stress normalised to sigma per face, with the wall top as its "
              "90-degree symmetry plane and no free-surface density hold "
              "(sphfem.fluid.axisymmetric_surface_stress)"),
    Param("gravity", VECTOR, lambda dim: (0.0,) * dim, unit="m/s^2", default_doc="zeros",
          quantity="acceleration", doc="body force per unit mass"),
    Param("gravity_ramp", float, 0.0, unit="s", ge=0.0, quantity="time",
          doc="time over which the body force rises smoothly from 0 (half a cosine "
              "period); lets a column at rest settle without exciting acoustic modes"),
    Param("visc_cfl", float, 0.125, gt=0.0, le=1.0,
          doc="viscous limit dt <= visc_cfl h^2 min(rho/mu) (the acoustic limit "
              "dt <= cfl h/(c0 + |v|max) uses `[time] cfl`)"),
    Param("force_cfl", float, 0.25, gt=0.0, le=1.0,
          doc="force limit dt <= force_cfl sqrt(h/|a|max)"),
    Param("density_cfl", float, 0.0, ge=0.0, le=1.0,
          doc="density-rate limit dt <= density_cfl min(rho / |D rho / D t|) over the fluid "
              "(0 = off): no particle's density changes by more than this fraction in a "
              "step.  It binds only in singular events (a cavity or a ring collapsing onto "
              "the axis of an axisymmetric run, whose hoop compression v_r / r is not bounded "
              "by the acoustic limit); 0.02 in the packaged axisymmetric droplet scenes"),
    Param("eps_visc", float, 1e-3, positive=True,
          doc="regulariser of the viscous term, as a fraction of h^2"),
    Param("cond_max", float, 1e8, gt=1.0,
          doc="largest accepted condition number of the renormalisation matrix (beyond: "
              "plain density gradient, counted as a fallback)"),
    Param("max_speed_factor", float, 1.0, positive=True,
          doc="guard: stop when a fluid speed exceeds this multiple of c0"),
    Param("rho_ratio_band", VECTOR, (0.8, 1.25), length=2, positive=True,
          doc="guard: stop when rho/rho0 of a fluid particle leaves [lo, hi]"),
    Param("threads", int, 0, ge=0,
          doc="numba threads of the fluid passes (0: one below 20000 particles, else "
              "numba's default)"),
    *_choice(surface_tension),
    *_choice(walls, doc="wall model of the boundary particles (blocks of kind \"wall\")"),
    *_choice(integrators, doc="time integrator of the weakly compressible model"),
    Param("shifting", str, "none", choices=("none", "interior", "all"),
          doc="particle shifting dr = -A h |v| dt grad C (Skillen et al. 2013, Xu & Yu "
              "2018, Park 2019 sec. 2.1.6): interior = only particles away from the free "
              "surface; all = free-surface and near-surface particles shifted tangentially "
              "only; needs the free-surface detection (switched on)"),
    Param("shifting_coef", float, 5.0 / 3.0, positive=True,
          doc="A of the shifting law (Park 2019: 5/3)"),
    Param("shifting_speed", str, "local", choices=("local", "max", "strain"),
          doc="the speed |v| in the shifting law: local = each particle's own (Skillen et "
              "al. 2013; slow regions such as a stagnation point are hardly shifted); max = "
              "the largest fluid speed of the step for every particle (the Mach-scaled "
              "shift of Sun et al. 2017); strain = h |S|, S the strain rate (axisymmetric "
              "scenes: Galilean invariant, a film carried at speed is not shifted along "
              "itself, and the shift vanishes with refinement; needs a larger "
              "shifting_coef, about D / dx times the local one)"),
    Param("shifting_drift", str, "kept", choices=("kept", "removed"),
          doc="removed: each particle's shift less the kernel-weighted mean shift of its "
              "fluid neighbourhood (sphfem.fluid.surface.remove_local_mean), so shifting "
              "only rearranges particles among their neighbours and carries no mass along "
              "a thin film towards its end (which over-spreads a droplet impact by 15-30 %; "
              "docs/validation/droplet_impact, session 20); kept: the plain shift"),
    Param("shifting_surface_lambda", float, 0.75, positive=True, le=1.0,
          doc="axisymmetric scenes: rings whose moment matrix' smallest eigenvalue lambda "
              "lies below this are shifted along the surface only, the rest in full "
              "(0.75: every ring within about a support of the surface; lower values let "
              "the rings of thin films and rims be shifted across them as well)"),
    Param("detect_free_surface", bool, False,
          doc="Marrone et al. (2010) free-surface detection every step (particle field "
              "`free_surface` = 1 on the surface); always on with shifting"),
), check=_check, doc=(
    "Weakly compressible delta-SPH fluid (Tait EOS, symmetric pressure gradient, laminar "
    "viscosity, delta-SPH continuity, symplectic position-Verlet step) with Adami et al. "
    "(2012) walls; registries choose the methods (`pressure`, `viscosity`, "
    "`surface_tension`, `walls`, `integrator`; sphfem.methods).  Blocks of kind "
    "`\"wall\"` are the walls (fixed; their `rho` and `p` are overwritten by the "
    "extrapolated wall state), `\"fluid\"` blocks the fluid; other kinds do not interact "
    "with the fluid.  Fluid materials need `c0` and (laminar) `mu` and must share `rho0` and "
    "`c0`.  The time step is the smallest of the acoustic, viscous and force limits (each "
    "reported in summary.json), and guards stop the run on NaN/Inf, speed, density ratio or "
    "particles leaving the domain."))
