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


#: the density variation a weakly compressible fluid is allowed under its largest pressures
COMPRESSIBILITY = 0.01


def capillary_sound_speed(sigma: float, rho0: float, h: float,
                          compressibility: float = COMPRESSIBILITY) -> float:
    """The least c0 [m/s] at which the capillary pressure sigma / h of a surface curved on
    the kernel's scale h (the largest curvature the particles resolve) compresses the fluid
    by no more than ``compressibility``:

        c0 = sqrt(sigma / (compressibility rho0 h))

    (the surface-tension condition on c0 of Morris 2000, Int. J. Numer. Meth. Fluids 33,
    333, with kappa = 1 / h).  It grows as dx^-1/2 and takes over from the usual 10 |v|max
    at low Weber numbers: the 3 m/s water droplet (We 12.5) with c0 = 10 V = 30 m/s at
    D/dx 64 (h = 2.3 um; bound 55 m/s) broke its lamella and blew up, with c0 = 100 m/s its
    film stayed whole (docs/validation/droplet_impact, sessions 30-31)."""
    if not (sigma >= 0.0 and rho0 > 0.0 and h > 0.0 and compressibility > 0.0):
        raise ValueError("capillary_sound_speed: needs sigma >= 0, rho0 > 0, h > 0 and "
                         f"compressibility > 0, got {(sigma, rho0, h, compressibility)}")
    return math.sqrt(sigma / (compressibility * rho0 * h))


def capillary_warning(c0: float, sigma: float, rho0: float, h: float) -> str | None:
    """A warning's text when ``c0`` lies below :func:`capillary_sound_speed` (else None)."""
    need = capillary_sound_speed(sigma, rho0, h)
    if sigma <= 0.0 or c0 >= need:
        return None
    return (f"c0 = {c0:.4g} m/s is low for the surface tension: a surface curved on the "
            f"kernel's scale h = {h:.3g} m carries sigma / h = {sigma / h:.3g} Pa, which "
            f"compresses the fluid by {100 * sigma / (h * rho0 * c0 ** 2):.2g} % (> "
            f"{100 * COMPRESSIBILITY:g} %): expect noisy pressures, a broken film at low "
            f"Weber numbers and a stop by the density guard; set the material's c0 >= "
            f"{need:.3g} m/s")
