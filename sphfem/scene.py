"""Scene files: TOML -> a validated, read-only :class:`Scene` with every default filled in.

``load_scene(path)`` reads a file, ``parse_scene(dict)`` validates an already parsed dict,
``parse_scene_toml(text)`` parses TOML text.  Every mistake raises :class:`SceneError`
whose ``str()`` is one line ``source: key: message``, e.g.
``drop.toml: blocks[1].radius: expected a positive length in m, got -0.1``.

The keys are declared in :mod:`sphfem.schema` (core sections below; physics modules add
theirs with :func:`sphfem.schema.register_module`); ``docs/scenes.md`` is generated from
the same declarations.

Attribute layout of a :class:`Scene`::

    scene.source, scene.name, scene.dim, scene.description, scene.seed
    scene.domain.lo / .hi (tuples, m) / .periodic (tuple of bool)
    scene.sph.kernel / .dx / .support_factor;  scene.support_radius (= support_factor * dx)
    scene.materials["water"].rho0 / .c / .k / .mu / .c0 (m/s; "physical" resolved to
                             .sound_speed) / .sound_speed / .sigma / .E / .nu / .alpha
    scene.blocks[i].name / .shape / .kind / .material / .sampling / .velocity /
                   .temperature (K) / .dx (None = sph.dx) / .above / .gap and, by shape,
                   .lo .hi (box) | .center .radius (sphere) | .center .radius .length .axis
    scene.physics.modules (tuple of str)
    scene.time.t_end / .dt (None) / .cfl / .max_steps (None) / .tc_block (None); times
                   given as "<x> tc" are in seconds here (sphfem.time_units)
    scene.output.every (None) / .format / .fields (None) / .exact_times (True)
    scene.heat, scene.fluid, ... : the section of each listed module (None if not listed)
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from sphfem.errors import SceneError
from sphfem.kernels import KERNELS
from sphfem.particles import KIND_NAMES
from sphfem.schema.declarations import (
    BOOLS,
    REQUIRED,
    STRINGS,
    TEMPERATURE,
    VECTOR,
    FrozenDict,
    Param,
    Record,
    Section,
    to_plain,
)
from sphfem.schema.registry import (
    MODULE_SECTIONS,
    SECTIONS,
    import_for,
    known_modules,
    register_section,
)
from sphfem.schema.validate import Context, key_text, suggest, validate_section
from sphfem.sound_speed import C0, SOUND_SPEED, resolve_sound_speeds
from sphfem.time_units import TC_BLOCK, check_time, resolve_times, time_param

__all__ = ["Scene", "SceneError", "load_scene", "parse_scene", "parse_scene_toml"]

AXES = "xyz"
BLOCK_KINDS = tuple(k for k in KIND_NAMES if k != "ghost")
SHAPES = ("box", "sphere", "cylinder")
#: values of ``[scene] geometry``
GEOMETRIES = ("cartesian", "axisymmetric")
#: a block estimated to need more particles than this is rejected (a typo in dx, usually)
MAX_PARTICLES_PER_BLOCK = 1e8


# --------------------------------------------------------------------------------------
# core section declarations


def _check_domain(rec, ctx, path):
    for a, (lo, hi) in enumerate(zip(rec.lo, rec.hi, strict=True)):
        if not hi > lo:
            ctx.error(f"{path}.hi", f"must exceed {path}.lo on every axis; axis {AXES[a]}: "
                                    f"hi = {hi:g} <= lo = {lo:g}")


def _check_block(rec, ctx, path):
    if rec.shape == "box":
        for a, (lo, hi) in enumerate(zip(rec.lo, rec.hi, strict=True)):
            if not hi > lo:
                ctx.error(f"{path}.hi", f"must exceed {path}.lo on every axis; axis "
                                        f"{AXES[a]}: hi = {hi:g} <= lo = {lo:g}")
    if rec.sampling == "shells" and (rec.shape != "sphere" or ctx.dim == 1):
        ctx.error(f"{path}.sampling", f'"shells" fills a sphere (disc) in 2D or 3D, got a '
                                      f"{rec.shape} in {ctx.dim}D")
    if rec.shape == "cylinder" and AXES.index(rec.axis) >= ctx.dim:
        ctx.error(f"{path}.axis", f"axis {rec.axis!r} does not exist in {ctx.dim}D; expected "
                                  + " or ".join(repr(a) for a in AXES[: ctx.dim]))


SCENE = Section("scene", (
    Param("name", str, None, doc="run name (default: the file name without .toml)"),
    Param("dim", int, REQUIRED, choices=(1, 2, 3), doc="spatial dimension"),
    Param("geometry", str, "cartesian", choices=GEOMETRIES,
          doc='"cartesian", or "axisymmetric": a body of revolution about the z axis, '
              "dim = 2 with coordinates (r, z) (r >= 0: the domain's lo[0] is 0 and a block "
              "may cross the axis, only its r >= 0 part is filled; lattice sampling); each "
              "particle is a ring: `vol` = 2 pi r A and `m` = rho 2 pi r A (A = dx^2 its "
              "meridian area); the listed modules take their axisymmetric forms "
              "(sphfem.axisymmetric_scene)"),
    Param("description", str, "", doc="free text, echoed in summary.json"),
    Param("seed", int, 0, ge=0,
          doc="random seed (Poisson sampling of block i uses the stream (seed, i))"),
), doc="Name, dimension and seed of the run.", required=True)

DOMAIN = Section("domain", (
    Param("lo", VECTOR, REQUIRED, unit="m", doc="lower corner of the simulation box"),
    Param("hi", VECTOR, REQUIRED, unit="m", doc="upper corner (> lo on every axis)"),
    Param("periodic", BOOLS, lambda dim: (False,) * dim, default_doc="all `false`",
          doc="periodic flag per axis"),
), doc="The axis-aligned simulation box; every block must lie inside it.", required=True,
    check=_check_domain)

SPH = Section("sph", (
    Param("kernel", str, "wendland_c2", choices=tuple(KERNELS),
          doc="smoothing kernel (Wendland C2 = the thesis' quintic Wendland)"),
    Param("dx", float, REQUIRED, unit="m", positive=True, quantity="spacing",
          doc="particle spacing"),
    Param("support_factor", float, 3.0, gt=1.0,
          doc="support radius R = support_factor * dx; must exceed the spacing (> 1)"),
    Param("skin", float, None, ge=0.0, le=1.0, default_doc="0.15 when a module moves "
          "particles, else 0",
          doc="Verlet skin: neighbours are listed within (1 + skin) R and the list is rebuilt "
          "only when a particle has moved more than skin R / 2"),
    Param("sort_every", int, 10, ge=0,
          doc="re-sort particles by cell every this many neighbour rebuilds (0 = never)"),
), doc="Discretisation shared by every SPH operator.", required=True)

_POSITIVE_OPT = dict(positive=True, default=None)
MATERIALS = Section("materials", (
    Param("rho0", float, REQUIRED, unit="kg/m^3", positive=True, doc="reference density"),
    Param("c", float, unit="J/(kg K)", doc="specific heat capacity", **_POSITIVE_OPT),
    Param("k", float, unit="W/(m K)", doc="thermal conductivity", **_POSITIVE_OPT),
    Param("mu", float, unit="Pa s", doc="dynamic viscosity", **_POSITIVE_OPT),
    C0,  # a number or "physical" (sphfem.sound_speed)
    SOUND_SPEED,
    Param("sigma", float, unit="N/m",
          doc="physical surface tension coefficient (not a force-model calibration constant)",
          **_POSITIVE_OPT),
    Param("E", float, unit="Pa", quantity="Young's modulus", doc="Young's modulus",
          **_POSITIVE_OPT),
    Param("nu", float, None, gt=-1.0, lt=0.5, doc="Poisson's ratio"),
    Param("alpha", float, unit="1/K", doc="linear thermal expansion coefficient",
          **_POSITIVE_OPT),
), open_keys=True, doc=(
    "Named materials, e.g. `[materials.water]`; blocks refer to them by name and a "
    "particle's `material` field is the position of its material in this table. Only "
    "`rho0` is required here; each physics module checks the properties it needs."))

_ROUND = ("sphere", "cylinder")
BLOCKS = Section("blocks", (
    Param("name", str, None, doc="block name (default `block<i>`), unique"),
    Param("shape", str, REQUIRED, choices=SHAPES, doc="geometry of the block"),
    Param("kind", str, REQUIRED, choices=BLOCK_KINDS, doc="particle kind"),
    Param("material", str, REQUIRED, doc="name of a `[materials.<name>]` table"),
    Param("sampling", str, "lattice", choices=("lattice", "poisson", "shells"),
          doc="particle placement: Cartesian lattice, Poisson-disk blue noise, or (a "
              "sphere in 2D or 3D) concentric shells with a smooth surface"),
    Param("lo", VECTOR, REQUIRED, unit="m", when=("shape", ("box",)), doc="lower corner"),
    Param("hi", VECTOR, REQUIRED, unit="m", when=("shape", ("box",)), doc="upper corner"),
    Param("center", VECTOR, REQUIRED, unit="m", when=("shape", _ROUND),
          doc="centre (of a cylinder: mid-length on its axis)"),
    Param("radius", float, REQUIRED, unit="m", positive=True, when=("shape", _ROUND),
          doc="radius"),
    Param("length", float, REQUIRED, unit="m", positive=True, when=("shape", ("cylinder",)),
          doc="cylinder length along its axis"),
    Param("axis", str, lambda dim: AXES[dim - 1] if dim == 3 else AXES[min(dim, 2) - 1],
          choices=tuple(AXES), when=("shape", ("cylinder",)),
          default_doc='`"z"` in 3D, `"y"` in 2D, `"x"` in 1D', doc="cylinder axis"),
    Param("velocity", VECTOR, lambda dim: (0.0,) * dim, unit="m/s",
          default_doc="zeros", doc="initial velocity of every particle"),
    Param("temperature", TEMPERATURE, 293.15, unit="K", doc="initial temperature"),
    Param("dx", float, None, unit="m", positive=True, quantity="spacing",
          doc="particle spacing of this block (default: `[sph] dx`)"),
    Param("jitter", float, 0.0, ge=0.0, lt=0.5,
          doc="random disorder: each coordinate moves by a uniform amount in "
              "[-jitter dx, jitter dx] (stream (seed, i, 1)); 0 keeps the sampling as is"),
    Param("above", str, None,
          doc="name of an earlier block: this block is moved along the last axis (z in "
              "3D, y in 2D) so that its lowest point lies `gap` above that block's highest "
              "point (the given vertical coordinate of `center` or `lo`/`hi` is replaced; "
              "see sphfem.geometry.place_above)"),
    Param("gap", float, None, unit="m", positive=True, quantity="clearance",
          default_doc="the support radius R",
          doc="clearance to the block named in `above`; must be >= the kernel support "
              "radius R = support_factor dx, so that no particle of the two blocks "
              "interacts at t = 0 (first contact is recorded in summary.json)"),
), repeated=True, min_count=1, check=_check_block, doc=(
    "Bodies filled with particles, one `[[blocks]]` table each (at least one)."))

PHYSICS = Section("physics", (
    Param("modules", STRINGS, (), doc="physics modules to build and step, in this order; "
                                      "nothing else is built"),
), doc="The physics this scene needs (see the registered modules below).")

TIME = Section("time", (
    time_param("t_end", REQUIRED, 'end time, counted from t = 0: seconds, or a multiple '
               'of the impact time tc = D / |v| of the moving fluid sphere, e.g. "4 tc" '
               '(sphfem.time_units)'),
    time_param("dt", None, "fixed time step (capped by the stable limits unless "
               "`cap_dt = false`)", "time step"),
    Param("cap_dt", bool, True,
          doc="cap a fixed `dt` at the modules' stable limits; `false` uses `dt` as given "
              "(for stability studies: the guards then stop an unstable run)"),
    Param("cfl", float, 0.25, gt=0.0, le=1.0, doc="Courant number of the stable time step"),
    Param("max_steps", int, None, ge=1, doc="stop after this many steps"),
    TC_BLOCK,
), doc="Time stepping.", required=True, check=check_time)

OUTPUT = Section("output", (
    time_param("every", None, 'simulated time between particle outputs (seconds or '
               '"0.25 tc"; default: first and last state)', "interval"),
    Param("format", str, "vtu", choices=("vtu",), doc="particle file format (VTU + PVD)"),
    Param("fields", STRINGS, None, doc="particle fields to write (default: all)"),
    Param("exact_times", bool, True,
          doc="`true`: the step is shortened to land on each output time (outputs at "
              "exactly every `every`); `false`: the step is never shortened and an output "
              "is written after the first step that reaches its time, so the run itself "
              "does not depend on `every` (a flow sensitive to small perturbations, e.g. a "
              "lamella's late spreading, otherwise changes with the output interval)"),
), doc="Result files.")

CORE = (SCENE, DOMAIN, SPH, MATERIALS, BLOCKS, PHYSICS, TIME, OUTPUT)
for _s in CORE:
    register_section(_s)


# --------------------------------------------------------------------------------------
# the scene object


@dataclass(frozen=True)
class Scene:
    """A validated scene (read-only).  See the module docstring for the attribute layout."""

    source: str
    name: str
    dim: int
    description: str
    seed: int
    domain: Record
    sph: Record
    materials: FrozenDict
    blocks: tuple
    physics: Record
    time: Record
    output: Record
    sections: FrozenDict  # physics-module sections of the listed modules, by section name
    geometry: str = "cartesian"  # or "axisymmetric": (r, z), particles are rings

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        secs = self.__dict__.get("sections", {})
        if name in secs:
            return secs[name]
        if name in SECTIONS and SECTIONS[name].module is not None:
            return None  # a registered module that this scene does not use
        raise AttributeError(f"Scene has no attribute or section {name!r}")

    @property
    def support_radius(self) -> float:
        """Kernel support radius R = support_factor * dx [m]."""
        return self.sph.support_factor * self.sph.dx

    @property
    def material_names(self) -> tuple[str, ...]:
        return tuple(self.materials)

    def material_index(self, name: str) -> int:
        """The particle ``material`` value of material ``name`` (its table position)."""
        return self.material_names.index(name)

    def block_index(self, name: str) -> int:
        return [b.name for b in self.blocks].index(name)

    def to_dict(self) -> dict:
        """Resolved scene (defaults filled, kelvin), JSON-serialisable; parse_scene() accepts it."""
        out = {
            "scene": {"name": self.name, "dim": self.dim, "geometry": self.geometry,
                      "description": self.description, "seed": self.seed},
            "domain": self.domain.to_dict(),
            "sph": self.sph.to_dict(),
            "materials": to_plain(self.materials),
            "blocks": [b.to_dict() for b in self.blocks],
            "physics": self.physics.to_dict(),
            "time": self.time.to_dict(),
            "output": self.output.to_dict(),
        }
        out.update({k: to_plain(v) for k, v in self.sections.items()})
        return out

    def __eq__(self, other):
        if not isinstance(other, Scene):
            return NotImplemented
        return all(getattr(self, f.name) == getattr(other, f.name)
                   for f in fields(self) if f.name != "source")

    __hash__ = None


# --------------------------------------------------------------------------------------
# parsing


def load_scene(path) -> Scene:
    """Read and validate the TOML scene file ``path``."""
    source = str(path)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except OSError as e:
        raise SceneError(source, "", f"cannot read scene file: {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise SceneError(source, "", f"not UTF-8 text (byte {e.start})") from None
    return parse_scene_toml(text, source=source)


_TOML_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_TOML_EOF = re.compile(r"\s*\(at end of document\)\s*$")


def parse_scene_toml(text: str, source: str = "<string>") -> Scene:
    """Parse TOML text and validate it (TOML syntax errors name the line)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = _TOML_POS.search(msg)
        if m:
            raise SceneError(source, f"line {m.group(1)}",
                             f"invalid TOML: {msg[: m.start()]} (column {m.group(2)})") from None
        m = _TOML_EOF.search(msg)
        if m:
            raise SceneError(source, "end of file", f"invalid TOML: {msg[: m.start()]}") from None
        raise SceneError(source, "", f"invalid TOML: {msg}") from None
    return parse_scene(data, source=source)


