"""Declarative scene parameters: one declaration feeds validation, defaults and the docs.

A :class:`Section` is a TOML table (``[sph]``), an array of tables (``[[blocks]]``,
``repeated=True``) or a table of named tables (``[materials.<name>]``, ``open_keys=True``).
It holds :class:`Param` declarations with type, unit, default, bounds and a one-line
description, and optionally nested sub-sections (``[coupling.mesh]``,
``[[heat.boundaries]]``).  Validation turns the parsed TOML dict into read-only
:class:`Record` objects with every default filled in and raises :class:`SceneError` -- one
line naming the file and the key -- on the first mistake.  A key declared with ``when=``
is present in the record only when its condition holds (read it with ``"key" in rec``
first, as cross-key checks must).

Registries (global, filled at import time):

* :data:`SECTIONS` -- every known top-level section; the core ones (``scene``, ``domain``,
  ``sph``, ``materials``, ``blocks``, ``physics``, ``time``, ``output``) are registered by
  :mod:`sphfem.scene`.
* :data:`MODULES` -- the physics-module names a scene may list in ``[physics] modules``.
  A physics package registers itself, and optionally its own section, in its
  ``__init__`` (the section declared in its ``scene_section.py``), e.g. sphfem.heat::

      register_module("heat", HEAT, target="sphfem.heat.module:HeatConduction")

  A module's section may only appear in a scene that lists the module.

Parameter types: ``float``, ``int``, ``bool``, ``str`` (optionally with ``choices``),
``VECTOR`` (floats, one per axis), ``BOOLS`` (bools, one per axis), ``STRINGS`` (list of
str), ``TEMPERATURE`` (a number is kelvin; a string ``"100 C"``, ``"100 degC"``,
``"100 °C"`` or ``"373.15 K"`` is converted to kelvin), ``CUSTOM`` (checked by the
param's ``convert(value, ctx, key)``, which calls ``ctx.error(key, message)`` on a bad
value; ``type_doc`` describes the accepted values).  Sub-sections may themselves be
repeated (``[[heat.boundaries]]``) or open-key tables.

``python -m sphfem.schema`` rewrites ``docs/scenes.md`` from the registered declarations.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import json
import math
import pkgutil
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from sphfem.errors import SceneError

VECTOR = "vector"
BOOLS = "bools"
STRINGS = "strings"
TEMPERATURE = "temperature"
#: a value checked by the param's own ``convert(value, ctx, key)`` (document it in ``type_doc``)
CUSTOM = "custom"

_TYPES = (float, int, bool, str, VECTOR, BOOLS, STRINGS, TEMPERATURE, CUSTOM)


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


#: default of a parameter that must be given
REQUIRED = _Required()


# quantity names used in messages ("expected a positive length in m")
_QUANTITY = {
    "m": "length",
    "s": "time",
    "kg/m^3": "density",
    "m/s": "velocity",
    "Pa": "pressure",
    "Pa s": "viscosity",
    "K": "temperature",
    "1/K": "expansion coefficient",
    "N/m": "surface tension",
    "W/(m K)": "conductivity",
    "J/(kg K)": "specific heat",
}


@dataclass(frozen=True)
class Param:
    """One scene key.

    ``default`` is :data:`REQUIRED`, a value, ``None`` (optional, no value) or a callable
    ``f(dim)`` (then give ``default_doc`` for the docs).  Bounds: ``positive`` (> 0),
    ``gt``/``ge``/``lt``/``le``, or ``bounds=(ge, le)``; for vectors they apply to every
    component.  ``when=("shape", ("sphere", "cylinder"))`` makes the key apply only when the
    sibling key has one of those values (it is an error to give it otherwise).
    ``length`` of vectors is ``"dim"`` (the scene dimension) or a fixed int.
    """

    name: str
    type: Any
    default: Any = REQUIRED
    unit: str = ""
    doc: str = ""
    positive: bool = False
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    bounds: tuple | None = None
    choices: tuple | None = None
    length: Any = "dim"
    when: tuple | None = None
    quantity: str = ""
    default_doc: str = ""
    convert: Callable | None = field(default=None, compare=False)
    type_doc: str = ""

    def __post_init__(self):
        if self.type is CUSTOM and (self.convert is None or not self.type_doc):
            raise TypeError(f"Param {self.name!r}: CUSTOM needs convert= and type_doc=")
        if self.type not in _TYPES:
            raise TypeError(f"Param {self.name!r}: unknown type {self.type!r}")
        if self.bounds is not None:
            lo, hi = self.bounds
            object.__setattr__(self, "ge", lo)
            object.__setattr__(self, "le", hi)
            object.__setattr__(self, "bounds", None)
        if self.positive:
            object.__setattr__(self, "gt", 0.0 if self.gt is None else max(self.gt, 0.0))
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))
        if self.when is not None:
            object.__setattr__(self, "when", (self.when[0], tuple(self.when[1])))

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def expectation(self, dim: int | None = None) -> str:
        """What a valid value looks like, e.g. ``a positive length in m``."""
        if self.type is CUSTOM:
            return self.type_doc
        if self.choices is not None:
            return "one of " + ", ".join(_show(c) for c in self.choices)
        if self.type is bool:
            return "true or false"
        if self.type is STRINGS:
            return "a list of strings"
        if self.type is str:
            return "a string"
        if self.type is TEMPERATURE:
            return ('a temperature above 0 K (a number in K, or a string such as '
                    '"100 C" or "373.15 K")')
        n = self.length if self.length != "dim" else dim
        count = f"{n} " if n is not None else ""
        if self.type is BOOLS:
            return f"a list of {count}booleans (one per axis)"
        scalar = self._scalar_expectation(plural=self.type is VECTOR)
        if self.type is VECTOR:
            return f"a vector of {count}{scalar} (one per axis)"
        return scalar

    def _scalar_expectation(self, plural: bool = False) -> str:
        integer = self.type is int
        qty = self.quantity or _QUANTITY.get(self.unit, "")
        noun = "integer" if integer else (qty or "number")
        if plural:
            noun = noun[:-1] + "ies" if re.search(r"[^aeiou]y$", noun) else noun + "s"
        unit = f" in {self.unit}" if self.unit and self.unit != "1" else ""
        rng = self._range_text()
        if self.gt == 0 and self.lt is None and self.le is None:
            return f"{'' if plural else 'a '}positive {noun}{unit}"
        if self.ge == 0 and self.lt is None and self.le is None:
            return f"{'' if plural else 'a '}non-negative {noun}{unit}"
        art = "" if plural else ("an " if noun[0] in "aeiou" else "a ")
        return f"{art}{noun}{unit}{(' ' + rng) if rng else ''}"

    def _range_text(self) -> str:
        lo = (f"({_num(self.gt)}" if self.gt is not None
              else f"[{_num(self.ge)}" if self.ge is not None else None)
        hi = (f"{_num(self.lt)})" if self.lt is not None
              else f"{_num(self.le)}]" if self.le is not None else None)
        if lo and hi:
            return f"in {lo}, {hi}"
        if lo:
            return f"{'>' if lo[0] == '(' else '>='} {lo[1:]}"
        if hi:
            return f"{'<' if hi[-1] == ')' else '<='} {hi[:-1]}"
        return ""

    def in_range(self, x: float) -> bool:
        return (
            math.isfinite(x)
            and (self.gt is None or x > self.gt)
            and (self.ge is None or x >= self.ge)
            and (self.lt is None or x < self.lt)
            and (self.le is None or x <= self.le)
        )


@dataclass(frozen=True)
class Section:
    """A scene table: ``[name]``, ``[[name]]`` (``repeated``) or ``[name.<key>]`` (``open_keys``).

    ``subsections`` are nested tables (``[coupling.mesh]``); a missing sub-section gets its
    defaults.  ``check(record, ctx, path)`` runs after the keys are validated and may call
    ``ctx.error(key, message)`` for cross-key rules.  ``module`` is set by
    :func:`register_module`.  ``required``: the table itself must be present.
    ``min_count``: least number of entries of a repeated / open-key section.
    """

    name: str
    params: tuple = ()
    doc: str = ""
    repeated: bool = False
    open_keys: bool = False
    subsections: tuple = ()
    check: Callable | None = field(default=None, compare=False)
    module: str | None = None
    required: bool = False
    min_count: int = 0

    def __post_init__(self):
        object.__setattr__(self, "params", tuple(self.params))
        object.__setattr__(self, "subsections", tuple(self.subsections))
        names = [p.name for p in self.params] + [s.name for s in self.subsections]
        if len(set(names)) != len(names):
            raise ValueError(f"section {self.name!r} declares a key twice")

    def param(self, name: str) -> Param:
        return next(p for p in self.params if p.name == name)

    @property
    def keys(self) -> list[str]:
        return [p.name for p in self.params] + [s.name for s in self.subsections]


class Record:
    """A read-only namespace of validated values (attribute and item access, ``to_dict``)."""

    __slots__ = ("_data",)

    def __init__(self, **values):
        object.__setattr__(self, "_data", dict(values))

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        try:
            return self._data[name]
        except KeyError:
            raise AttributeError(
                f"no parameter {name!r}; known: {', '.join(self._data)}"
            ) from None

    def __setattr__(self, name, value):
        raise AttributeError("scene parameters are read-only; use .replace(key=value)")

    def __getitem__(self, name):
        return self._data[name]

    def __contains__(self, name) -> bool:
        return name in self._data

    def __iter__(self):
        return iter(self._data)

    def __eq__(self, other) -> bool:
        return isinstance(other, Record) and self._data == other._data

    def __hash__(self):
        return hash(tuple(self._data))

    def __repr__(self) -> str:
        return "Record(" + ", ".join(f"{k}={v!r}" for k, v in self._data.items()) + ")"

    def __reduce__(self):
        return (_record_from_dict, (self._data,))

    def keys(self):
        return self._data.keys()

    def items(self):
        return self._data.items()

    def replace(self, **changes) -> Record:
        """A copy with some values changed (no validation)."""
        unknown = set(changes) - set(self._data)
        if unknown:
            raise AttributeError(f"no parameter(s) {sorted(unknown)}")
        return Record(**{**self._data, **changes})

    def to_dict(self) -> dict:
        """Plain JSON-serialisable dict (tuples become lists, records dicts)."""
        return {k: to_plain(v) for k, v in self._data.items()}


def _record_from_dict(d):
    return Record(**d)


class FrozenDict(dict):
    """A dict that refuses changes (named materials); picklable, JSON-friendly."""

    def _ro(self, *a, **k):
        raise TypeError("scene tables are read-only")

    __setitem__ = __delitem__ = clear = pop = popitem = setdefault = update = _ro

    def __reduce__(self):
        return (FrozenDict, (dict(self),))


def to_plain(v):
    """Convert records, tuples and frozen dicts to plain JSON types."""
    if isinstance(v, Record):
        return v.to_dict()
    if isinstance(v, Mapping):
        return {k: to_plain(x) for k, x in v.items()}
    if isinstance(v, (tuple, list)):
        return [to_plain(x) for x in v]
    return v


# --------------------------------------------------------------------------------------
# registries

#: every top-level section a scene may contain, by name
SECTIONS: dict[str, Section] = {}
#: physics-module names a scene may list, with the name of their section (or None)
MODULES: dict[str, str | None] = {}


def register_section(section: Section, *, replace_existing: bool = False) -> Section:
    """Make ``[section.name]`` a known scene section (idempotent for an equal declaration)."""
    old = SECTIONS.get(section.name)
    if old is not None and old != section and not replace_existing:
        raise ValueError(f"scene section [{section.name}] is already registered")
    SECTIONS[section.name] = section
    return section


def register_module(name: str, section: Section | None = None, *, target: str | None = None,
                    replace_existing: bool = False) -> None:
    """Register physics module ``name`` (listed in ``[physics] modules``).

    ``section``: its parameter table, allowed in a scene only when the module is listed
    (missing from such a scene, it gets its defaults).  ``target``: ``"pkg.mod:Class"``,
    forwarded to :func:`sphfem.physics.register_physics` so the driver can build it.
    """
    new = replace(section, module=name) if section is not None else None
    if name in MODULES and not replace_existing:
        old = SECTIONS.get(MODULES[name]) if MODULES[name] is not None else None
        if old != new:
            raise ValueError(f"physics module {name!r} is already registered")
    if new is not None:
        register_section(new, replace_existing=True)
    MODULES[name] = section.name if section is not None else None
    if target is not None:
        from sphfem.physics import register_physics

        register_physics(name, target)


def unregister(name: str) -> None:
    """Remove module and/or section ``name`` (for tests)."""
    sec = MODULES.pop(name, None)
    if sec is not None:
        SECTIONS.pop(sec, None)
    s = SECTIONS.get(name)
    if s is not None and (s.module is None or s.module == name):
        SECTIONS.pop(name, None)


def known_modules() -> list[str]:
    """Module names a scene may list: this registry plus :data:`sphfem.physics.MODULES`."""
    names = list(MODULES)
    try:
        from sphfem.physics import MODULES as targets
    except ImportError:  # pragma: no cover - physics protocol not available
        targets = {}
    return names + [n for n in targets if n not in MODULES]


#: entry-point group through which installed packages add scene sections and physics
#: modules: ``[project.entry-points."sphfem.physics"] name = "package"`` in their
#: pyproject.toml; importing ``package`` registers them (sphfem names none of them)
ENTRY_POINT_GROUP = "sphfem.physics"
#: sphfem sub-packages that never register scene sections
_NOT_PHYSICS = {"validation"}


def plugin_packages() -> dict[str, str]:
    """Installed packages that register sections, by entry-point name -> importable package
    (group :data:`ENTRY_POINT_GROUP`; those whose package cannot be found are left out)."""
    from importlib.metadata import entry_points

    found = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        pkg = ep.value.split(":")[0]
        if importlib.util.find_spec(pkg.split(".")[0]) is not None:
            found[ep.name] = pkg
    return found


def physics_packages() -> list[str]:
    """Importable packages that may register sections: sphfem sub-packages and the plugin
    packages of :func:`plugin_packages`."""
    import sphfem

    names = [f"sphfem.{m.name}" for m in pkgutil.iter_modules(sphfem.__path__)
             if m.ispkg and m.name not in _NOT_PHYSICS]
    names += list(plugin_packages().values())
    return sorted(set(names))


def import_for(name: str) -> None:
    """Import what registers module/section ``name``: ``sphfem.<name>`` and its target."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name or ""):
        return
    plugins = plugin_packages()
    if name in plugins:
        importlib.import_module(plugins[name])  # an installed package registering ``name``
    pkg = f"sphfem.{name}"
    spec = importlib.util.find_spec(pkg) if name not in _NOT_PHYSICS else None
    if spec is not None and spec.submodule_search_locations is not None:  # a package
        importlib.import_module(pkg)
    try:
        from sphfem.physics import MODULES as targets
    except ImportError:  # pragma: no cover
        return
    if name in targets and name not in MODULES:
        importlib.import_module(targets[name].split(":")[0])
    if name not in MODULES and name not in SECTIONS:
        # a package may register modules under other names (sphfem.solid -> "tlsph"):
        # import every physics package (their imports are cheap: no numba compilation)
        for pkg in physics_packages():
            importlib.import_module(pkg)


