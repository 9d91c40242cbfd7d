"""Validation of parsed TOML against the declarations: :func:`validate_section` turns a
table into a read-only :class:`Record` (every default filled in) or raises
:class:`SceneError` naming the file and the key on the first mistake.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Mapping
from typing import Any

from sphfem.errors import SceneError
from sphfem.schema.declarations import (
    BOOLS,
    CUSTOM,
    STRINGS,
    TEMPERATURE,
    VECTOR,
    FrozenDict,
    Param,
    Record,
    Section,
    show_value,
)


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
        ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {show_value(v)}")


def _convert(p: Param, v, ctx: Context, key: str):
    def bad():
        ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {show_value(v)}")

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
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {show_value(v)}"
                      + (hint if hint.startswith("; did") else ""))
        return v
    if t is STRINGS:
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            bad()
        if p.choices is not None:
            for s in v:
                if s not in p.choices:
                    ctx.error(key, f"unknown entry {show_value(s)}; expected entries from "
                                   + ", ".join(show_value(c) for c in p.choices))
        return tuple(v)
    if t is TEMPERATURE:
        try:
            x = parse_temperature(v)
        except ValueError:
            bad()
        if not (math.isfinite(x) and x > 0 and p.in_range(x)):
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {show_value(v)}"
                           + (f" = {x:g} K" if isinstance(v, str) else ""))
        return x
    if t in (VECTOR, BOOLS):
        n = ctx.dim if p.length == "dim" else p.length
        if not isinstance(v, list) or (n is not None and len(v) != n):
            ctx.error(key, f"expected {p.expectation(ctx.dim)}, got {show_value(v)}"
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
        ctx.error(path, f"expected a table{where}, got {show_value(data)}")
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
                          f"does not apply when {other} = {show_value(out.get(other))}; "
                          f"only for {other} = " + " or ".join(show_value(x) for x in values))
            continue
        out[p.name] = _value(p, data, ctx, path, f"{other} = {show_value(out.get(other))}")
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
                            f"{show_value(data)}")
        if len(data) < section.min_count:
            ctx.error(path, f"at least {section.min_count} [[{section.name}]] "
                            f"table(s) required, got {len(data)}")
        return tuple(validate_table(section, item, ctx, f"{path}[{i}]")
                     for i, item in enumerate(data))
    if section.open_keys:
        data = {} if data is None else data
        if not isinstance(data, Mapping):
            ctx.error(path, f"expected tables [{section.name}.<name>], got {show_value(data)}")
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


