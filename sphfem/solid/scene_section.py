"""The ``[tlsph]`` scene section (declarations only; importing compiles nothing).

Example (a bar heated from its left end, clamped at both ends)::

    [physics]
    modules = ["heat", "tlsph"]      # heat first: the solid reads the new temperatures

    [materials.steel]
    rho0 = 7800.0
    E = 200e9
    nu = 0.3
    alpha = 1.2e-5
    c = 500.0
    k = 50.0

    [tlsph]
    integrator = "relax"             # quasi-static: relaxed to equilibrium every step

    [[tlsph.boundaries]]
    block = "bar"
    face = "xmin"
    condition = "clamp"

    [[tlsph.boundaries]]
    block = "bar"
    face = "xmax"
    condition = "roller"
    components = "x"
"""

from __future__ import annotations

from sphfem.schema import REQUIRED, STRINGS, TEMPERATURE, VECTOR, Param, Section

FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax", "all")
AXES = "xyz"

BOUNDARY = Section("boundaries", (
    Param("block", str, REQUIRED, doc="name of a `[[blocks]]` entry of the body"),
    Param("face", str, REQUIRED, choices=FACES,
          doc="face of the block's box (`all`: every particle of the block, any shape)"),
    Param("condition", str, REQUIRED, choices=("clamp", "roller", "traction"),
          doc="clamp: every displacement component held; roller: the `components` held "
              "(symmetry planes, sliding supports); traction: applied surface traction on "
              "the outermost particle layer"),
    Param("components", str, None, when=("condition", ("roller",)),
          doc="held components of a roller, letters of `xyz` (e.g. `\"x\"`)"),
    Param("traction", VECTOR, None, unit="Pa", quantity="traction",
          when=("condition", ("traction",)),
          doc="traction vector; the total force traction x face area is shared equally by "
              "the face's outermost particle layer (constant in time)"),
    Param("layers", int, None, ge=1, when=("condition", ("clamp", "roller")),
          default_doc="ceil(`[sph] support_factor`)",
          doc="particles within `layers` x dx of the face are held; the default holds the "
              "full kernel support next to the first free row (one held layer leaves a "
              "kernel-deficient, softer zone: about 4% stress error at 20 particles per "
              "bar length)"),
), repeated=True, doc="Mechanical condition of one face of a box block "
   "(`[[tlsph.boundaries]]`); faces not listed are traction-free.  Thermal conditions are "
   "those of the `heat` module (`[[heat.boundaries]]`).")


def body_blocks(named, blocks) -> list[str]:
    """The names of the body's blocks: ``[tlsph] blocks`` as ``named``, or (None) every
    block of kind "solid" among ``blocks``, in scene order."""
    return list(named) if named is not None else [b.name for b in blocks if b.kind == "solid"]


def _check(rec, ctx, path):
    core = ctx.core
    dim = ctx.dim
    if dim not in (2, 3):
        ctx.error("scene.dim", "the tlsph module needs a 2D (plane strain) or 3D scene")
    blocks = {b.name: b for b in core.get("blocks", ())}
    mats = core.get("materials", {})
    names = body_blocks(rec.blocks, blocks.values())
    if not names:
        ctx.error(f"{path}.blocks", "no block of kind \"solid\": the tlsph module needs one "
                                    "(or name the body's blocks in tlsph.blocks)")
    for i, n in enumerate(names):
        if n not in blocks:
            ctx.error(f"{path}.blocks[{i}]", f"unknown block {n!r} (defined: "
                                             f"{', '.join(blocks)})")
        if blocks[n].kind != "solid":
            ctx.error(f"{path}.blocks[{i}]", f"block {n!r} is of kind {blocks[n].kind!r}; "
                                             "a TL-SPH body is made of solid blocks")
        mname = blocks[n].material
        m = mats[mname]
        for k in ("E", "nu"):
            if m[k] is None:
                ctx.error(f"materials.{mname}.{k}",
                          f"missing: the TL-SPH body (block {n!r}) needs {k}")
    mods = list(core["physics"].modules)
    if "heat" in mods and mods.index("heat") > mods.index("tlsph"):
        ctx.error("physics.modules", "list \"heat\" before \"tlsph\": the solid reads the "
                                     "temperatures of the end of each step")
    for i, b in enumerate(rec.boundaries):
        where = f"{path}.boundaries[{i}]"
        if b.block not in names:
            ctx.error(f"{where}.block", f"block {b.block!r} is not part of the TL-SPH body "
                                        f"({', '.join(names)})")
        if b.face != "all":
            if blocks[b.block].shape != "box":
                ctx.error(f"{where}.face", f"block {b.block!r} is a {blocks[b.block].shape}; "
                                           "faces are defined for box blocks (or use \"all\")")
            if AXES.index(b.face[0]) >= dim:
                ctx.error(f"{where}.face", f"face {b.face!r} does not exist in {dim}D")
        if b.condition == "roller":
            c = b.components
            if c is None or not c or any(ch not in AXES[:dim] for ch in c.lower()):
                ctx.error(f"{where}.components", f"a roller needs components as letters from "
                                                 f"{AXES[:dim]!r} (e.g. \"x\"), got {c!r}")
        if b.condition == "traction":
            if b.traction is None:
                ctx.error(f"{where}.traction", "missing: a traction condition needs the "
                                               "traction vector [Pa]")
            if b.face == "all":
                ctx.error(f"{where}.face", "a traction acts on a face, not on \"all\"")
    if rec.integrator == "verlet" and rec.dt is not None:
        ctx.error(f"{path}.dt", "applies to integrator = \"trapezoid\" or \"relax\" (the "
                                "explicit step follows from cfl)")