def parse_scene(data, source: str = "<string>") -> Scene:
    """Validate a parsed scene dict (as from ``tomllib``) into a :class:`Scene`."""
    ctx = Context(source)
    if not isinstance(data, dict):
        ctx.error("", f"a scene must be a table of sections, got {type(data).__name__}")
    data = {k: v for k, v in data.items() if v is not None}

    # physics packages register their sections on import: import those the scene names
    mods_raw = data.get("physics", {}).get("modules", []) if isinstance(
        data.get("physics"), dict) else []
    wanted = [m for m in (mods_raw if isinstance(mods_raw, list) else []) if isinstance(m, str)]
    for name in wanted + [str(k) for k in data if k not in SECTIONS]:
        if name not in MODULE_SECTIONS:
            import_for(name)

    core = [s.name for s in CORE]
    for key in data:
        if key not in SECTIONS:
            ctx.error(key_text(key), "unknown section" + suggest(key, list(SECTIONS)))

    meta = validate_section(SCENE, data.get("scene"), ctx)
    ctx.dim = meta.dim
    ctx.geometry = meta.geometry
    if meta.geometry == "axisymmetric" and meta.dim != 2:
        ctx.error("scene.dim", f'geometry = "axisymmetric" needs dim = 2 (r, z), got {meta.dim}')
    rec = {name: validate_section(SECTIONS[name], data.get(name), ctx)
           for name in core if name != "scene"}

    # physics modules and their sections
    known = known_modules()
    modules = rec["physics"].modules
    for i, m in enumerate(modules):
        if m not in known:
            reg = ", ".join(known) if known else "none yet"
            hint = suggest(m, known) if known else ""
            ctx.error(f"physics.modules[{i}]", f"unknown physics module {m!r}"
                      + (hint if hint.startswith("; did") else "") + f" (registered: {reg})")
        if m in modules[:i]:
            ctx.error(f"physics.modules[{i}]", f"module {m!r} is listed twice")
    rec["materials"] = resolve_sound_speeds(rec["materials"], ctx)  # c0 = "physical"
    if meta.geometry == "axisymmetric":
        _check_axisymmetric(rec, ctx)
    blocks = _resolve_blocks(rec["blocks"], rec["materials"], rec["domain"], rec["sph"], ctx)
    rec.update(resolve_times(rec, blocks, ctx))  # times in tc = D / |v|
    # module sections' check(rec, ctx, path) may cross-reference the core: ctx.core["blocks"]
    ctx.core = {"scene": meta, **rec, "blocks": blocks}
    sections = {}
    for key in data:
        sec = SECTIONS[key]
        if sec.module is not None and sec.module not in modules:
            ctx.error(key, f"section [{key}] belongs to physics module {sec.module!r}, which is "
                           f"not listed in physics.modules; add it there or remove the section")
    for m in modules:
        sec_name = MODULE_SECTIONS.get(m)
        if sec_name is not None:
            sections[sec_name] = validate_section(SECTIONS[sec_name], data.get(sec_name), ctx)

    name = meta.name if meta.name is not None else _default_name(source)
    return Scene(
        source=source, name=name, dim=meta.dim, description=meta.description, seed=meta.seed,
        domain=rec["domain"], sph=rec["sph"], materials=rec["materials"], blocks=blocks,
        physics=rec["physics"], time=rec["time"], output=rec["output"],
        sections=FrozenDict(sections), geometry=meta.geometry,
    )


