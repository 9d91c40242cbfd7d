"""Observed order, Richardson extrapolation and an error bar from a sequence of resolutions.

A figure f computed at spacings h_1 > h_2 > h_3 (coarse to fine; refinement ratios
r_c = h_1 / h_2 and r_f = h_2 / h_3, not necessarily equal) is modelled in the asymptotic
range as

    f(h) = f_0 + C h^p.                                                               (1)

Three levels fix (f_0, C, p).  With e_c = f_2 - f_1, e_f = f_3 - f_2 and s = sign(e_c /
e_f), the observed order solves (Celik et al. 2008, J. Fluids Eng. 130, 078001, eqs. 3-5,
whose index 1 is the finest level; a fixed-point iteration)

    p = | ln| e_c / e_f | + ln((r_f^p - s) / (r_c^p - s)) | / ln r_f,                   (2)

which for r_c = r_f = r reduces to p = ln(e_c / e_f) / ln r; solved here in the equivalent
form e_c / e_f = r_f^p (r_c^p - 1) / (r_f^p - 1) by bisection (the right side increases
with p from ln r_c / ln r_f at p -> 0, so the root is unique).  The extrapolated value and
the grid convergence index of the finest level (Roache 1994, factor of safety F_s = 1.25 for
three or more levels) are

    f_0 = f_3 + (f_3 - f_2) / (r_f^p - 1),   GCI = F_s |(f_3 - f_2) / f_3| / (r_f^p - 1).    (3)

The error bar reported is GCI |f_3|: the band around the finest value that holds the
converged one, in the sense of Roache's 95 % coverage.  Oscillatory (s < 0) or divergent
(|e_32| >= |e_21| for a refinement) sequences are not in the asymptotic range: then no order
is claimed, f_0 is the finest value and the error bar is the sequence's full spread
max f - min f of the last three levels times F_s = 3 (Roache's factor for an unverified
order), flagged ``asymptotic = False``; so is an observed order above 5 (``MAX_ORDER``: no
SPH/FEM figure converges that fast; such an order comes from a coarse difference that
happens to be much larger than the fine one).  Equal values (e_21 = e_32 = 0) are converged to
round-off.

With a ``formal_order`` p_f (the discretisation's theoretical order) the order used in (3)
is min(p, p_f) for every monotone converging sequence, including one whose observed order
exceeds :data:`MAX_ORDER` (Roache 1998, "Verification and Validation in Computational
Science and Engineering", sec. 5.9; Eca & Hoekstra 2014, J. Comput. Phys. 262, 104: an
observed order above the formal one is not trusted, and the formal order gives the larger,
conservative error estimate).  Such a sequence is then reported as asymptotic with the
formal order, F_s = 1.25 (the extrapolation from the two finest levels: the coarse level
ahead of the asymptotic range, or differences below the figure's scatter); oscillatory and
diverging sequences keep the 3x-spread bar.

With more than three levels the last three are used for (2)-(3) and the order of every
consecutive triple is also returned, so a reader sees whether it settles.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

__all__ = ["RichardsonEstimate", "observed_order", "richardson"]

#: Roache's factor of safety with an observed order from three or more levels
FS_VERIFIED = 1.25
#: ... and without one (oscillatory or divergent sequence)
FS_UNVERIFIED = 3.0
#: an observed order above this is taken as a sign that the levels are not in the
#: asymptotic range (two nearly equal differences by chance), not as a real order
MAX_ORDER = 5.0


@dataclass
class RichardsonEstimate:
    """Result of :func:`richardson`.  ``value`` the extrapolated figure (the finest value
    when not ``asymptotic``), ``error_bar`` the half-width of the band around the finest
    value that holds the converged one (GCI |f_finest|), ``order`` the observed order (None
    when not asymptotic), ``finest`` the finest-level value, ``relative_error_finest``
    |finest - value| / |value| (the finest level's estimated error), ``orders`` the order of
    every consecutive triple (coarse to fine; None where not asymptotic)."""

    value: float
    error_bar: float
    order: float | None
    finest: float
    relative_error_finest: float
    asymptotic: bool
    orders: list = field(default_factory=list)
    note: str = ""

    def to_dict(self) -> dict:
        return asdict(self)

    def within(self, x: float, rel: float) -> bool:
        """True when ``x`` lies within ``rel`` (relative) of the converged estimate, the
        error bar added to the band: |x - value| <= rel |value| + error_bar."""
        return abs(x - self.value) <= rel * abs(self.value) + self.error_bar


def observed_order(h, f, tol: float = 1e-15, max_iter: int = 200) -> float | None:
    """Observed order p of three values ``f`` at spacings ``h`` (any order of the input;
    sorted coarse to fine here) from eq. (2); None when the
    sequence is oscillatory, divergent or already converged to round-off."""
    (h1, f1), (h2, f2), (h3, f3) = sorted(zip(h, f, strict=True), key=lambda t: -t[0])
    if not (h1 > h2 > h3 > 0):
        raise ValueError(f"observed_order: spacings must be distinct and positive, got {h}")
    ec, ef = f2 - f1, f3 - f2
    scale = max(abs(f1), abs(f2), abs(f3), 1e-300)
    if abs(ec) <= 1e-13 * scale or abs(ef) <= 1e-13 * scale:
        return None
    ratio = ec / ef
    if ratio <= 0:
        return None  # oscillatory
    rc, rf = h1 / h2, h2 / h3

    def g(p):  # ec / ef of the model (1) at order p; increasing from ln rc / ln rf at p -> 0
        return rf**p * (rc**p - 1.0) / (rf**p - 1.0)

    lo, hi = 1e-6, 1.0
    if ratio <= g(lo):
        return None  # no decay: order <= 0
    while g(hi) < ratio:
        hi *= 2.0
        if hi > 64.0:
            return None
    for _ in range(max_iter):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(mid) < ratio else (lo, mid)
        if hi - lo < tol * hi:
            break
    return 0.5 * (lo + hi)

def _triple(h, f):
    (h1, f1), (h2, f2), (h3, f3) = sorted(zip(h, f, strict=True), key=lambda t: -t[0])
    p = observed_order((h1, h2, h3), (f1, f2, f3))
    return p, (h1, h2, h3), (f1, f2, f3)


def richardson(h, f, formal_order: float | None = None, noise=None) -> RichardsonEstimate:
    """Richardson estimate (module docstring) of the figure ``f`` computed at spacings
    ``h`` (>= 3 levels, any order; the three finest are used for the estimate);
    ``formal_order``: the discretisation's theoretical order, which caps the observed one
    (module docstring; None: the observed order is used up to :data:`MAX_ORDER`);
    ``noise``: each value's sampling half-width (e.g. a 95 % interval of an ensemble mean;
    needs ``formal_order``): a sequence read as oscillatory or diverging whose finest
    difference is not significant, |f_3 - f_2| <= hypot(noise_2, noise_3), is not
    classified by the data, and is estimated with the formal order like a sequence that
    settled in one step (the sampling uncertainty itself is the caller's to add)."""
    if formal_order is not None and not formal_order > 0:
        raise ValueError(f"richardson: formal_order must be > 0, got {formal_order}")
    if noise is not None and formal_order is None:
        raise ValueError("richardson: noise needs a formal_order")
    h = [float(v) for v in h]
    f = [float(v) for v in f]
    u = [float(v) for v in noise] if noise is not None else [0.0] * len(f)
    if len(h) != len(f) or len(u) != len(f):
        raise ValueError(f"richardson: {len(h)} spacings but {len(f)} values"
                         + (f" and {len(u)} noise half-widths" if noise is not None else ""))
    if len(h) < 3:
        raise ValueError(f"richardson: needs at least 3 resolutions, got {len(h)}")
    if any(not math.isfinite(v) for v in f):
        raise ValueError(f"richardson: non-finite value in {f}")
    pairs = sorted(zip(h, f, u, strict=True), key=lambda t: -t[0])
    hs, fs, us = [p[0] for p in pairs], [p[1] for p in pairs], [p[2] for p in pairs]
    orders = [observed_order(hs[i:i + 3], fs[i:i + 3]) for i in range(len(hs) - 2)]
    p, (h1, h2, h3), (f1, f2, f3) = _triple(hs[-3:], fs[-3:])
    scale = max(abs(f1), abs(f2), abs(f3), 1e-300)
    if abs(f3 - f2) <= 1e-13 * scale and abs(f2 - f1) <= 1e-13 * scale:
        return RichardsonEstimate(f3, 0.0, None, f3, 0.0, True, orders,
                                  "converged to round-off")
    note = ""
    if p is None and noise is not None and abs(f3 - f2) <= math.hypot(us[-2], us[-1]):
        p = float(formal_order)
        note = (f"{'oscillatory' if (f3 - f2) * (f2 - f1) < 0 else 'not converging'} by "
                f"{abs(f3 - f2):.3g}, within the sampling noise {math.hypot(us[-2], us[-1]):.2g}"
                f": the formal order {formal_order:g} used")
    elif p is not None and formal_order is not None and p > formal_order:
        note = (f"observed order {p:.2f} > formal {formal_order:g}: the formal order used "
                "(Roache 1998)")
        p = float(formal_order)
    if p is None or p > MAX_ORDER:
        spread = max(f1, f2, f3) - min(f1, f2, f3)
        kind = ("oscillatory" if (f3 - f2) * (f2 - f1) < 0 else
                f"observed order {p:.1f} > {MAX_ORDER:g}, implausible" if p is not None
                else "not converging")
        return RichardsonEstimate(f3, FS_UNVERIFIED * spread, None, f3, float("nan"), False,
                                  orders, f"{kind}: no order; error bar = 3 x spread")
    rf = h2 / h3
    f0 = f3 + (f3 - f2) / (rf**p - 1.0)
    gci = FS_VERIFIED * abs((f3 - f2) / f3) / (rf**p - 1.0) if f3 != 0 else float("inf")
    rel = abs(f3 - f0) / abs(f0) if f0 != 0 else float("inf")
    return RichardsonEstimate(f0, gci * abs(f3), p, f3, rel, True, orders, note)
