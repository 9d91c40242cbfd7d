"""``c0 = "physical"``: a fluid material's speed of sound from its physical value.

A weakly compressible fluid usually runs with an artificial speed of sound c0 (about ten
times the largest flow speed, so the density varies by about 1 %).  Pressures that scale
with c0, such as the water-hammer pressure rho c0 v of an impact, then depend on that
numerical choice.  ``[materials.<name>] c0 = "physical"`` takes c0 from the material's
``sound_speed`` key (water: about 1480 m/s at 20 C) instead; the time step shrinks in
proportion (acoustic limit dt <= cfl h / (c0 + |v|)).  Validation keeps the string as
:data:`PHYSICAL` and :func:`resolve_sound_speeds` replaces it by the number once the table is
validated, so every reader of ``c0`` sees metres per second.
"""

from __future__ import annotations

import math

from sphfem.schema.declarations import CUSTOM, FrozenDict, Param

#: the value of ``c0`` that asks for ``sound_speed``
PHYSICAL = "physical"

TYPE_DOC = 'speed of sound in m/s or "physical"'


def _convert_c0(v, ctx, key):
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        x = float(v)
        if math.isfinite(x) and x > 0.0:
            return x
    elif v == PHYSICAL:
        return PHYSICAL
    shown = f'"{v}"' if isinstance(v, str) else repr(v)
    ctx.error(key, 'expected a positive speed of sound in m/s or "physical" (the '
                   f'material\'s sound_speed), got {shown}')


C0 = Param("c0", CUSTOM, None, unit="m/s", convert=_convert_c0, type_doc=TYPE_DOC,
           positive=True,
           doc='speed of sound of the weakly compressible fluid: a number (artificial, '
               'usually >= 10 x the largest speed) or "physical" (the material\'s '
               '`sound_speed`; pressures scaling with rho c0 v then take their physical '
               'value and the time step shrinks in proportion)')

SOUND_SPEED = Param("sound_speed", float, None, unit="m/s", positive=True,
                    quantity="speed of sound",
                    doc='physical speed of sound (water: ~1480 m/s at 20 C); used by '
                        '`c0 = "physical"`')


def resolve_sound_speeds(materials, ctx) -> FrozenDict:
    """``materials`` (name -> record) with ``c0 = "physical"`` replaced by the material's
    ``sound_speed``; a missing ``sound_speed`` is an error naming that key."""
    out = {}
    for name, m in materials.items():
        if m.c0 == PHYSICAL:
            if m.sound_speed is None:
                ctx.error(f"materials.{name}.sound_speed",
                          'missing: c0 = "physical" takes the speed of sound from this key; '
                          'give the physical speed of sound in m/s (water: ~1480) or a '
                          'number for c0')
            m = m.replace(c0=m.sound_speed)
        out[name] = m
    return FrozenDict(out)
