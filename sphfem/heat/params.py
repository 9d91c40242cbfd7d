"""Parameters of the heat-conduction module: :class:`HeatParams`, built from a scene's
``[heat]`` section and its materials by :func:`params_from_scene`, or passed directly to
``HeatConduction(scene, params)``.

:class:`HeatParams` has one field per ``[heat]`` key, derived from the declaration
(:data:`sphfem.heat.scene_section.HEAT`: names, defaults, bounds and meaning, documented in
docs/scenes.md), plus the :data:`RUN_FIELDS` that come from elsewhere in the scene: the
faces of box blocks (:class:`BoxBoundary`), the thermal materials (:class:`ThermalMaterial`)
and an initial temperature.  A key added to the declaration needs no edit here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sphfem.heat.scene_section import HEAT
from sphfem.schema.params import check_declared, section_dataclass


@dataclass
class ThermalMaterial:
    """Specific heat capacity ``c`` [J/(kg K)] and conductivity ``k`` [W/(m K)]."""

    c: float
    k: float


@dataclass
class BoxBoundary:
    """Faces of the box [lo, hi] with their conditions (unnamed faces: insulated)."""

    lo: tuple
    hi: tuple
    faces: dict = field(default_factory=dict)


#: the parameters of :class:`HeatParams` that are not ``[heat]`` keys (name -> (default or
#: default factory, doc)); :func:`params_from_scene` fills them from the scene
RUN_FIELDS = {
    "boundaries": (list, "list of BoxBoundary (the [[heat.boundaries]] faces of box blocks)"),
    "materials": (dict, "material id -> ThermalMaterial (c [J/(kg K)], k [W/(m K)])"),
    "initial_temperature": (None, "[K] for particles whose T is not set beforehand "
                                  "(None: keep)"),
}


def _check_params(self) -> None:
    """Check the values against the ``[heat]`` declaration and the cross-key rule."""
    check_declared(self, HEAT, "heat")
    if not self.eta_place < self.eta_trim:
        raise ValueError("heat: need 0 < eta_place < eta_trim")


HeatParams = section_dataclass(
    "HeatParams", HEAT, RUN_FIELDS, module=__name__,
    doc="Parameters of the heat conduction (SI units): the ``[heat]`` keys of the scene "
        "(declared in :mod:`sphfem.heat.scene_section`, documented in docs/scenes.md), "
        "the box boundaries and the materials.",
    namespace={"__post_init__": _check_params})


def params_from_scene(scene) -> HeatParams:
    """:class:`HeatParams` from a validated scene's ``[heat]`` section and its box blocks."""
    h = scene.heat
    kw = {q.name: h[q.name] for q in HEAT.params} if h is not None else {}
    boundaries = {}
    for b in (h.boundaries if h is not None else ()):
        blk = scene.blocks[scene.block_index(b.block)]
        if blk.shape != "box":
            raise ValueError(f"heat.boundaries: block {b.block!r} is a {blk.shape}; "
                             "faces are defined for box blocks only")
        faces = boundaries.setdefault(b.block, BoxBoundary(tuple(blk.lo), tuple(blk.hi), {}))
        faces.faces[b.face] = ((b.condition, b.temperature) if b.condition == "dirichlet"
                               else b.condition)
    mats = {}
    for i, m in enumerate(scene.materials.values()):
        if m.c is None or m.k is None:
            continue
        mats[i] = ThermalMaterial(m.c, m.k)
    return HeatParams(**kw, boundaries=list(boundaries.values()), materials=mats)
