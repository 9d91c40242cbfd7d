"""Registry of the fluid's surface-tension methods (``[fluid] surface_tension``).

Each method lives in one module named after its paper and registers a
:class:`SurfaceTensionMethod` at import: its name (the value of ``surface_tension``), the
scene keys it adds to ``[fluid]`` (declared with ``when=("surface_tension", (name,))`` so
they exist only for that method), the key of its calibration constant, how the constant and
the sigma it represents follow from the material's sigma, and the pass that adds its
acceleration.  :class:`sphfem.fluid.wcsph.FluidSolver` looks the method up by name; the
``[fluid]`` declaration (:mod:`sphfem.fluid.scene_section`) takes the choices, the keys and
their documentation from here.  ``"none"`` is no method (no entry).

Adding a method: a new module ``surface_tension_<paper>.py`` that calls :func:`register`,
and its name in :data:`METHOD_MODULES` (see docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

#: the method modules, in the order of the ``surface_tension`` choices (one line per method)
METHOD_MODULES = (
    "sphfem.fluid.surface_tension_csf",
    "sphfem.fluid.surface_tension_iif_tartakovsky2005",
    "sphfem.fluid.surface_tension_akinci2013",
)


@dataclass(frozen=True)
class SurfaceTensionMethod:
    """One surface-tension method.

    name        the value of ``[fluid] surface_tension``
    doc         its description in the ``surface_tension`` key's documentation
    params      its own ``[fluid]`` keys (:class:`sphfem.schema.Param` with ``when=``)
    constant_key  the key of its calibration constant (set: sigma is not needed), or None
    calibrate   ``(params, m_bar, R, dim) -> (constant or None, sigma it represents)``
    accelerate  ``(solver, state) -> state``: adds the acceleration to ``solver.p.acc``
                during :meth:`FluidSolver.evaluate`; ``state`` (None at first) is the
                method's work arrays, kept by the solver between evaluations
    """

    name: str
    doc: str
    params: tuple
    constant_key: str | None
    calibrate: Callable
    accelerate: Callable


_METHODS: dict[str, SurfaceTensionMethod] = {}


def register(method: SurfaceTensionMethod) -> SurfaceTensionMethod:
    """Add ``method`` to the registry (called by each method module at import)."""
    if method.name in _METHODS or method.name == "none":
        raise ValueError(f"surface-tension method {method.name!r} registered twice")
    _METHODS[method.name] = method
    return method


def methods() -> dict[str, SurfaceTensionMethod]:
    """name -> method, in the order of :data:`METHOD_MODULES`."""
    if len(_METHODS) < len(METHOD_MODULES):
        for mod in METHOD_MODULES:
            importlib.import_module(mod)
    return _METHODS


def names() -> tuple[str, ...]:
    """The allowed values of ``surface_tension``: "none" and the registered methods."""
    return ("none", *methods())


def lookup(name: str) -> SurfaceTensionMethod | None:
    """The method called ``name`` (None for "none"); ValueError for an unknown name."""
    if name == "none":
        return None
    try:
        return methods()[name]
    except KeyError:
        raise ValueError(f"unknown surface_tension model {name!r}") from None


def scene_params() -> tuple:
    """The ``[fluid]`` keys of all methods (each applies only to its own method)."""
    return tuple(p for m in methods().values() for p in m.params)


def choices_doc() -> str:
    """Documentation of the ``surface_tension`` key, from the methods' descriptions."""
    return "; ".join(["none: no surface tension",
                      *(f"{m.name}: {m.doc}" for m in methods().values())])
