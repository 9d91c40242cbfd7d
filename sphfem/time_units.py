"""Scene times in units of the impact time tc = D / |v| (``[time] t_end = "4 tc"``).

A time key declared with :func:`time_param` (``[time] t_end``, ``[time] dt``, ``[output]
every``) takes a positive number of seconds or a string ``"<x> tc"``.  The impact time is
that of the impacting fluid block: the one ``[[blocks]]`` entry of kind ``"fluid"`` and
shape ``"sphere"`` (a disc in 2D) with a non-zero velocity, or the block named by ``[time]
tc_block`` when the scene has several.  Then

    tc = D / |v| = 2 radius / |velocity|

and ``"4 tc"`` is 4 tc seconds after t = 0 (the start of the run, before contact when the
droplet starts a gap above the wall).  Validation converts a number at once; a tc string
becomes :class:`InTc`, which :func:`resolve_times` turns into seconds once the blocks are
validated (errors name the key that asked for tc).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from sphfem.schema.declarations import CUSTOM, Param, Record

_TC = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*tc\s*")

TYPE_DOC = 'time: seconds or "<x> tc"'
#: the keys (section, key) that accept "<x> tc"
TIME_KEYS = (("time", "t_end"), ("time", "dt"), ("output", "every"))


@dataclass(frozen=True)
class InTc:
    """A time of ``factor`` impact times, resolved by :func:`resolve_times`."""

    factor: float

    def __str__(self) -> str:
        return f"{self.factor:g} tc"


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _expected(what: str) -> str:
    return (f'expected a positive {what} in s or a multiple of the impact time as a string '
            f'"<x> tc" (tc = D / |v| of the impacting fluid sphere), e.g. "4 tc"')


def _convert(what: str):
    def convert(v, ctx, key):
        if _is_number(v):
            x = float(v)
            if not (math.isfinite(x) and x > 0.0):
                ctx.error(key, f"{_expected(what)}; got {v!r}")
            return x
        if isinstance(v, str):
            m = _TC.fullmatch(v)
            if m is None:
                ctx.error(key, f'{_expected(what)}; got "{v}"')
            f = float(m.group(1))
            if not (math.isfinite(f) and f > 0.0):
                ctx.error(key, f'{_expected(what)}; got "{v}" (the multiple must be > 0)')
            return InTc(f)
        ctx.error(key, f"{_expected(what)}; got {v!r}")

    return convert


def time_param(name: str, default, doc: str, what: str = "time") -> Param:
    """A scene time key: seconds or ``"<x> tc"`` (see the module docstring)."""
    return Param(name, CUSTOM, default, unit="s", doc=doc, convert=_convert(what),
                 type_doc=TYPE_DOC, positive=True)  # positive: the docs' "> 0"


TC_BLOCK = Param(
    "tc_block", str, None,
    doc='name of the fluid sphere whose impact time tc = D / |v| gives times written as '
        '"<x> tc" (needed only when the scene has several moving fluid spheres)')


# --------------------------------------------------------------------------------------
# resolution


def _impactors(blocks) -> list:
    return [b for b in blocks if b.kind == "fluid" and b.shape == "sphere"
            and any(c != 0.0 for c in b.velocity)]


def impact_time(block) -> float:
    """tc = 2 radius / |velocity| of a sphere block [s]."""
    return 2.0 * block.radius / math.sqrt(sum(c * c for c in block.velocity))


def impact_block(blocks, tc_block: str | None, ctx, key: str):
    """The impacting fluid block (see the module docstring); errors name ``key`` (the key
    that asked for tc) or ``time.tc_block``."""
    if tc_block is not None:
        named = [b for b in blocks if b.name == tc_block]
        if not named:
            ctx.error("time.tc_block", f"no block named {tc_block!r} (blocks: "
                      + ", ".join(repr(b.name) for b in blocks) + ")")
        b = named[0]
        if b.kind != "fluid" or b.shape != "sphere":
            ctx.error("time.tc_block", f"block {tc_block!r} is a {b.kind} {b.shape}; tc = "
                      "D / |v| needs a fluid sphere (a disc in 2D)")
        if not any(c != 0.0 for c in b.velocity):
            ctx.error("time.tc_block", f"block {tc_block!r} has no velocity: tc = D / |v| "
                      "is undefined")
        return b
    cands = _impactors(blocks)
    if not cands:
        ctx.error(key, "a time in tc needs the impact time tc = D / |v| of a fluid sphere "
                       "(a disc in 2D) with a non-zero velocity; the scene has none (give the "
                       "time in seconds)")
    if len(cands) > 1:
        ctx.error(key, "a time in tc is ambiguous: the scene has several moving fluid "
                       "spheres (" + ", ".join(repr(b.name) for b in cands) + "); name one "
                       "with [time] tc_block = \"<name>\"")
    return cands[0]


def check_time(rec, ctx, path) -> None:
    """``dt <= t_end`` once both are in seconds (the ``[time]`` cross-key check)."""
    if isinstance(rec.dt, InTc) or isinstance(rec.t_end, InTc):
        return  # checked again by resolve_times
    if rec.dt is not None and rec.dt > rec.t_end:
        ctx.error(f"{path}.dt", f"fixed time step {rec.dt:g} s exceeds t_end = {rec.t_end:g} s")


def resolve_times(sections: dict, blocks, ctx) -> dict:
    """``sections`` (name -> record; ``time`` and ``output`` are used) with every
    :class:`InTc` value converted to seconds; the tc block is validated when named."""
    time_rec = sections["time"]
    tc_block = time_rec.tc_block if "tc_block" in time_rec else None
    tc = None
    if tc_block is not None:
        tc = impact_time(impact_block(blocks, tc_block, ctx, "time.tc_block"))
    out = dict(sections)
    for sec, key in TIME_KEYS:
        rec = out.get(sec)
        if not isinstance(rec, Record) or key not in rec or not isinstance(rec[key], InTc):
            continue
        if tc is None:
            tc = impact_time(impact_block(blocks, None, ctx, f"{sec}.{key}"))
        out[sec] = rec.replace(**{key: rec[key].factor * tc})
    check_time(out["time"], ctx, "time")
    return out


def scene_impact_time(scene) -> float:
    """tc [s] of a validated scene (the block rule of the module docstring)."""
    from sphfem.schema.validate import Context

    tc_block = scene.time.tc_block if "tc_block" in scene.time else None
    return impact_time(impact_block(scene.blocks, tc_block, Context(scene.source),
                                    "time.tc_block"))
