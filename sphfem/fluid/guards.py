"""Stability guards of the fluid: stop a run with a message that names the step, the number
of particles affected and the likely cause (raises ``SimulationStopped``).

Checked on fluid particles after every step (one fused parallel reduction, strict IEEE maths
so that NaN tests work): non-finite position, velocity or density; speed above
``max_speed_factor * c0``; density ratio rho/rho0 outside ``rho_ratio_band``; position outside
the domain box on a non-periodic axis.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sphfem.errors import SimulationStopped
from sphfem.particles import FLUID


@njit(cache=True, parallel=True)
def _flags(x, v, rho, kind, lo, hi, period, vmax, rlo, rhi, out):
    """out[i] = bit mask: 1 non-finite, 2 too fast, 4 density out of band, 8 outside."""
    n, dim = x.shape
    vmax2 = vmax * vmax
    for i in prange(n):
        f = 0
        if kind[i] == FLUID:
            s = 0.0
            fin = np.isfinite(rho[i])
            for k in range(dim):
                fin = fin and np.isfinite(x[i, k]) and np.isfinite(v[i, k])
                s += v[i, k] * v[i, k]
            if not fin:
                f = 1
            else:
                if s > vmax2:
                    f |= 2
                if rho[i] < rlo or rho[i] > rhi:
                    f |= 4
                for k in range(dim):
                    if period[k] == 0.0 and (x[i, k] < lo[k] or x[i, k] > hi[k]):
                        f |= 8
        out[i] = f


_CAUSES = {
    1: ("non-finite position, velocity or density",
        "time step above the stable limit, or a pressure blow-up (check c0, the wall layers "
        "and the initial particle spacing)"),
    2: ("speed above {fac:g} c0 (c0 = {c0:g} m/s, max {val:.4g} m/s)",
        "c0 too low for the flow (keep the Mach number below ~0.1: c0 >= 10 |v|max), or "
        "particles expelled by a pressure blow-up or penetration of a wall"),
    4: ("density ratio rho/rho0 outside [{lo:g}, {hi:g}] (min {dmin:.4g}, max {dmax:.4g})",
        "c0 too low (compressibility above a few per cent), particles penetrating a wall, "
        "or tensile instability at a free surface"),
    8: ("position outside the domain box on a non-periodic axis",
        "particles leaking through a wall (use >= R/dx wall layers, a smaller time step) or a "
        "domain box too small for the flow"),
}


def check_fluid(x, v, rho, kind, lo, hi, period, c0, rho0, max_speed_factor, rho_ratio_band,
                step, t):
    """Raise ``SimulationStopped`` if any fluid particle trips a guard (see module doc)."""
    n = x.shape[0]
    flags = np.empty(n, dtype=np.int8)
    _flags(x, v, rho, kind, lo, hi, period, max_speed_factor * c0,
           rho_ratio_band[0] * rho0, rho_ratio_band[1] * rho0, flags)
    if not flags.any():
        return
    fl = kind == FLUID
    parts = []
    for bit in (1, 2, 4, 8):
        hit = (flags & bit) != 0
        cnt = int(hit.sum())
        if not cnt:
            continue
        what, cause = _CAUSES[bit]
        sp = np.sqrt((v[fl] ** 2).sum(axis=1)) if bit == 2 else None
        ratio = rho[hit] / rho0 if bit == 4 else None
        what = what.format(fac=max_speed_factor, c0=c0,
                           val=float(np.nanmax(sp)) if sp is not None else 0.0,
                           lo=rho_ratio_band[0], hi=rho_ratio_band[1],
                           dmin=float(ratio.min()) if ratio is not None else 0.0,
                           dmax=float(ratio.max()) if ratio is not None else 0.0)
        first = int(np.flatnonzero(hit)[0])
        parts.append(f"{cnt} fluid particle(s) with {what} (first index {first}); "
                     f"likely cause: {cause}")
    raise SimulationStopped(f"fluid stopped at step {step}, t = {t:.6g} s: " + "; ".join(parts))