def all_sections() -> dict[str, Section]:
    """Every section, after importing the core scene and every existing physics package."""
    importlib.import_module("sphfem.scene")
    for pkg in physics_packages():
        importlib.import_module(pkg)
    return dict(SECTIONS)


# --------------------------------------------------------------------------------------
# validation


class Context:
    """Validation state: the source name (for errors) and the scene dimension."""

    def __init__(self, source: str = "<string>", dim: int | None = None):
        self.source = source
        self.dim = dim
        #: validated core sections (name -> record; "blocks" a tuple with names filled in),
        #: set before physics-module sections are validated, for their cross-key checks
        self.core: dict[str, Any] = {}

    def error(self, key: str, message: str):
        raise SceneError(self.source, key, message)


def _show(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        s = '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    elif isinstance(v, Mapping):
        s = "a table {" + ", ".join(f"{k} = {_show(x)}" for k, x in v.items()) + "}"
    elif isinstance(v, (list, tuple)):
        s = "[" + ", ".join(_show(x) for x in v) + "]"
    elif isinstance(v, float):
        s = repr(v)
    else:
        s = repr(v) if not isinstance(v, int) else str(v)
    s = " ".join(s.split())
    return s if len(s) <= 80 else s[:77] + "..."


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def key_text(key) -> str:
    """A key as TOML writes it: bare if it can be, else quoted with escapes."""
    key = str(key)
    if re.fullmatch(r"[A-Za-z0-9_-]+", key):
        return key
    return json.dumps(key, ensure_ascii=False)


def _join(path: str, key: str) -> str:
    key = key_text(key)
    return f"{path}.{key}" if path else key


def suggest(word: str, known) -> str:
    """``; did you mean 'x'?`` or the list of known keys (for unknown-key messages)."""
    known = list(known)
    close = difflib.get_close_matches(str(word), known, n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return f"; known: {', '.join(known)}" if known else ""


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


_TEMP = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(K|C|degC|°C)\s*")


def parse_temperature(v) -> float:
    """Kelvin from a number (kelvin) or a string ``"100 C"``/``"100 degC"``/``"373.15 K"``."""
    if _is_number(v):
        return float(v)
    if isinstance(v, str):
        m = _TEMP.fullmatch(v)
        if m:
            x = float(m.group(1))
            return x if m.group(2) == "K" else x + 273.15
    raise ValueError(v)


def convert(p: Param, v, ctx: Context, key: str):
    """Validate and convert one value; raises SceneError naming ``key``."""
    try:
        return _convert(p, v, ctx, key)
    except OverflowError:  # e.g. an integer beyond float range
        ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {_show(v)}")


def _convert(p: Param, v, ctx: Context, key: str):
    def bad():
        ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {_show(v)}")

    t = p.type
    if t is CUSTOM:
        return p.convert(v, ctx, key)
    if t is bool:
        if not isinstance(v, bool):
            bad()
        return v
    if t is str:
        if not isinstance(v, str):
            bad()
        if p.choices is not None and v not in p.choices:
            hint = suggest(v, p.choices)
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {_show(v)}"
                      + (hint if hint.startswith("; did") else ""))
        return v
    if t is STRINGS:
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            bad()
        if p.choices is not None:
            for s in v:
                if s not in p.choices:
                    ctx.error(key, f"unknown entry {_show(s)}; expected entries from "
                                   + ", ".join(_show(c) for c in p.choices))
        return tuple(v)
    if t is TEMPERATURE:
        try:
            x = parse_temperature(v)
        except ValueError:
            bad()
        if not (math.isfinite(x) and x > 0 and p.in_range(x)):
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {_show(v)}"
                           + (f" = {x:g} K" if isinstance(v, str) else ""))
        return x
    if t in (VECTOR, BOOLS):
        n = ctx.dim if p.length == "dim" else p.length
        if not isinstance(v, list) or (n is not None and len(v) != n):
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {_show(v)}"
                      + (f" (dim = {n})" if isinstance(v, list) and p.length == "dim" else ""))
        if t is BOOLS:
            if not all(isinstance(b, bool) for b in v):
                bad()
            return tuple(v)
        if not all(_is_number(x) and p.in_range(float(x)) for x in v):
            bad()
        return tuple(float(x) for x in v)
    # scalars
    if t is int:
        if isinstance(v, float) and math.isfinite(v) and v == int(v):
            v = int(v)
        if not (isinstance(v, int) and not isinstance(v, bool)):
            bad()
        if p.choices is not None and v not in p.choices:
            bad()
        if not p.in_range(v):
            bad()
        return v
    if not _is_number(v) or not p.in_range(float(v)):
        bad()
    if p.choices is not None and v not in p.choices:
        bad()
    return float(v)