def _check_axisymmetric(rec, ctx) -> None:
    """An axisymmetric scene: the domain starts at the axis (lo[0] = 0, r not periodic) and
    every block is a lattice or shells (a Poisson sample puts rings arbitrarily close to the
    axis)."""
    dom = rec["domain"]
    if dom.lo[0] != 0.0:
        ctx.error("domain.lo", f'geometry = "axisymmetric": the domain starts at the axis, '
                               f"lo[0] = 0 (r), got {dom.lo[0]:g}")
    if dom.periodic[0]:
        ctx.error("domain.periodic", 'geometry = "axisymmetric": r cannot be periodic')
    for i, b in enumerate(rec["blocks"]):
        if b.sampling == "poisson":
            ctx.error(f"blocks[{i}].sampling", 'geometry = "axisymmetric" takes "lattice" or '
                                               '"shells" blocks (rings off the axis), got '
                                               f"{b.sampling!r}")


def _default_name(source: str) -> str:
    if source.startswith("<"):
        return "scene"
    return Path(source).stem or "scene"


def _resolve_blocks(blocks, materials, domain, sph, ctx) -> tuple:
    from sphfem.geometry import Shape, place_above

    out = []
    seen = {}
    for i, b in enumerate(blocks):
        path = f"blocks[{i}]"
        if b.name is None:
            b = b.replace(name=f"block{i}")
        if b.name in seen:
            ctx.error(f"{path}.name", f"block name {b.name!r} already used by "
                                      f"blocks[{seen[b.name]}]")
        seen[b.name] = i
        if b.material not in materials:
            known = list(materials)
            hint = suggest(b.material, known)
            ctx.error(f"{path}.material", f"unknown material {b.material!r}"
                      + (hint if hint.startswith("; did") else "")
                      + (f" (defined: {', '.join(known)})" if known
                         else "; no [materials.<name>] table is defined"))
        b = place_above(b, {c.name: c for c in out}, sph.support_factor * sph.dx, ctx,
                        path)
        lo, hi = Shape.from_block(b, ctx.dim).bounds()
        tol = 1e-9 * max(h - l for l, h in zip(domain.lo, domain.hi, strict=True))
        if getattr(ctx, "geometry", "cartesian") == "axisymmetric":
            lo = (max(lo[0], 0.0), *lo[1:])  # only the part r >= 0 is filled
        for a in range(ctx.dim):
            if lo[a] < domain.lo[a] - tol or hi[a] > domain.hi[a] + tol:
                ctx.error(path, f"block {b.name!r} ({b.shape}) extends outside the domain on "
                                f"axis {AXES[a]}: [{lo[a]:g}, {hi[a]:g}] is not within "
                                f"[{domain.lo[a]:g}, {domain.hi[a]:g}]")
        dx = b.dx if b.dx is not None else sph.dx
        # (vol^(1/d) / dx)^d: dx^d alone overflows a float for dx > ~1e103 (3D)
        estimate = (Shape.from_block(b, ctx.dim).volume() ** (1.0 / ctx.dim) / dx) ** ctx.dim
        if not estimate <= MAX_PARTICLES_PER_BLOCK:
            ctx.error(f"{path}.dx" if b.dx is not None else "sph.dx",
                      f"block {b.name!r} would get about {estimate:.3g} particles (limit "
                      f"{MAX_PARTICLES_PER_BLOCK:.0e}); the spacing is too small")
        out.append(b)
    return tuple(out)
