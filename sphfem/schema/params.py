"""A physics family's parameter dataclass derived from its scene-section declaration.

:func:`section_dataclass` makes a dataclass with one field per key of a :class:`Section`
(name and default from the declaration) plus the family's own run fields (materials,
boundaries, ``[time]`` settings), so a key added to the declaration needs no second edit;
:func:`check_declared` checks the values of such an object against the same declaration
(choices, bounds) for parameters built by hand, without a scene.
"""

from __future__ import annotations

from dataclasses import MISSING, field, make_dataclass
from typing import Any

from sphfem.schema.declarations import Section


def declared_default(p):
    """A key's default as a dataclass default: a per-axis default (a function of the
    dimension in the declaration) becomes (), to be padded by its user."""
    return () if callable(p.default) else p.default


def section_dataclass(name: str, section: Section, run_fields: dict, *, module: str,
                      doc: str, namespace: dict | None = None):
    """A dataclass ``name`` with the :data:`run_fields` first (name -> (default, doc); a
    callable default is a default factory) and then one field per key of ``section``; its
    docstring is ``doc`` followed by one line per field."""
    rows = [(k, d, text) for k, (d, text) in run_fields.items()]
    rows += [(q.name, declared_default(q), q.doc) for q in section.params]
    fields = []
    for k, d, _ in rows:
        spec = field(default_factory=d) if callable(d) else field(default=d)
        fields.append((k, Any, spec))
    body = "\n".join(f"{k}: {text}" for k, _, text in rows)
    cls = make_dataclass(name, fields, namespace={"__doc__": f"{doc}\n\n{body}",
                                                  **(namespace or {})})
    cls.__module__ = module
    return cls


def check_declared(obj, section: Section, label: str, registries: dict | None = None) -> None:
    """Raise ValueError when a field of ``obj`` named after a key of ``section`` breaks the
    declaration: not among its ``choices`` (or not a method of ``registries[name]``, whose
    ``lookup`` raises) or a number outside its bounds."""
    registries = registries or {}
    for q in section.params:
        v = getattr(obj, q.name, MISSING)
        if v is MISSING:
            continue
        if q.name in registries:
            registries[q.name].lookup(v)
        elif q.choices is not None and v not in q.choices:
            raise ValueError(f"unknown {label} {q.name} {v!r}; known: {', '.join(q.choices)}")
        elif q.type in (float, int) and v is not None and not q.in_range(v):
            raise ValueError(f"{label} {q.name} must be {q.expectation()}, got {v!r}")