def _default(p: Param, ctx: Context):
    d = p.default
    if callable(d):
        return d(ctx.dim)
    return d


def validate_table(section: Section, data, ctx: Context, path: str) -> Record:
    """Validate one table of ``section`` (``data`` a dict) into a :class:`Record`."""
    if not isinstance(data, Mapping):
        where = "" if path.endswith("]") else f" ([{path}])"
        ctx.error(path, f"expected a table{where}, got {_show(data)}")
    known = section.keys
    for k in data:
        if k not in known:
            ctx.error(_join(path, k), f"unknown key in [{_header(section)}]"
                      + suggest(k, known))
    out: dict[str, Any] = {}
    conditional = []
    for p in section.params:
        if p.when is not None:
            conditional.append(p)
            continue
        out[p.name] = _value(p, data, ctx, path, None)
    for p in conditional:
        other, values = p.when
        applies = out.get(other) in values
        if not applies:
            if data.get(p.name) is not None:
                ctx.error(_join(path, p.name),
                          f"does not apply when {other} = {_show(out.get(other))}; "
                          f"only for {other} = " + " or ".join(_show(x) for x in values))
            continue
        out[p.name] = _value(p, data, ctx, path, f"{other} = {_show(out.get(other))}")
    for sub in section.subsections:
        out[sub.name] = validate_section(sub, data.get(sub.name), ctx, _join(path, sub.name))
    rec = Record(**out)
    if section.check is not None:
        section.check(rec, ctx, path)
    return rec