TLSPH = Section("tlsph", (
    Param("blocks", STRINGS, None, default_doc="every block of kind `\"solid\"`",
          doc="blocks forming the body; touching blocks are bonded (one body, several "
              "materials).  Materials need `E`, `nu` (and `alpha` for thermal strain)"),
    Param("integrator", str, "verlet",
          choices=("verlet", "trapezoid", "implicit", "relax", "newton"),
          doc="verlet: explicit velocity Verlet at `cfl` x 2/omega_max; trapezoid: implicit "
              "trapezoidal rule by fixed-point iteration (Park 2019 sec. 2.5.5), which "
              "contracts only below the explicit limit; implicit: the same trapezoidal rule "
              "solved by Newton-Krylov, at any step (default `dt`: 10 x the explicit "
              "limit); relax: quasi-static, every step relaxed to equilibrium under that "
              "step's loads (dynamic relaxation); newton: quasi-static as relax, solved by "
              "Newton-Krylov (same `relax_tol`)"),
    Param("cfl", float, 0.8, gt=0.0, lt=1.0,
          doc="fraction of the explicit limit 2/omega_max (power iteration on the "
              "particle stiffness at the start) used as the verlet/trapezoid step"),
    Param("dt", float, None, unit="s", positive=True, quantity="time step",
          default_doc="trapezoid: `cfl` x explicit limit; implicit: 10 x the explicit "
                      "limit; relax, newton: no limit (one step, or the other modules' "
                      "steps)",
          doc="fixed step of the trapezoid / implicit / relax / newton integrators"),
    Param("tol", float, 1e-9, positive=True,
          doc="trapezoid: fixed-point tolerance on max(|dx|, dt |dv|) / dx; implicit: "
              "bound on the position error of the Newton-Krylov solve, in dx"),
    Param("max_iter", int, 200, ge=1, doc="trapezoid: fixed-point iterations per step"),
    Param("on_failure", str, "stop", choices=("stop", "substep"),
          doc="trapezoid step that does not converge: stop the run with the iteration "
              "history, or take the step as explicit Verlet sub-steps (counted as "
              "`fallbacks` in summary.json)"),
    Param("damping", float, 0.0, ge=0.0, unit="1/s", quantity="damping rate",
          doc="viscous damping rate c of a -= c v (verlet and trapezoid); 0: undamped"),
    Param("relax_tol", float, 1e-6, positive=True,
          doc="relax, newton: residual force / load at which the solve stops"),
    Param("relax_max_steps", int, 200000, ge=1,
          doc="relax: pseudo-time steps per relaxation before the run stops"),
    Param("hourglass", float, 10.0, ge=0.0,
          doc="Ganzenmueller (2015) hourglass-control coefficient (0: off)"),
    Param("T0", TEMPERATURE, None, unit="K",
          default_doc="each particle's initial temperature",
          doc="stress-free temperature of the thermal strain alpha (T - T0)"),
), subsections=(BOUNDARY,), check=_check, doc=(
    "Total-Lagrangian SPH thermo-elastic solid (Park 2019 sec. 2.5): reference neighbours "
    "and corrected gradients kept for the run, F = F_e F_theta, Saint Venant-Kirchhoff "
    "stress, momentum-conserving divergence and hourglass control; 2D is plane strain.  "
    "Temperatures are the particle field `T` (constant, or advanced by the `heat` module "
    "listed before `tlsph`).  Particle fields written: `u` (displacement), `X0` (reference "
    "position), `stress` (Cauchy, 3x3 row-major), `von_mises`; summary.json reports the "
    "stable step, iterations, fallbacks, relaxation steps, peak von Mises and energies."))
