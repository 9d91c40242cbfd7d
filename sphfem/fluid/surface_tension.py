"""Registry of the fluid's surface-tension methods (``[fluid] surface_tension``).

Each method lives in one module named after its paper and registers a
:class:`SurfaceTensionMethod` at import: its name (the value of ``surface_tension``), the
scene keys it adds to ``[fluid]`` (declared with ``when=("surface_tension", (name,))`` so
they exist only for that method), the key of its calibration constant, how the constant and
the sigma it represents follow from the material's sigma, and the pass that adds its
acceleration.  :class:`sphfem.fluid.wcsph.FluidSolver` looks the method up by name; the
``[fluid]`` declaration (:mod:`sphfem.fluid.scene_section`) takes the choices, the keys and
their documentation from here.  ``"none"`` is no method (no entry).

Adding a method: a new module ``surface_tension_<paper>.py`` that calls :func:`register`
(keeping the result as its ``METHOD``), and its name in :data:`METHOD_MODULES` (see
docs/architecture.md, "Adding a method").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sphfem.methods import MethodRegistry

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


#: the registry (:class:`sphfem.methods.MethodRegistry`) of ``[fluid] surface_tension``
REGISTRY = MethodRegistry("surface_tension", METHOD_MODULES, none_doc="no surface tension",
                          family="surface-tension")
register = REGISTRY.register
methods = REGISTRY.methods
names = REGISTRY.names
lookup = REGISTRY.lookup
scene_params = REGISTRY.scene_params
choices_doc = REGISTRY.choices_doc