def _value(p: Param, data, ctx: Context, path: str, condition: str | None):
    key = _join(path, p.name)
    v = data.get(p.name)
    if v is None:
        if p.required:
            ctx.error(key, "missing required key" + (f" (needed when {condition})"
                                                     if condition else "")
                      + f"; expected {p.expectation(ctx.dim)}")
        return _default(p, ctx)
    return convert(p, v, ctx, key)


def _header(section: Section) -> str:
    if section.open_keys:
        return f"{section.name}.<name>"
    return section.name


def validate_section(section: Section, data, ctx: Context, path: str | None = None):
    """Validate ``data`` (None if absent) for ``section``.

    Returns a :class:`Record` for a plain table, a tuple of records for a repeated section
    and a :class:`FrozenDict` name -> record for an open-key section.
    """
    path = section.name if path is None else path
    if data is None and section.required:
        ctx.error(path, f"missing required section [{_header(section)}]")
    if section.repeated:
        data = [] if data is None else data
        if not isinstance(data, list):
            ctx.error(path, f"expected an array of tables ([[{section.name}]]), got "
                            f"{_show(data)}")
        if len(data) < section.min_count:
            ctx.error(path, f"at least {section.min_count} [[{section.name}]] "
                            f"table(s) required, got {len(data)}")
        return tuple(validate_table(section, item, ctx, f"{path}[{i}]")
                     for i, item in enumerate(data))
    if section.open_keys:
        data = {} if data is None else data
        if not isinstance(data, Mapping):
            ctx.error(path, f"expected tables [{section.name}.<name>], got {_show(data)}")
        if len(data) < section.min_count:
            ctx.error(path, f"at least {section.min_count} [{section.name}.<name>] "
                            f"table(s) required")
        out = {}
        for name, item in data.items():
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_\-]*", str(name)):
                ctx.error(_join(path, name),
                          "names must start with a letter and use letters, digits, _ or -")
            out[name] = validate_table(section, item, ctx, _join(path, name))
        return FrozenDict(out)
    return validate_table(section, {} if data is None else data, ctx, path)


