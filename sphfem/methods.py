"""Method registries: inside a physics family, a scene key chooses one method by name.

A family (the fluid's surface tension, wall model, viscosity, time integrator, pressure
solver) declares one :class:`MethodRegistry`: the scene key it answers (``[fluid]
surface_tension``), the modules that hold its methods (one module per method, named after
its paper) and, optionally, what ``"none"`` means (no method: no entry).  Each method
module builds its method object (a frozen dataclass with at least ``name``, ``doc`` and
``params``) and registers it at import.  The registry imports the modules on first use, so
declaring a scene section that takes its choices from a registry compiles nothing.

The scene section takes from the registry the allowed values (:meth:`MethodRegistry.names`),
the key's documentation (:meth:`MethodRegistry.choices_doc`) and each method's own keys
(:meth:`MethodRegistry.scene_params`: :class:`sphfem.schema.Param` declared with
``when=(key, (name,))``, so they exist only when that method is chosen), and therefore
``docs/scenes.md`` (``python -m sphfem.schema``) documents every method from its
declaration.  Adding a method: one new module and one line in the family's module list
(docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence


class MethodRegistry:
    """The methods of one family, chosen by the scene key ``key``.

    ``modules``: the method modules, in the order of the key's choices (importing one
    registers its method, which it keeps as its ``METHOD``); ``none_doc``: the meaning of
    the choice ``"none"`` (None: there is no such choice); ``family``: how errors name the
    family.
    """

    def __init__(self, key: str, modules: Sequence[str], none_doc: str | None = None,
                 family: str | None = None):
        self.key = key
        self.modules = tuple(modules)
        self.none_doc = none_doc
        self.family = family or key.replace("_", "-")
        self._methods: dict = {}
        self._loaded = False

    def register(self, method):
        """Add ``method`` (called by its module at import); returns it."""
        if method.name in self._methods or (method.name == "none" and self.none_doc):
            raise ValueError(f"{self.family} method {method.name!r} registered twice")
        self._methods[method.name] = method
        return method

    def unregister(self, name: str) -> None:
        """Remove the method called ``name`` (tests that register a toy method)."""
        self._methods.pop(name, None)

    def methods(self) -> dict:
        """name -> method: the listed modules' methods in list order, then any registered
        directly."""
        if not self._loaded:
            self._loaded = True
            listed = {}
            for name in self.modules:
                method = getattr(importlib.import_module(name), "METHOD", None)
                if method is not None:
                    listed[method.name] = method
            self._methods = listed | self._methods
        return self._methods

    def names(self) -> tuple[str, ...]:
        """The allowed values of the key ("none" first when it is a choice)."""
        return (("none",) if self.none_doc else ()) + tuple(self.methods())

    @property
    def default(self) -> str:
        """The first listed method's name ("none" when that is a choice)."""
        return self.names()[0]

    def lookup(self, name: str):
        """The method called ``name`` (None for "none"); ValueError for an unknown name."""
        if name == "none" and self.none_doc:
            return None
        try:
            return self.methods()[name]
        except KeyError:
            raise ValueError(f"unknown {self.key} model {name!r}; known: "
                             f"{', '.join(self.names())}") from None

    def scene_params(self) -> tuple:
        """The scene keys of all methods (each applies only to its own method)."""
        return tuple(p for m in self.methods().values() for p in m.params)

    def choices_doc(self) -> str:
        """Documentation of the key, from the methods' descriptions."""
        head = [f"none: {self.none_doc}"] if self.none_doc else []
        return "; ".join([*head, *(f"{m.name}: {m.doc}" for m in self.methods().values())])
