"""Scene-key declarations: parameter types, :class:`Param`, :class:`Section` and the
read-only values validation produces (:class:`Record`, :class:`FrozenDict`).

Parameter types: ``float``, ``int``, ``bool``, ``str`` (optionally with ``choices``),
``VECTOR`` (floats, one per axis), ``BOOLS`` (bools, one per axis), ``STRINGS`` (list of
str), ``TEMPERATURE`` (a number is kelvin; a string ``"100 C"``, ``"100 degC"``,
``"100 °C"`` or ``"373.15 K"`` is converted to kelvin), ``CUSTOM`` (checked by the
param's ``convert(value, ctx, key)``, which calls ``ctx.error(key, message)`` on a bad
value; ``type_doc`` describes the accepted values).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

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
            return "one of " + ", ".join(show_value(c) for c in self.choices)
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
        lo = (f"({number_text(self.gt)}" if self.gt is not None
              else f"[{number_text(self.ge)}" if self.ge is not None else None)
        hi = (f"{number_text(self.lt)})" if self.lt is not None
              else f"{number_text(self.le)}]" if self.le is not None else None)
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


def show_value(v) -> str:
    """A value as the messages and the docs show it (TOML spelling, at most 80 characters)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        s = '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    elif isinstance(v, Mapping):
        s = "a table {" + ", ".join(f"{k} = {show_value(x)}" for k, x in v.items()) + "}"
    elif isinstance(v, (list, tuple)):
        s = "[" + ", ".join(show_value(x) for x in v) + "]"
    elif isinstance(v, float):
        s = repr(v)
    else:
        s = repr(v) if not isinstance(v, int) else str(v)
    s = " ".join(s.split())
    return s if len(s) <= 80 else s[:77] + "..."


def number_text(x) -> str:
    """A bound as the messages show it (``%g`` for floats)."""
    return f"{x:g}" if isinstance(x, float) else str(x)