# --------------------------------------------------------------------------------------
# documentation


def _type_text(p: Param) -> str:
    return {
        float: "float", int: "int", bool: "bool", str: "str", VECTOR: "float[dim]",
        BOOLS: "bool[dim]", STRINGS: "list of str", TEMPERATURE: "temperature",
        CUSTOM: p.type_doc,
    }[p.type] if not (p.type in (VECTOR, BOOLS) and p.length != "dim") else (
        f"{'float' if p.type is VECTOR else 'bool'}[{p.length}]")


def _default_text(p: Param) -> str:
    if p.required:
        return "**required**"
    if p.default_doc:
        return p.default_doc
    if p.default is None:
        return "(unset)"
    if isinstance(p.default, (tuple, list)):
        return "`" + _show(list(p.default)) + "`"
    return "`" + _show(p.default) + "`"


def _allowed_text(p: Param) -> str:
    parts = []
    if p.choices is not None:
        parts.append(", ".join(f"`{_show(c)}`" for c in p.choices))
    else:
        rng = p._range_text()
        if rng:
            parts.append(rng.replace("in ", "", 1) if rng.startswith("in ") else rng)
    if p.type is TEMPERATURE:
        parts.append("> 0 K")
    if p.when is not None:
        parts.append(f"only if {p.when[0]} = " + " or ".join(f"`{_show(x)}`"
                                                             for x in p.when[1]))
    return "; ".join(parts)


