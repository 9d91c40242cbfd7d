"""The ``[coupling]`` scene section (declarations only; importing compiles nothing).

Example (the substrate under a droplet, FEM on a graded hexahedral mesh)::

    [physics]
    modules = ["fluid", "heat", "coupling"]

    [coupling]
    material = "alumina"          # E, nu, alpha from [materials.alumina]
    blocks = ["substrate"]        # the SPH solid region (default: wall/solid blocks of it)
    clamps = ["left", "right", "front", "back"]
    probes = [[0.0, 0.0, -1e-6], [0.0, 0.0, -50e-6]]

    [coupling.mesh]
    lo = [-1e-3, -1e-3, -0.26e-3]
    hi = [1e-3, 1e-3, 0.0]
    h_fine = 5e-6
"""

from __future__ import annotations

from coupling.substrate_heat import HEAT_SECTION, check_heat
from sphfem.schema import CUSTOM, REQUIRED, STRINGS, TEMPERATURE, VECTOR, FrozenDict, Param, Section

AXES = "xyz"


def _rollers(v, ctx, key):
    if not isinstance(v, dict):
        ctx.error(key, f"expected a table {{group = \"components\"}}, e.g. {{bottom = \"z\"}}, "
                       f"got {v!r}")
    for g, c in v.items():
        ok = isinstance(c, str) and c and all(ch in AXES[: ctx.dim] for ch in c.lower())
        if not ok:
            ctx.error(f"{key}.{g}", f"expected components as letters from "
                                    f"{AXES[: ctx.dim]!r} (e.g. \"z\"), got {c!r}")
    return FrozenDict({str(g): str(c).lower() for g, c in v.items()})


def _points(v, ctx, key):
    ok = isinstance(v, list) and all(
        isinstance(p, list) and len(p) == ctx.dim
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in p) for p in v)
    if not ok:
        ctx.error(key, f"expected a list of points, each a list of {ctx.dim} numbers "
                       f"(m), got {v!r}")
    return tuple(tuple(float(x) for x in p) for p in v)


def region_block_names(cfg, blocks) -> list[str]:
    """Names of the blocks forming the SPH solid region of the ``[coupling]`` section
    ``cfg``: its ``blocks`` list, by default every wall or solid block of its material."""
    if cfg.blocks is not None:
        return list(cfg.blocks)
    return [b.name for b in blocks if b.material == cfg.material and b.kind in ("wall", "solid")]


def _check(rec, ctx, path):
    core = ctx.core
    mats = core.get("materials", {})
    if rec.material not in mats:
        ctx.error(f"{path}.material", f"unknown material {rec.material!r} (defined: "
                                      f"{', '.join(mats) or 'none'})")
    m = mats[rec.material]
    for k in ("E", "nu"):
        if m[k] is None:
            ctx.error(f"materials.{rec.material}.{k}",
                      f"missing: the coupled substrate needs {k} (material {rec.material!r})")
    blocks = {b.name: b for b in core.get("blocks", ())}
    names = region_block_names(rec, blocks.values())
    if not names:
        ctx.error(f"{path}.blocks", f"no wall or solid block of material {rec.material!r}: "
                                    "name the SPH solid region's blocks")
    for i, n in enumerate(names):
        if n not in blocks:
            ctx.error(f"{path}.blocks[{i}]", f"unknown block {n!r} (defined: "
                                             f"{', '.join(blocks)})")
        if blocks[n].kind not in ("wall", "solid"):
            ctx.error(f"{path}.blocks[{i}]", f"block {n!r} is of kind {blocks[n].kind!r}; the "
                                             "SPH solid region is made of wall or solid blocks")
    mods = list(core["physics"].modules)
    me = mods.index("coupling") if "coupling" in mods else len(mods)
    for dep in ("fluid", "heat", "solid"):
        if dep in mods and mods.index(dep) > me:
            ctx.error("physics.modules", f"list \"coupling\" after {dep!r}: it reads that "
                                         "module's fields at the end of each step")
    mesh = rec["mesh"]
    if mesh.lo is not None and mesh.hi is not None:
        if any(h <= lo for lo, h in zip(mesh.lo, mesh.hi, strict=True)):
            ctx.error(f"{path}.mesh.hi", "must exceed coupling.mesh.lo on every axis")
    if mesh.cells is not None:
        want = ("hex", "tet") if ctx.dim == 3 else ("quad", "tri")
        if mesh.cells not in want:
            ctx.error(f"{path}.mesh.cells", f"expected one of {want} in {ctx.dim}D, got "
                                            f"{mesh.cells!r}")
    if ctx.dim == 1:
        ctx.error(path, "the coupled substrate needs a 2D (plane strain) or 3D scene")
    axi = getattr(core.get("scene"), "geometry", "cartesian") == "axisymmetric"
    if axi != (rec.backend == "fem-axisymmetric"):
        ctx.error(f"{path}.backend", 'backend = "fem-axisymmetric" goes with [scene] geometry '
                                     f'= "axisymmetric" and only with it; got {rec.backend!r}')
    check_heat(rec["heat"], ctx, f"{path}.heat", rec.material, rec.backend)