def _cell(s: str) -> str:
    return s.replace("|", "\\|")


def _describe(section: Section, header: str, level: int) -> list[str]:
    lines = [f"{'#' * level} `{header}`", ""]
    if section.doc:
        lines += [section.doc, ""]
    if section.module:
        lines += [f"Allowed only when `\"{section.module}\"` is listed in `[physics] modules`.",
                  ""]
    if section.params:
        lines += ["| key | type | unit | default | allowed | description |",
                  "|---|---|---|---|---|---|"]
        for p in section.params:
            lines.append("| " + " | ".join(_cell(c) for c in (
                f"`{p.name}`", _type_text(p), p.unit, _default_text(p), _allowed_text(p),
                p.doc)) + " |")
        lines.append("")
    base = header.strip("[]")
    for sub in section.subsections:
        lines += _describe(sub, _section_header(sub, f"{base}.{sub.name}"), level + 1)
    return lines


def _section_header(section: Section, name: str) -> str:
    if section.repeated:
        return f"[[{name}]]"
    return f"[{name}.<name>]" if section.open_keys else f"[{name}]"


_CORE_ORDER = ("scene", "domain", "sph", "materials", "blocks", "physics", "time", "output")

_INTRO = """\
# Scene files

<!-- generated by sphfem.schema.describe_markdown(); regenerate with
     `python -m sphfem.schema` after changing or registering a section -->

A scene is a TOML file, the single source of a run: `sphfem run scene.toml --out DIR`.
It is validated in full before anything is built; every mistake stops with one line naming
the file and the key, e.g. `drop.toml: blocks[1].radius: expected a positive length in m,
got -0.1`. Unknown sections and keys are errors (with the closest known key suggested).

Conventions:

- SI units everywhere (m, s, kg, K, Pa). `float[dim]` is a list with one number per axis
  of the scene's dimension, e.g. `lo = [0.0, 0.0]` in 2D.
- Temperatures (type `temperature`) are kelvin when given as a number; a string with a unit
  is converted: `"100 C"`, `"100 degC"` or `"100 °C"` is 373.15 K, `"373.15 K"` is 373.15 K.
- Integers are accepted where a float is expected; a float with an integral value (`1e6`)
  is accepted where an integer is expected.
- Physics sections (e.g. `[heat]`) belong to a physics module and are only allowed when
  the module is listed in `[physics] modules`; a listed module whose section is absent
  gets the defaults.
- Geometry of `[[blocks]]`: in 1D a box and a sphere are segments and a cylinder is the
  segment of `length` along x; in 2D a sphere is a disc and a cylinder is its axial
  section, the rectangle `length` along `axis` by `2 radius` across; in 3D a cylinder is
  circular with its axis along `axis`, centred (mid-length) at `center`.
- Particle placement (`sampling`): `"lattice"` is a cell-centred Cartesian lattice (a box
  `[0, 1]` with `dx = 0.1` gets 10 particles per axis at 0.05 ... 0.95; the spacing of a
  box is adjusted per axis to `length / round(length / dx)` so the box is tiled exactly);
  `"poisson"` is blue noise (Poisson-disk) with the same mean number density, for
  free-surface bodies, reproducible for a given `[scene] seed`.
- Every particle of a block has mass `rho0 * (exact block volume) / (particle count)`, so
  the block carries its exact mass; particles of two blocks closer than `dx / 2` are an
  error (overlapping blocks).
"""