MESH = Section("mesh", (
    Param("lo", VECTOR, None, unit="m", default_doc="the SPH solid region's box",
          doc="lower corner of the substrate box (the recipe's block / rectangle)"),
    Param("hi", VECTOR, None, unit="m", default_doc="the SPH solid region's box",
          doc="upper corner; the coupled surface is the `top` face (max of the last axis)"),
    Param("h_fine", float, None, unit="m", positive=True, quantity="mesh size",
          default_doc="2 `[sph] dx`", doc="element size near `refine_center`"),
    Param("h_coarse", float, None, unit="m", positive=True, quantity="mesh size",
          default_doc="8 `h_fine`", doc="element size far from it"),
    Param("refine_center", VECTOR, None, unit="m",
          default_doc="centre of the SPH region's top face", doc="centre of the refinement"),
    Param("refine_radius", float, None, unit="m", positive=True, quantity="length",
          default_doc="half the SPH region's largest lateral extent",
          doc="radius of the fine zone"),
    Param("growth", float, 1.3, gt=1.0, doc="element size ratio of neighbouring cells "
                                            "outside the fine zone"),
    Param("cells", str, None, choices=("hex", "tet", "quad", "tri"),
          default_doc='`"hex"` (3D), `"quad"` (2D)',
          doc="element shape (structured graded hex/quad or unstructured tet/tri)"),
), doc="Substrate mesh made by the gmsh recipe (`sphfem.fem.substrate_block` / "
       "`substrate_rect`) when `coupling.mesh_file` is not given; groups `top`, `bottom`, "
       "`left`, `right` (, `front`, `back`).")

COUPLING = Section("coupling", (
    Param("backend", str, "fem", choices=("fem", "fem-dynamic", "tlsph", "fem-axisymmetric"),
          doc="substrate model: quasi-static FEM (K factorised once), elastodynamic FEM "
              "(HHT-alpha / Newmark, `sphfem.fem.elastodynamic`; for loading faster than "
              "about 3 times the substrate's slowest mode 4 h / c_S, see "
              "docs/validation/substrate_dynamics), the TL-SPH solid, or the quasi-static "
              'axisymmetric FEM of a `geometry = "axisymmetric"` scene (its only backend; '
              "(r, z) mesh, hoop stress, ring forces: coupling.axisymmetric_scene)"),
    Param("hht_alpha", float, 0.0, ge=-1.0 / 3.0, le=0.0, when=("backend", ("fem-dynamic",)),
          doc="HHT-alpha parameter of the elastodynamic substrate: 0 = Newmark average "
              "acceleration (no numerical damping), down to -1/3 (damps the modes the mesh "
              "does not resolve; second order)"),
    Param("mass", str, "consistent", choices=("consistent", "lumped"),
          when=("backend", ("fem-dynamic",)),
          doc="mass matrix of the elastodynamic substrate (lumped: P1 only)"),
    Param("material", str, REQUIRED,
          doc="name of the `[materials.<name>]` table giving E, nu and alpha (alpha unset: "
              "no thermal strain)"),
    Param("blocks", STRINGS, None, default_doc="every wall/solid block of `material`",
          doc="blocks forming the SPH solid region (sensors and temperatures)"),
    Param("mesh_file", str, None,
          doc="substrate mesh (.msh, any meshio format); relative to the scene file; "
              "default: `[coupling.mesh]`"),
    Param("element", str, "P1", choices=("P1", "P2"), doc="displacement interpolation order"),
    Param("solver", str, "direct", choices=("direct", "cg-amg"),
          doc="direct (factorised once) or AMG-preconditioned CG"),
    Param("clamps", STRINGS, (), doc="mesh groups with every displacement component fixed"),
    Param("rollers", CUSTOM, None, convert=_rollers,
          type_doc="table {group = \"components\"}",
          doc="mesh groups with some components fixed, e.g. `{bottom = \"z\"}`"),
    Param("surface", str, "top", doc="mesh facet group the sensor forces act on"),
    Param("sensor_depth", float, None, unit="m", positive=True, quantity="length",
          default_doc="the support radius R",
          doc="sensors: region particles within this distance below the surface"),
    Param("temperature_map", str, "mls", choices=("mls", "shepard", "nearest", "off"),
          doc="particle temperatures -> mesh nodes: linear moving least squares (exact for "
              "linear fields), Shepard, nearest particle, or off (no thermal load); nodes "
              "outside the SPH solid region keep T0"),
    Param("T0", TEMPERATURE, None, unit="K", default_doc="the region's initial temperature",
          doc="stress-free reference temperature of the substrate"),
    Param("every_k_steps", int, None, ge=1,
          default_doc="from the time scales (coupling.driver.default_every_k)",
          doc="one substrate solve every this many SPH steps (and at the last step)"),
    Param("probes", CUSTOM, None, convert=_points, type_doc="list of points (float[dim] each)",
          default_doc="5 points under the centre of the coupled surface",
          doc="points where the stress history is recorded [m]"),
    Param("output", str, "substrate", doc="subfolder of the run's output folder"),
    Param("vtu_every", int, 10, ge=0,
          doc="write the substrate VTU every this many solves (0: the last only)"),
), subsections=(MESH, HEAT_SECTION), check=_check, doc=(
    "One-way staggered coupling (Park 2019 sec. 2.4.4): every `every_k_steps` SPH steps the "
    "sensor particles (the SPH solid region's surface layers) hand the force the fluid exerts "
    "on them (f = P^T F, total force and moment conserved) and the region's temperatures "
    "(mapped to the mesh nodes) to the substrate backend, which solves once; the stress "
    "history at the probes goes to `<out>/<output>/probes.csv`, `history.json` and "
    "summary.json, the substrate fields to `<out>/<output>/substrate.pvd`."))