def describe_markdown() -> str:
    """The scene reference (docs/scenes.md) generated from every registered section."""
    sections = all_sections()
    order = [n for n in _CORE_ORDER if n in sections]
    order += sorted(n for n in sections if n not in order)
    lines = [_INTRO, "## Core sections", ""]
    modules_started = False
    for name in order:
        s = sections[name]
        if s.module and not modules_started:
            lines += ["## Physics-module sections", ""]
            modules_started = True
        lines += _describe(s, _section_header(s, name), 3)
    mods = sorted(known_modules())
    lines += ["## Registered physics modules", "",
              ("Names accepted in `[physics] modules`: "
               + ", ".join(f"`{m}`" for m in mods) + ".") if mods else
              "No physics module is registered yet.", ""]
    return "\n".join(lines).rstrip() + "\n"


def docs_path() -> Path:
    return Path(__file__).resolve().parents[1] / "docs" / "scenes.md"


def write_docs(path=None) -> Path:
    """Write :func:`describe_markdown` to ``docs/scenes.md`` (or ``path``)."""
    path = Path(path) if path is not None else docs_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(describe_markdown(), encoding="utf-8")
    return path


if __name__ == "__main__":  # pragma: no cover
    import sys

    from sphfem import schema as _schema  # the registry lives in the imported module

    print(_schema.write_docs(sys.argv[1] if len(sys.argv) > 1 else None))
